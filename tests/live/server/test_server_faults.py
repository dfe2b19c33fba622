"""``shlight serve`` under faults and hostile clients (issue 22): a malformed relay
upstream, flooding clients, the rate cap against a steady source, the open-files limit,
DNS rebinding, corrupt files in a sequence, many frame sizes, repeated warnings, HTTP
methods.

Real servers and real clients on loopback (tests/servertools.py); behaviour is asserted,
never a duration.
"""
from __future__ import annotations

import asyncio
import json
import logging
import os
from pathlib import Path
import resource
import socket
import statistics
import threading
import time

import cv2
import numpy as np
import pytest
from websockets.exceptions import ConnectionClosed

from servertools import (ServeProcess, ServerThread, connect, health, http_get, metric, poll,
                         recv_json, recv_until)

HDRI = os.path.join(str(Path(__file__).resolve().parents[2]), "data", "hdri")
BRIDGE = os.path.join(HDRI, "bridge.exr")


def sh9(msg: dict) -> bool:
    return msg.get("type") == "sh9"


# ---- a fake relay upstream ---------------------------------------------------------------------

class FakeUpstream:
    """A WebSocket server that speaks like ``shlight serve`` (hello, then sh9 messages at
    ``hz``), in a thread; ``bad`` maps a message number to the fields that replace the
    valid ones in that message."""

    def __init__(self, template: dict, hz: float = 20.0, bad: dict | None = None):
        self.template, self.hz, self.bad = template, hz, dict(bad or {})
        self.sent = 0
        self.loop = asyncio.new_event_loop()
        self._ready = threading.Event()
        self._stop: asyncio.Event | None = None
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self):
        from websockets.asyncio.server import serve
        asyncio.set_event_loop(self.loop)

        async def handler(ws):
            await ws.send(json.dumps({"type": "hello", "version": 1, "probes": ["edge"]}))
            await ws.recv()                                  # the relay's subscribe
            while True:
                n = self.sent
                msg = dict(self.template, seq=n, time=time.time(), stale=False)
                scale = 1.0 + 0.01 * (n % 7)                 # lighting that changes
                msg["coefficients"] = [v * scale for v in self.template["coefficients"]]
                msg["matrices"] = [v * scale for v in self.template["matrices"]]
                msg.update(self.bad.get(n, {}))
                await ws.send(json.dumps(msg))
                self.sent += 1
                await asyncio.sleep(1.0 / self.hz)

        async def main():
            self._stop = asyncio.Event()
            async with serve(handler, "127.0.0.1", 0) as server:
                self.port = server.sockets[0].getsockname()[1]
                self._ready.set()
                await self._stop.wait()
        self.loop.run_until_complete(main())

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/?probe=edge"

    def __enter__(self):
        self.thread.start()
        self._ready.wait(10)
        return self

    def __exit__(self, *exc):
        self.loop.call_soon_threadsafe(self._stop.set)
        self.thread.join(10)


@pytest.fixture(scope="module")
def sh9_template():
    """A valid sh9 message of a real provider (the bridge panorama)."""
    with ServerThread("--source", BRIDGE) as srv:
        poll(lambda: srv.server.probes["default"].latest_message, what="lighting")
        msg = dict(srv.server.probes["default"].latest_message)
    msg["probe"] = "edge"
    return msg


@pytest.mark.parametrize("bad", [{"clipped_fraction": "x"}, {"coefficients": [1.0, 2.0]},
                                 {"min_irradiance": "oops"}, {"light_directions": [0.0]},
                                 {"order": [1]}])
