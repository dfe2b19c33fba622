"""A client that stops reading is dropped within ``--send-timeout`` (issue 41), whatever its
own receive buffer holds: sh9 and reflection-cube subscribers alike, and a client that keeps
reading is never dropped.

Each client is websockets' own (it answers pings while it reads) with ``max_queue=1``: when
the test stops calling ``recv`` the library takes one more message and then leaves the socket
unread, as an application that stopped reading does. Before the fix the server learnt of it
only once the client's kernel receive buffer was full: at the slow rates below (5 sh9 messages
a second, a cube every 2 s) that took 20 s (sh9) and 10 s (cubes) with ``--send-timeout 2``
and a default receive buffer, and more than a minute with the 1 MiB one asked for here (a
cube client was never dropped: a cube sent into an empty buffer waited untimed); now the
server pings with its writes and drops a client whose pong is not back within the timeout: at
most 2 × 1.25 = 2.5 s and a message interval after it stopped reading
(session.STALL_PING_SHARE)."""
from __future__ import annotations

import json
import re
import socket
import time

from servertools import ServeProcess, connect, metric, poll

SEND_TIMEOUT = 2.0
#: The drop's bound: the timeout, a quarter of it until the next ping may go
#: (STALL_PING_SHARE), a message interval for the library's last read and one for the write
#: that finds the ping overdue, and 4 s for a loaded machine (the server's loop and the
#: test's /metrics polls run late there): 7.5 s, against more than a minute before the fix
#: with these buffers (measured 2.3-3.4 s on an idle machine).
DROP_BOUND_S = SEND_TIMEOUT * 1.25 + 2 * 0.5 + 4.0


def _client(proc, rcvbuf: int = 1 << 20):
    """A websockets client on a socket whose receive buffer is large (the kernel caps it at
    net.core.rmem_max): before the fix a larger buffer meant a later drop."""
    sock = socket.create_connection(("127.0.0.1", proc.port), timeout=10)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, rcvbuf)
    return connect(proc.url, sock=sock, max_queue=1, max_size=None)


def _stalled_after(proc, stopped: float) -> float:
    poll(lambda: metric(proc.http, "shlight_stalled_clients_total") >= 1, timeout=120,
         interval=0.1, what="the stalled client dropped")
    return time.monotonic() - stopped


def test_an_sh9_client_that_stops_reading_is_dropped_within_the_send_timeout():
    with ServeProcess("--source", "demo", "--fps", "5", "--change-threshold", "0",
                      "--send-timeout", str(SEND_TIMEOUT)) as proc, _client(proc) as ws:
        for _ in range(10):             # a reading client first (its window open)
            ws.recv(timeout=30)
        stopped = time.monotonic()      # from here on the application reads nothing
        waited = _stalled_after(proc, stopped)
        assert waited < DROP_BOUND_S, f"dropped {waited:.1f} s after it stopped reading"
        poll(lambda: re.search(r"client \S+ left \(code", proc.output), 30, what="'left' line")
        assert f"not reading for {SEND_TIMEOUT:.0f} s; disconnecting" in proc.output


def test_a_cube_client_that_stops_reading_is_dropped_within_the_send_timeout():
    with ServeProcess("--source", "demo", "--fps", "5", "--change-threshold", "0",
                      "--environment", "--environment-hz", "0.5",
                      "--send-timeout", str(SEND_TIMEOUT)) as proc, _client(proc) as ws:
        ws.send(json.dumps({"type": "subscribe", "environment": True}))
        # read until a cube came (the first one takes the projector's warm-up)
        deadline = time.monotonic() + 240
        while not isinstance(ws.recv(timeout=240), bytes):
            assert time.monotonic() < deadline, "no cube"
        stopped = time.monotonic()
        waited = _stalled_after(proc, stopped)
        assert waited < DROP_BOUND_S, f"dropped {waited:.1f} s after it stopped reading"
        assert metric(proc.http, "shlight_environment_clients") == 0


def test_a_client_that_keeps_reading_is_not_dropped():
    """The server's pings are answered by a client that reads: it stays connected over many
    pings (the span is counted on the server's own message times, not the test's clock)."""
    with ServeProcess("--source", "demo", "--fps", "20", "--change-threshold", "0",
                      "--environment", "--send-timeout", "1") as proc, \
            _client(proc) as ws:
        ws.send(json.dumps({"type": "subscribe", "environment": True}))
        first = last = None
        cubes = 0
        # 8 s: 32 pings at one every 0.25 s; and a cube among them (its warm-up may be long)
        while last is None or last - first < 8.0 or not cubes:
            message = ws.recv(timeout=240)
            if isinstance(message, bytes):
                cubes += 1
                continue
            msg = json.loads(message)
            if msg.get("type") == "sh9":
                first = msg["time"] if first is None else first
                last = msg["time"]
        assert metric(proc.http, "shlight_stalled_clients_total") == 0
        assert metric(proc.http, "shlight_clients") == 1
