"""A lean WebSocket load generator for ``shlight bench --sections server``.

Many clients per process on raw sockets (one epoll loop, no asyncio, no per-client task):
each does the opening handshake, reads frames, answers pings, and for every ``sh9``
message parses only its ``"time"`` field (frame-to-client latency = receive time − the
frame's capture time). Clients are spread over several worker processes, each pinned to
the CPUs given (the server has its own), and driven by the parent over a pipe:
``connect`` (open more clients), ``measure`` (count messages and latencies between two
wall-clock times), ``quit``.

The cost per message is what a client must pay anyway (a recv and a frame header), so the
generator saturates late; it reports its own CPU so that a saturated generator is seen.
"""
from __future__ import annotations

import base64
import multiprocessing
import os
import re
import selectors
import socket
import time
from array import array

_TIME = re.compile(rb'"time":([0-9.eE+-]+)')
_SH9 = b'{"type":"sh9"'


class _Client:
    __slots__ = ("sock", "buf", "count", "alive")

    def __init__(self, sock):
        self.sock, self.buf, self.count, self.alive = sock, bytearray(), 0, True


def _handshake(host: str, port: int, path: str, timeout: float) -> tuple[socket.socket, bytes]:
    sock = socket.create_connection((host, port), timeout=timeout)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    key = base64.b64encode(os.urandom(16)).decode()
    sock.sendall((f"GET {path} HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                  f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\n"
                  "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    data = b""
    while b"\r\n\r\n" not in data:
        chunk = sock.recv(65536)
        if not chunk:
            raise ConnectionError("closed during the handshake")
        data += chunk
    head, _, rest = data.partition(b"\r\n\r\n")
    if not head.startswith(b"HTTP/1.1 101"):
        raise ConnectionError(head.split(b"\r\n", 1)[0].decode(errors="replace"))
    sock.setblocking(False)
    return sock, rest


def _frames(c: _Client, now: float, record: bool, lats: array) -> None:
    """Consume the complete frames in ``c.buf``."""
    buf = c.buf
    pos, end = 0, len(buf)
    while end - pos >= 2:
        b1 = buf[pos + 1] & 0x7F
        if b1 < 126:
            hdr, n = 2, b1
        elif b1 == 126:
            if end - pos < 4:
                break
            hdr, n = 4, (buf[pos + 2] << 8) | buf[pos + 3]
        else:
            if end - pos < 10:
                break
            hdr, n = 10, int.from_bytes(buf[pos + 2: pos + 10], "big")
        if end - pos < hdr + n:
            break
        op = buf[pos] & 0x0F
        start = pos + hdr
        if op == 1:
            if record and buf.startswith(_SH9, start):
                m = _TIME.search(buf, start, start + n)
                if m:
                    lats.append(now - float(m.group(1)))
                    c.count += 1
        elif op == 9 and n <= 125:            # ping: answer with a (masked) pong
            payload = bytes(buf[start: start + n])
            try:
                c.sock.send(bytes([0x8A, 0x80 | n, 0, 0, 0, 0]) + payload)
            except OSError:
                pass
        elif op == 8:
            c.alive = False
        pos = start + n
    if pos:
        del buf[:pos]


def _worker(pipe, host: str, port: int, path: str, cpus) -> None:
    if cpus:
        try:
            os.sched_setaffinity(0, cpus)
        except OSError:
            pass
    if os.geteuid() == 0:            # as the server does in the bench: ahead of other work
        try:
            os.nice(-10)
        except OSError:
            pass
    sel = selectors.DefaultSelector()
    sel.register(pipe.fileno(), selectors.EVENT_READ, None)
    clients: list[_Client] = []
    lats = array("d")
    window = (0.0, 0.0)
    cpu_at = None

    def handle_command():
        nonlocal window, lats, cpu_at
        cmd, *args = pipe.recv()
        if cmd == "connect":
            want, errors = args[0], []
            for _ in range(want):
                try:
                    sock, rest = _handshake(host, port, path, 30.0)
                except (OSError, ConnectionError) as exc:
                    errors.append(str(exc))
                    continue
                c = _Client(sock)
                c.buf += rest
                clients.append(c)
                sel.register(sock, selectors.EVENT_READ, c)
            pipe.send(("connected", len(clients), errors[:3], len(errors)))
        elif cmd == "measure":
            window = (args[0], args[1])
            lats = array("d")
            for c in clients:
                c.count = 0
            cpu_at = None
        elif cmd == "quit":
            return False
        return True

    running = True
    while running:
        events = sel.select(0.05)
        now = time.time()
        t0, t1 = window
        record = t0 <= now < t1
        if record and cpu_at is None:
            cpu_at = sum(os.times()[:2])
        for key, _ in events:
            c = key.data
            if c is None:
                running = handle_command()
                continue
            try:
                chunk = c.sock.recv(262144)
            except BlockingIOError:
                continue
            except OSError:
                chunk = b""
            if not chunk:
                c.alive = False
            else:
                c.buf += chunk
                _frames(c, now, record, lats)
            if not c.alive:
                sel.unregister(c.sock)
                c.sock.close()
        if t1 and now >= t1 and cpu_at is not None:
            cpu = sum(os.times()[:2]) - cpu_at
            pipe.send(("measured", [c.count if c.alive else -1 for c in clients],
                       lats.tobytes(), cpu))
            window, cpu_at = (0.0, 0.0), None
    for c in clients:
        c.sock.close()


class LoadGenerator:
    """``procs`` worker processes on ``cpus``; clients are spread evenly over them."""

    def __init__(self, host: str, port: int, path: str = "/", procs: int = 2, cpus=None):
        ctx = multiprocessing.get_context("spawn")
        self.workers = []
        for _ in range(procs):
            parent, child = ctx.Pipe()
            p = ctx.Process(target=_worker, args=(child, host, port, path, cpus), daemon=True)
            p.start()
            self.workers.append((p, parent))
        self.clients = 0

    def connect(self, total: int) -> list[str]:
        """Open clients until ``total`` are connected; returns a few error texts."""
        need = total - self.clients
        errors: list[str] = []
        if need <= 0:
            return errors
        per = [need // len(self.workers) + (i < need % len(self.workers))
               for i in range(len(self.workers))]
        for (_, pipe), n in zip(self.workers, per):
            pipe.send(("connect", n))
        connected = 0
        for _, pipe in self.workers:
            _, count, errs, _ = pipe.recv()
            connected += count
            errors += errs
        self.clients = connected
        return errors

    def measure(self, seconds: float, lead: float = 0.2):
        """(per-client message counts, latencies in s, load generator CPU seconds) over
        the next ``seconds``."""
        t0 = time.time() + lead
        t1 = t0 + seconds
        for _, pipe in self.workers:
            pipe.send(("measure", t0, t1))
        counts, lats, cpu = [], array("d"), 0.0
        for _, pipe in self.workers:
            if not pipe.poll(seconds + lead + 60):
                raise RuntimeError("a load generator process did not answer")
            _, c, raw, used = pipe.recv()
            counts += c
            lats.frombytes(raw)
            cpu += used
        return counts, lats, cpu

    def close(self) -> None:
        for p, pipe in self.workers:
            try:
                pipe.send(("quit",))
            except OSError:
                pass
        for p, _ in self.workers:
            p.join(10)
            if p.is_alive():
                p.kill()