def test_a_malformed_relay_message_is_one_rejected_frame(sh9_template, bad):
    with FakeUpstream(sh9_template, bad={3: bad}) as up:
        with ServerThread("--probe", f"pc={up.url}", "--change-threshold", "0",
                          "--keepalive", "0.3") as pc:
            poll(lambda: up.sent > 8, what="upstream messages")
            probe = pc.server.probes["pc"]
            poll(lambda: pc.call(lambda: probe.frames_rejected) == 1, what="one rejected frame")
            with connect(pc.url) as ws:
                recv_json(ws)
                first = recv_until(ws, lambda m: sh9(m) and not m["stale"])
                # the probe goes on: newer fresh messages keep coming after the bad one
                later = recv_until(ws, lambda m: sh9(m) and not m["stale"]
                                   and m["seq"] > first["seq"] + 5)
                assert later["source"] == "relay"
            h = health(pc.http)["probes"]["pc"]
            assert h["state"] == "live" and h["frames_rejected"] == 1 and h["running"]
            assert pc.call(lambda: probe.capture.reconnects) == 0      # not a lost source
            assert metric(pc.http, "shlight_probe_frames_rejected_total", probe="pc") == 1


class _FailingPublisher:
    """Another destination of every message (the MQTT publisher's interface) that fails
    on its ``fail_at``-th message."""

    kind = "failing"

    def __init__(self, fail_at: int):
        self.fail_at, self.offered = fail_at, 0

    def start(self, loop):
        pass

    def stop(self):
        pass

    def offer(self, probe, text):
        self.offered += 1
        if self.offered == self.fail_at:
            raise RuntimeError("a bug in a publisher")

    def health(self):
        return {"state": "connected"}

    def add_metrics(self, m):
        pass


def test_the_probe_loop_survives_any_error_and_a_stopped_probe_shows():
    with ServerThread("--source", "demo", "--change-threshold", "0") as srv:
        publisher = _FailingPublisher(fail_at=5)
        srv.call(lambda: srv.server.publishers.append(publisher))
        probe = srv.server.probes["default"]
        poll(lambda: publisher.offered > 20, what="messages after the failing one")
        assert srv.call(lambda: probe.loop_errors) == 1
        assert health(srv.http)["status"] == "ok"
        # a probe task that ends (here: cancelled from outside) is reported, not hidden
        srv.call(lambda: srv.server._tasks[0].cancel())
        poll(lambda: health(srv.http)["probes"]["default"]["state"] == "stopped",
             what="stopped probe in /healthz")
        h = health(srv.http)
        assert h["status"] == "degraded" and not h["probes"]["default"]["running"]
        assert metric(srv.http, "shlight_probe_running", probe="default") == 0
        assert metric(srv.http, "shlight_probe_up", probe="default") == 0


# ---- flooding clients ----------------------------------------------------------------------------

def _reader(url: str, out: list, stop: threading.Event):
    with connect(url) as ws:
        recv_json(ws)
        while not stop.is_set():
            try:
                msg = recv_json(ws, timeout=5)
            except TimeoutError:
                out.append("timeout")
                continue
            if sh9(msg):
                out.append(msg["seq"])


@pytest.mark.parametrize("kind", ["json", "ping-frames"])
def test_a_flooding_client_is_limited_and_the_others_untouched(kind):
    with ServerThread("--source", "demo", "--fps", "30", "--change-threshold", "0") as srv:
        stop = threading.Event()
        seen = [[] for _ in range(5)]
        readers = [threading.Thread(target=_reader, args=(srv.url, s, stop), daemon=True)
                   for s in seen]
        for t in readers:
            t.start()
        poll(lambda: all(len(s) >= 3 for s in seen), what="readers receiving")
        before = [len(s) for s in seen]
        with connect(srv.url, max_queue=None) as flooder:
            recv_json(flooder)
            sent, pongs = 0, 0
            with pytest.raises(ConnectionClosed):
                while sent < 200_000:
                    if kind == "json":
                        flooder.send('{"type":"ping","id":1}')
                    else:
                        flooder.ping()
                    sent += 1
                while True:                        # what came back before the close
                    msg = json.loads(flooder.recv(timeout=10))
                    pongs += msg.get("type") == "pong"
            # policy violation (1008); a flooder whose socket is still full when the server
            # gives up on the closing handshake sees the TCP close without the frame: the
            # server-side count below says why in both cases
            rcvd = flooder.protocol.close_rcvd
            assert rcvd is None or rcvd.code == 1008
        assert pongs <= 100                      # the budget, not the flood, set the replies
        # the others kept their stream all along and still have it
        poll(lambda: all(len(s) >= b + 10 for s, b in zip(seen, before)),
             what="the other clients' messages")
        poll(lambda: srv.call(lambda: len(srv.server.clients)) == 5, what="the flooder gone")
        stop.set()
        for t in readers:
            t.join(10)
        for s in seen:
            seqs = [x for x in s if x != "timeout"]
            assert "timeout" not in s and seqs == sorted(seqs)
        assert srv.call(lambda: srv.server.limit_counters.policy_closes) == 1
        assert metric(srv.http, "shlight_client_policy_closes_total") == 1


