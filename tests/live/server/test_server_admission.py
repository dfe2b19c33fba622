"""Connections that send nothing must not lock the headsets out (issue 29, High).

Each test floods a real ``shlight serve`` on loopback with real TCP connections that never
send a byte, reopened as the server cuts them (as a device on the LAN could, without the
token), while a client with the token and a monitor's ``/healthz`` keep trying. Before the
fix, 600 such sockets made 29 of 30 of those tries fail with HTTP 503 "too many
connections": the early refusal counted connections still waiting for their request.
"""
from __future__ import annotations

import json
import resource
import selectors
import socket
import threading
import time

import pytest

from servertools import ServeProcess, connect, http_get, metric, poll, recv_json

TOKEN = "s3cret-token"
#: An address of this machine that the per-address rules apply to (127.0.0.1 is exempt).
OTHER_ADDRESS = "127.0.0.2"


class IdleFlood:
    """Up to ``count`` TCP connections from ``source`` to ``port`` that never send a byte,
    each reopened when the server cuts it (at most ``rate`` connects a second), in a thread,
    for at most ``limit_s`` seconds (bounded: it stops by itself)."""

    def __init__(self, port: int, count: int, source: str = OTHER_ADDRESS, rate: float = 200.0,
                 limit_s: float = 120.0):
        self.port, self.count, self.source, self.rate = port, count, source, rate
        self.deadline = time.monotonic() + limit_s
        self.opened = self.cut = self.refused = 0
        self.held_max = 0
        self._stop = threading.Event()
        self._full = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True, name="idle-flood")

    def __enter__(self) -> "IdleFlood":
        try:
            probe = socket.create_connection(("127.0.0.1", self.port), timeout=5,
                                             source_address=(self.source, 0))
            probe.close()
        except OSError as exc:
            pytest.skip(f"cannot connect from {self.source} here (not Linux?): {exc}")
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join(30)

    def wait_until_full_or_churning(self, timeout: float = 60.0) -> None:
        """Until the flood holds ``count`` sockets or has had at least ``count`` cut."""
        poll(lambda: self._full.is_set() or self.cut >= self.count, timeout,
             what=f"{self.count} idle sockets opened or cut")

    def _run(self) -> None:
        sel = selectors.DefaultSelector()
        held = 0
        pause = 1.0 / self.rate
        try:
            while not self._stop.is_set() and time.monotonic() < self.deadline:
                if held < self.count:
                    try:
                        s = socket.create_connection(("127.0.0.1", self.port), timeout=2,
                                                     source_address=(self.source, 0))
                        s.setblocking(False)
                        sel.register(s, selectors.EVENT_READ)
                        held += 1
                        self.opened += 1
                        self.held_max = max(self.held_max, held)
                    except OSError:
                        self.refused += 1
                    if held >= self.count:
                        self._full.set()
                # sockets the server closed read as EOF (or a reset): reopen them
                for key, _ in sel.select(timeout=pause):
                    s = key.fileobj
                    try:
                        data = s.recv(4096)
                    except (BlockingIOError, InterruptedError):
                        continue
                    except OSError:
                        data = b""
                    if not data:
                        sel.unregister(s)
                        s.close()
                        held -= 1
                        self.cut += 1
        finally:
            for key in list(sel.get_map().values()):
                key.fileobj.close()
            sel.close()


def _cut_total(proc: ServeProcess) -> float:
    """Connections the server cut before their request, all reasons together (/metrics)."""
    _, _, body = http_get(proc.http + "/metrics", {"Authorization": f"Bearer {TOKEN}"})
    return sum(float(line.rpartition(" ")[2]) for line in body.decode().splitlines()
               if line.startswith("shlight_silent_connections_cut_total{"))


