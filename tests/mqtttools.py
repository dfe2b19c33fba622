"""A real mosquitto broker on loopback for the MQTT tests, a subscriber, and a TCP relay
that can stop forwarding (a slow broker or a congested link)."""
from __future__ import annotations

import json
import os
import select
import shutil
import socket
import subprocess
import threading
import time
from pathlib import Path

from provider.bench.common import stop as stop_process
from servertools import poll

MOSQUITTO = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
MOSQUITTO_PASSWD = shutil.which("mosquitto_passwd") or "/usr/bin/mosquitto_passwd"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _accepts(port: int) -> bool:
    try:
        socket.create_connection(("127.0.0.1", port), timeout=1).close()
        return True
    except OSError:
        return False


class Mosquitto:
    """``mosquitto -c CONF`` on 127.0.0.1:``port`` (no persistence: a restart forgets the
    retained messages, as a broker that crashed would). ``start()``/``stop()`` may be
    called again: the port stays the same."""

    def __init__(self, folder: Path, *, tls: tuple[Path, Path] | None = None,
                 users: dict[str, str] | None = None):
        self.folder, self.port = Path(folder), free_port()
        self.proc: subprocess.Popen | None = None
        lines = [f"listener {self.port} 127.0.0.1", "persistence false",
                 f"allow_anonymous {'false' if users else 'true'}"]
        if os.geteuid() == 0:      # as root it would switch to user mosquitto, who cannot
            lines.append("user root")   # read pytest's private tmp dir
        if tls:
            lines += [f"certfile {tls[0]}", f"keyfile {tls[1]}"]
        if users:
            pw = self.folder / "passwords"
            pw.write_text("")
            for user, password in users.items():
                subprocess.run([MOSQUITTO_PASSWD, "-b", str(pw), user, password], check=True,
                               capture_output=True)
            os.chmod(pw, 0o600)
            lines.append(f"password_file {pw}")
        self.conf = self.folder / f"mosquitto-{self.port}.conf"
        self.conf.write_text("\n".join(lines) + "\n")
        self.log = self.folder / f"mosquitto-{self.port}.log"

    def start(self) -> "Mosquitto":
        with open(self.log, "ab") as log:
            self.proc = subprocess.Popen([MOSQUITTO, "-c", str(self.conf)], stdout=log,
                                         stderr=subprocess.STDOUT)
        poll(lambda: self.proc.poll() is not None or _accepts(self.port), timeout=20,
             what="mosquitto to listen")
        assert self.proc.poll() is None, self.log.read_text()
        return self

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            stop_process(self.proc, 10)

    def __enter__(self) -> "Mosquitto":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


class Subscriber:
    """A paho client subscribed to ``topic``; ``messages`` collects (topic, retained,
    payload bytes) in arrival order."""

    def __init__(self, port: int, topic: str, *, tls_ca: Path | None = None,
                 username: str | None = None, password: str | None = None,
                 host: str = "127.0.0.1"):
        import paho.mqtt.client as paho
        self.messages: list[tuple[str, bool, bytes]] = []
        self.client = c = paho.Client(paho.CallbackAPIVersion.VERSION2)
        if tls_ca:
            c.tls_set(ca_certs=str(tls_ca))
        if username:
            c.username_pw_set(username, password)
        c.on_connect = lambda client, u, f, rc, p: client.subscribe(topic, qos=0)
        c.on_message = lambda client, u, msg: self.messages.append(
            (msg.topic, bool(msg.retain), bytes(msg.payload)))
        c.connect(host, port, keepalive=30)
        c.loop_start()

    def first(self, topic: str, timeout: float = 20.0) -> tuple[bool, bytes]:
        """(retained, payload) of the first message on ``topic``."""
        found = poll(lambda: next(((r, p) for t, r, p in list(self.messages) if t == topic),
                                  None), timeout=timeout, what=f"a message on {topic}")
        return found

    def retained(self, topic: str, timeout: float = 20.0) -> bytes:
        """The payload of the retained message the broker sent on subscribing. It is not
        always the first on ``topic``: a live publish that reaches the broker while the
        subscription is being made may be delivered before it (seen under load)."""
        return poll(lambda: next((p for t, r, p in list(self.messages) if t == topic and r),
                                 None), timeout=timeout, what=f"the retained message on {topic}")

    def latest_seq(self, topic: str) -> int | None:
        seqs = [json.loads(p)["seq"] for t, _, p in list(self.messages) if t == topic]
        return max(seqs) if seqs else None

    def close(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()

    def __enter__(self) -> "Subscriber":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class PausableRelay:
    """A TCP relay 127.0.0.1:``port`` → 127.0.0.1:``target`` whose client→broker
    direction can be paused: while paused it reads nothing from the client (small socket
    buffers, so the client's writes back up within seconds), like a broker that stopped
    reading or a congested link."""

    BUFFER = 4096

    def __init__(self, target: int):
        self.target = target
        self.paused = threading.Event()
        self._closed = False
        self._listener = socket.socket()
        self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self.BUFFER)
        self._listener.bind(("127.0.0.1", 0))
        self._listener.listen()
        self.port = self._listener.getsockname()[1]
        self._threads = [threading.Thread(target=self._accept, daemon=True)]
        self._threads[0].start()

    def _accept(self) -> None:
        while not self._closed:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            client.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, self.BUFFER)
            try:
                upstream = socket.create_connection(("127.0.0.1", self.target), timeout=5)
            except OSError:
                client.close()
                continue
            for a, b, pausable in ((client, upstream, True), (upstream, client, False)):
                t = threading.Thread(target=self._pump, args=(a, b, pausable), daemon=True)
                t.start()
                self._threads.append(t)

    def _pump(self, src: socket.socket, dst: socket.socket, pausable: bool) -> None:
        try:
            while not self._closed:
                if pausable and self.paused.is_set():
                    time.sleep(0.02)
                    continue
                ready, _, _ = select.select([src], [], [], 0.05)
                if not ready:
                    continue
                data = src.recv(65536)
                if not data:
                    break
                dst.sendall(data)
        except OSError:
            pass
        finally:
            for s in (src, dst):
                try:
                    s.shutdown(socket.SHUT_RDWR)
                except OSError:
                    pass

    def close(self) -> None:
        self._closed = True
        self._listener.close()