#: An address of this machine that --connect-rate limits (it exempts 127.0.0.1 and ::1).
OTHER_ADDRESS = "127.0.0.2"


def _from_other_address(port: int) -> socket.socket:
    try:
        return socket.create_connection(("127.0.0.1", port), timeout=10,
                                        source_address=(OTHER_ADDRESS, 0))
    except OSError as exc:
        pytest.skip(f"cannot connect from {OTHER_ADDRESS} here (not Linux?): {exc}")


def test_an_address_past_the_connect_rate_waits_its_turn_or_gets_429():
    """A client that opens WebSocket connections faster than --connect-rate (after its
    burst of 10) is held until its turn, at most 2 s and 4 at once, then let in or refused
    with HTTP 429 and Retry-After, counted; its open connections, its plain HTTP requests
    and other addresses are untouched. 127.0.0.1 (this machine's programs, a reverse
    proxy) is never limited."""
    import concurrent.futures
    import contextlib
    import http.client
    from websockets.exceptions import InvalidStatus

    def burst(proc, stack):
        """The burst's 10 connections from 127.0.0.2, held open."""
        held = [stack.enter_context(connect(proc.url, sock=_from_other_address(proc.port)))
                for _ in range(10)]
        for ws in held:
            recv_json(ws)
        return held

    def attempt(proc, timeout=10):
        """(seconds, the response of a refusal or None) of one handshake from 127.0.0.2."""
        t0 = time.monotonic()
        try:
            with connect(proc.url, sock=_from_other_address(proc.port),
                         open_timeout=timeout) as ws:
                assert recv_json(ws)["type"] == "hello"
            return time.monotonic() - t0, None
        except InvalidStatus as exc:
            return time.monotonic() - t0, exc.response

    with ServeProcess("--source", "demo", "--connect-rate", "0.1") as proc, \
            contextlib.ExitStack() as stack:
        held = burst(proc, stack)
        # the next one's turn is 10 s away: held for 2 s, then 429 with the rest to wait
        seconds, refused = attempt(proc)
        assert refused is not None and refused.status_code == 429 and seconds >= 1.9
        assert 7 <= int(refused.headers["Retry-After"]) <= 9
        assert b"too many WebSocket connections from 127.0.0.2" in refused.body
        assert b"--connect-rate" in refused.body
        # five at once: four are held, the fifth is refused without waiting
        with concurrent.futures.ThreadPoolExecutor(5) as pool:
            results = list(pool.map(lambda _: attempt(proc), range(5)))
        assert all(r is not None and r.status_code == 429 for _, r in results)
        assert sorted(s > 1.9 for s, _ in results) == [False, True, True, True, True]
        assert metric(proc.http, "shlight_rejected_connections_total",
                      reason="connect_rate") == 6
        for _ in range(25):                  # loopback: never limited
            with connect(proc.url) as ws:
                assert recv_json(ws)["type"] == "hello"
        recv_until(held[0], sh9)             # what it holds keeps its lighting
        page = http.client.HTTPConnection("127.0.0.1", proc.port, timeout=10,
                                          source_address=(OTHER_ADDRESS, 0))
        page.request("GET", "/healthz")      # plain HTTP is not counted
        assert page.getresponse().status == 200
        page.close()
        assert proc.proc.poll() is None and "Traceback" not in proc.output
        assert "refused 127.0.0.2" in proc.output
    # a turn within 2 s (2 s less the burst's own time): held, then let in
    with ServeProcess("--source", "demo", "--connect-rate", "0.5") as proc, \
            contextlib.ExitStack() as stack:
        burst(proc, stack)
        seconds, refused = attempt(proc)
        assert refused is None and 0.5 <= seconds, seconds
        assert b'reason="connect_rate"' not in http_get(proc.http + "/metrics")[2]