def _tries(proc: ServeProcess, n: int = 30) -> tuple[int, int, list[str]]:
    """(WebSocket clients with the token that got their hello, /healthz answered 200, what
    failed) out of ``n`` tries each."""
    ws_ok = health_ok = 0
    failures = []
    for _ in range(n):
        try:
            with connect(proc.url + f"?token={TOKEN}", open_timeout=10) as ws:
                if recv_json(ws)["type"] == "hello":
                    ws_ok += 1
        except Exception as exc:  # noqa: BLE001 - counted, and shown if too many
            failures.append(f"ws: {type(exc).__name__}: {exc}")
        status, _, body = http_get(proc.http + "/healthz", timeout=10)
        if status == 200:
            health_ok += 1
        else:
            failures.append(f"healthz: {status} {body[:80]!r}")
    return ws_ok, health_ok, failures


@pytest.mark.parametrize("source", [OTHER_ADDRESS, "127.0.0.1"])
def test_600_idle_sockets_leave_a_token_client_and_healthz_answered(source):
    with ServeProcess("--source", "demo", "--token", TOKEN) as proc, \
            IdleFlood(proc.port, 600, source=source) as flood:
        flood.wait_until_full_or_churning()
        ws_ok, health_ok, failures = _tries(proc)
        assert ws_ok >= 27 and health_ok >= 27, (ws_ok, health_ok, failures[:5])
        assert proc.proc.poll() is None and "Traceback" not in proc.output
        if source == OTHER_ADDRESS:
            # the per-address rules keep its silent sockets few: most were cut at once
            assert _cut_total(proc) > 0 and flood.cut > 0
            assert f"cut connection(s) from {OTHER_ADDRESS}" in proc.output
        else:
            # loopback is exempt from them (a reverse proxy); its sockets are not counted
            # against --max-clients, and each is cut after the head timeout
            poll(lambda: flood.cut > 0, 30, what="a silent loopback socket cut")


def test_a_silent_connection_is_cut_after_the_head_timeout_and_counted():
    with ServeProcess("--source", "demo") as proc:
        s = socket.create_connection(("127.0.0.1", proc.port), timeout=60)
        t0 = time.monotonic()
        try:
            data = s.recv(1)        # blocks until the server cuts it (EOF or a reset)
        except ConnectionResetError:
            data = b""
        waited = time.monotonic() - t0
        s.close()
        assert data == b"" and waited < 60
        assert metric(proc.http, "shlight_silent_connections_cut_total",
                      reason="head_timeout") >= 1
        limits = json.loads(http_get(proc.http + "/healthz")[2])
        assert limits["silent_connections_cut"]["head_timeout"] >= 1
        # a client that speaks at once is never cut: still served past the head timeout
        with connect(proc.url) as ws:
            t0 = time.monotonic()
            assert recv_json(ws)["type"] == "hello"
            while time.monotonic() - t0 < 7.0:
                assert recv_json(ws)["type"] == "sh9"


def _file_limit_1024():
    resource.setrlimit(resource.RLIMIT_NOFILE, (1024, 1024))


def test_1100_idle_sockets_under_a_1024_file_limit_leave_clients_answered():
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft < 2048:
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (min(hard, 4096), hard))
        except (ValueError, OSError):
            pytest.skip(f"this test needs 2,048 open files (limit {soft})")
    # From loopback, which the per-address rules exempt: only the cap on silent connections
    # in all (from the file limit) keeps the server's descriptors for the clients.
    with ServeProcess("--source", "demo", "--token", TOKEN, preexec_fn=_file_limit_1024) as proc, \
            IdleFlood(proc.port, 1100, source="127.0.0.1") as flood:
        flood.wait_until_full_or_churning()
        ws_ok, health_ok, failures = _tries(proc)
        assert ws_ok >= 27 and health_ok >= 27, (ws_ok, health_ok, failures[:5])
        assert metric(proc.http, "shlight_silent_connections_cut_total", TOKEN,
                      reason="too_many_silent") > 0
        assert proc.proc.poll() is None and "Traceback" not in proc.output