def test_the_connect_rate_table_stays_small():
    """Many addresses, each within its burst: the table forgets those whose bucket is full
    again, and never holds more than its bound; exempt addresses are never in it."""
    from provider.live.server.limits import ConnectRate
    rate = ConnectRate(rate=2.0, burst=20.0, max_addresses=100)
    t = 1000.0
    for _ in range(20):
        assert rate.retry_after("10.9.9.9", now=t) == 0.0
    assert rate.retry_after("10.9.9.9", now=t) == pytest.approx(0.5)
    assert rate.retry_after("10.9.9.9", now=t + 0.25) == pytest.approx(0.25)  # no lock-out
    for i in range(5000):                   # one new address every 10 ms
        t += 0.01
        assert rate.retry_after(f"10.0.{i // 250}.{i % 250}", now=t) == 0.0
        assert len(rate) <= 100
        if i == 150:                        # pruned twice by now: the busy one is kept
            assert "10.9.9.9" in rate._buckets and "10.0.0.0" not in rate._buckets
    assert rate.retry_after("127.0.0.1", now=t) == 0.0 and "127.0.0.1" not in rate._buckets
    assert ConnectRate(rate=0.0, burst=10.0).retry_after("10.0.0.1") == 0.0   # 0: no limit


def test_a_client_under_its_budget_is_answered_in_full():
    with ServerThread("--source", BRIDGE) as srv, connect(srv.url) as ws:
        recv_json(ws)
        ids = []
        for burst in range(4):                   # 40 messages at once: within the budget
            for i in range(10):
                ws.send(json.dumps({"type": "ping", "id": 10 * burst + i}))
            for _ in range(10):
                ids.append(recv_until(ws, lambda m: m["type"] == "pong")["id"])
        assert ids == list(range(40))
        assert srv.call(lambda: srv.server.limit_counters.frames_dropped) == 0


# ---- the rate cap ------------------------------------------------------------------------------------

def _steady_seqs(srv, hz: float, n: int) -> tuple[list[int], int]:
    """(seqs of ``n`` messages to a client with ``max_hz=hz``, after a warm-up of 20; how
    many of those ``n`` waited for their turn)."""
    with connect(srv.url + f"?max_hz={hz}") as ws:
        recv_json(ws)
        for _ in range(20):                      # past the burst of connecting
            recv_until(ws, sh9)
        held = srv.call(lambda: srv.server.counters.messages_held)
        seqs = [recv_until(ws, sh9)["seq"] for _ in range(n)]
        return seqs, srv.call(lambda: srv.server.counters.messages_held) - held


def test_max_hz_at_the_source_rate_skips_nothing_and_below_it_is_even():
    """A cap at (or above) the source's rate passes its messages as they come, although the
    frames jitter (a loaded machine: a few may bunch up); below it, the newest every
    30/hz frames."""
    with ServerThread("--source", "demo", "--fps", "30", "--change-threshold", "0") as srv:
        for hz in (30, 45):
            seqs, held = _steady_seqs(srv, hz, 60)
            gaps = np.diff(seqs)
            # beside a CPU hog the source's frames bunch up (several within one 1/hz): the
            # cap then passes the newest, so allow a fifth of gaps; a cap that locked onto the
            # frames' phase would skip or hold most of them
            assert np.count_nonzero(gaps == 1) >= 0.8 * len(gaps), (hz, gaps)
            assert held <= 12, (hz, held)
        seqs, _ = _steady_seqs(srv, 10, 20)
        gaps = np.diff(seqs)
        assert statistics.median(gaps) == 3 and np.count_nonzero(gaps == 1) <= 2, gaps


# ---- the open-files limit --------------------------------------------------------------------

def _limit_files(soft: int, hard: int):
    def preexec():
        resource.setrlimit(resource.RLIMIT_NOFILE, (soft, hard))
    return preexec


def _handshake(port: int, host: str | None = None) -> tuple[socket.socket, bytes]:
    s = socket.create_connection(("127.0.0.1", port), timeout=20)
    s.sendall((f"GET / HTTP/1.1\r\nHost: {host or f'127.0.0.1:{port}'}\r\n"
               "Upgrade: websocket\r\nConnection: Upgrade\r\n"
               "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
               "Sec-WebSocket-Version: 13\r\n\r\n").encode())
    head = b""
    while b"\r\n\r\n" not in head:
        chunk = s.recv(1)
        if not chunk:
            break
        head += chunk
    return s, head


def test_more_clients_than_open_files_get_a_clean_503():
    with ServeProcess("--source", BRIDGE, "--max-clients", "1000",
                      preexec_fn=_limit_files(96, 160)) as proc:
        h = health(proc.http)
        assert h["open_files_limit"] == 160                  # soft raised to hard
        capacity = h["max_clients"]
        assert 10 < capacity < 160 and h["max_clients_requested"] == 1000
        assert "max-clients" in proc.output and "open files" in proc.output
        socks, statuses = [], []
        try:
            for _ in range(capacity + 40):
                s, head = _handshake(proc.port)
                statuses.append(head.split(b" ")[1] if head else b"reset")
                if statuses[-1] == b"101":
                    socks.append(s)
                else:
                    s.close()
            assert statuses.count(b"101") == capacity
            assert set(statuses) == {b"101", b"503"}, set(statuses)
            assert health(proc.http)["clients"] == capacity
        finally:
            for s in socks:
                s.close()
        poll(lambda: health(proc.http)["clients"] == 0, what="clients gone")
        with connect(proc.url) as ws:
            assert recv_json(ws)["type"] == "hello"
        assert "Traceback" not in proc.output
        assert proc.output.count("refused") < 5               # said once, with a count


# ---- DNS rebinding -----------------------------------------------------------------------------

def test_host_allow_list_refuses_rebinding_names():
    with ServerThread("--source", BRIDGE, "--allow-host", "lights.example",
                      "--allow-host", ".studio.example") as srv:
        port = srv.port
        poll(lambda: http_get(srv.http + "/latest.json")[0] == 200, what="lighting")
        for host in ("evil.example", f"evil.example:{port}", "127.0.0.1.evil.example",
                     "sub.lights.example", "localhost.evil.example"):
            assert http_get(srv.http + "/latest.json", {"Host": host})[0] == 421, host
            s, head = _handshake(port, host)
            s.close()
            assert head.startswith(b"HTTP/1.1 421"), (host, head)
        for host in (f"127.0.0.1:{port}", f"localhost:{port}", "[::1]:80", "lights.example",
                     "studio.example", "a.studio.example", "x.localhost", "192.168.1.7"):
            assert http_get(srv.http + "/latest.json", {"Host": host})[0] == 200, host
        s, head = _handshake(port, f"localhost:{port}")
        s.close()
        assert head.startswith(b"HTTP/1.1 101")
        assert srv.call(lambda: srv.server.counters.rejected["host"]) == 10


# ---- files: a corrupt one in a sequence, many sizes ---------------------------------------------

def _write_png(path, value, size=(64, 32)):
    img = np.zeros((size[1], size[0], 3), np.uint8)
    img[:] = value
    img[: size[1] // 4] = 255
    assert cv2.imwrite(str(path), img)


def test_a_corrupt_file_in_a_sequence_is_skipped_counted_and_remembered(tmp_path, caplog):
    caplog.set_level(logging.INFO)
    _write_png(tmp_path / "a.png", (40, 40, 40))
    (tmp_path / "b.png").write_bytes(b"\x89PNG\r\n\x1a\n" + os.urandom(200))
    _write_png(tmp_path / "c.png", (200, 90, 30))
    with ServerThread("--source", str(tmp_path), "--fps", "20", "--change-threshold", "0") as srv:
        probe = srv.server.probes["default"]
        with connect(srv.url) as ws:
            recv_json(ws)
            seen = set()
            while len(seen) < 2:
                seen.add(tuple(recv_until(ws, sh9)["coefficients"][:3]))
        poll(lambda: srv.call(lambda: probe.frames_processed) >= 12, what="several loops")
        h = health(srv.http)["probes"]["default"]
        assert h["frames_rejected"] == 1                 # decoded once, not every loop
        assert list(h["bad_files"]) == [str(tmp_path / "b.png")]
        assert h["state"] == "live" and h["reconnects"] == 0
        assert sum("b.png" in r.getMessage() for r in caplog.records
                   if r.levelno >= logging.WARNING) == 1
        # fixed in place: read again, and no longer listed
        _write_png(tmp_path / "b.png", (10, 200, 10))
        poll(lambda: not health(srv.http)["probes"]["default"]["bad_files"],
             what="the repaired file read")


def test_a_corrupt_replacement_of_an_image_keeps_the_last_one_and_says_so_once(tmp_path, caplog):
    caplog.set_level(logging.INFO)
    path = tmp_path / "room.png"
    _write_png(path, (90, 90, 90))
    with ServerThread("--source", str(path), "--fps", "30") as srv:
        probe = srv.server.probes["default"]
        poll(lambda: srv.call(lambda: probe.frames_processed) >= 2, what="frames")
        path.write_bytes(b"\x89PNG\r\n\x1a\n" + os.urandom(100))
        poll(lambda: health(srv.http)["probes"]["default"]["bad_files"], what="reported")
        frames = srv.call(lambda: probe.frames_processed)
        poll(lambda: srv.call(lambda: probe.frames_processed) >= frames + 20, what="frames")
        assert health(srv.http)["probes"]["default"]["state"] == "live"
        assert sum("room.png" in r.getMessage() for r in caplog.records
                   if r.levelno >= logging.WARNING) == 1


def test_many_frame_sizes_keep_a_few_projectors(tmp_path):
    for i in range(10):
        _write_png(tmp_path / f"{i:02d}.png", (50 + 10 * i, 60, 70), size=(32 + 8 * i, 16 + 4 * i))
    with ServerThread("--source", str(tmp_path), "--fps", "30", "--no-loop") as srv:
        probe = srv.server.probes["default"]
        sizes = set()
        while srv.call(lambda: probe.frames_processed) < 10:
            sizes.add(srv.call(lambda: len(probe._projectors)))
            time.sleep(0.01)
        assert max(sizes) <= 4
        assert srv.call(lambda: list(probe._projectors)[-1]) == (32 + 8 * 9, 16 + 4 * 9)


# ---- log lines -------------------------------------------------------------------------------------

def test_identical_warnings_are_said_once_with_a_count():
    from provider.live.server.limits import RepeatFilter
    records = []

    class Keep(logging.Handler):
        def emit(self, record):
            records.append(self.format(record))
    handler = Keep()
    flt = RepeatFilter(interval=3600)
    handler.addFilter(flt)
    logger = logging.getLogger("shlight.test-repeat")
    logger.addHandler(handler)
    logger.propagate = False
    try:
        for i in range(500):
            logger.warning("refused %s: missing or wrong token", f"127.0.0.1:{i}")
        logger.warning("something else")
        assert records == ["refused 127.0.0.1:0: missing or wrong token", "something else"]
        flt.interval = 0.0                       # the window is over
        logger.warning("refused %s: missing or wrong token", "127.0.0.1:9")
        assert records[-1] == ("refused 127.0.0.1:9: missing or wrong token "
                               "(and 499 more like this in the last 0 s)")
        flt.interval = 3600
        # What a line is about keeps its own line: another probe, another file, another
        # address (issue 33: probe b's failure never reached the log); counts do not.
        logger.warning("probe %s: source failed: %s", "a", "no such camera")
        logger.warning("probe %s: source failed: %s", "b", "no such camera")
        logger.warning("probe %s: %s is corrupt", "a", "seq/0001.png")
        logger.warning("probe %s: %s is corrupt", "a", "seq/0002.png")
        logger.warning("refused %s: missing or wrong token", "192.168.1.7:4000")
        for n in range(5):
            logger.warning("refused %s: %d clients connected", "127.0.0.1:1", 500 + n)
        assert records[-6:] == [
            "probe a: source failed: no such camera", "probe b: source failed: no such camera",
            "probe a: seq/0001.png is corrupt", "probe a: seq/0002.png is corrupt",
            "refused 192.168.1.7:4000: missing or wrong token",
            "refused 127.0.0.1:1: 500 clients connected"]
    finally:
        logger.removeHandler(handler)


def test_refused_requests_do_not_flood_the_log():
    with ServeProcess("--source", BRIDGE, "--token", "s3cret") as proc:
        for _ in range(200):
            assert http_get(proc.http + "/latest.json")[0] == 401
        poll(lambda: "refused" in proc.output, what="the first line")
        assert proc.output.count("missing or wrong token") == 1


# ---- HTTP methods ------------------------------------------------------------------------------------

def _raw_http(port: int, request: bytes) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=10) as s:
        s.sendall(request)
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    return data


def test_head_other_methods_and_bodies():
    with ServerThread("--source", BRIDGE) as srv:
        poll(lambda: http_get(srv.http + "/latest.json")[0] == 200, what="lighting")
        get = _raw_http(srv.port, b"GET /latest.json HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        head = _raw_http(srv.port, b"HEAD /latest.json HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n")
        head_part, _, body = head.partition(b"\r\n\r\n")
        assert head.startswith(b"HTTP/1.1 200") and body == b""
        length = int(head_part.lower().split(b"content-length: ")[1].split(b"\r\n")[0])
        assert length == len(get.partition(b"\r\n\r\n")[2]) > 0
        for method in (b"POST", b"PUT", b"DELETE", b"OPTIONS"):
            answer = _raw_http(srv.port, method + b" /latest.json HTTP/1.1\r\n"
                                                  b"Host: 127.0.0.1\r\n\r\n")
            assert answer.startswith(b"HTTP/1.1 405"), answer[:40]
            assert b"allow: get, head" in answer.lower()
        answer = _raw_http(srv.port, b"POST /latest.json HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                                     b"Content-Length: 5\r\n\r\nhello")
        assert answer.startswith(b"HTTP/1.1 400"), answer[:40]
        answer = _raw_http(srv.port, b"GET / HTTP/1.1\r\nHost: 127.0.0.1\r\n"
                                     b"Transfer-Encoding: chunked\r\n\r\n0\r\n\r\n")
        assert answer.startswith(b"HTTP/1.1 400"), answer[:40]


def test_a_tls_hello_on_the_plain_port_is_answered_at_once():
    """wss:// to a server without TLS: the head of a TLS handshake is not HTTP, so the
    server answers (400) without waiting for a header block that never comes; clients then
    say "does not serve wss://" instead of timing out."""
    import socket
    import ssl
    with ServerThread("--source", BRIDGE) as srv:
        port = int(srv.url.rsplit(":", 1)[1].strip("/"))
        ctx = ssl.create_default_context()
        ctx.check_hostname, ctx.verify_mode = False, ssl.CERT_NONE
        with socket.create_connection(("127.0.0.1", port), timeout=5) as raw:
            with pytest.raises((ssl.SSLError, OSError)) as err:
                ctx.wrap_socket(raw, server_hostname="localhost")
        assert not isinstance(err.value, TimeoutError), "the server waited for a head"
