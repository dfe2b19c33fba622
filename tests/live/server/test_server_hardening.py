"""The server's smaller faults from the fault audit (issue 29), each reproduced on a real
``shlight serve`` over loopback: duplicate headers, a client that stops reading."""
from __future__ import annotations

import re
import socket

import pytest

from servertools import ServeProcess, metric, poll


def _raw_request(port: int, head: str, timeout: float = 10.0) -> bytes:
    with socket.create_connection(("127.0.0.1", port), timeout=timeout) as s:
        s.sendall(head.encode())
        data = b""
        while True:
            chunk = s.recv(4096)
            if not chunk:
                return data
            data += chunk


@pytest.fixture(scope="module")
def server():
    with ServeProcess("--source", "demo", "--token", "tok") as proc:
        yield proc


@pytest.mark.parametrize("header,value", [("Host", "127.0.0.1"), ("Authorization", "Bearer tok"),
                                          ("Origin", "http://127.0.0.1"), ("Upgrade", "websocket")])
def test_a_repeated_header_gets_400_not_a_traceback(server, header, value):
    ws = ("Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
          "Sec-WebSocket-Version: 13\r\n")
    lines = {"Host": f"127.0.0.1:{server.port}", "Authorization": "Bearer tok",
             "Origin": f"http://127.0.0.1:{server.port}", "Upgrade": "websocket"}
    head = "GET /?token=tok HTTP/1.1\r\n" + "".join(f"{k}: {v}\r\n" for k, v in lines.items())
    head += f"{header}: {value}\r\n" + ws + "\r\n"
    reply = _raw_request(server.port, head)
    assert reply.startswith(b"HTTP/1.1 400"), reply[:200]
    assert f"more than one {header} header".encode() in reply
    # the same request without the repeat is answered (101 Switching Protocols)
    once = "GET /?token=tok HTTP/1.1\r\n" + "".join(f"{k}: {v}\r\n" for k, v in lines.items())
    with socket.create_connection(("127.0.0.1", server.port), timeout=10) as s:
        s.sendall((once + ws + "\r\n").encode())
        assert s.recv(12) == b"HTTP/1.1 101"
    assert server.proc.poll() is None
    assert "Traceback" not in server.output and "MultipleValuesError" not in server.output


def test_a_client_that_stops_reading_is_dropped_soon_after_its_window_closes():
    """--send-timeout counts from when the client's connection stops taking data: the
    server's kernel send buffer is bounded, so the backlog that must fill before the
    timer starts is about 128 KiB, not the megabytes Linux would grow it to (before the
    fix: dropped after 13-45 s with --send-timeout 10)."""
    with ServeProcess("--source", "demo", "--fps", "60", "--change-threshold", "0",
                      "--send-timeout", "2") as proc:
        s = socket.socket()
        s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)    # a small window
        s.settimeout(10)
        s.connect(("127.0.0.1", proc.port))
        s.sendall((f"GET / HTTP/1.1\r\nHost: 127.0.0.1:{proc.port}\r\nUpgrade: websocket\r\n"
                   "Connection: Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n"
                   "Sec-WebSocket-Version: 13\r\n\r\n").encode())
        assert s.recv(12) == b"HTTP/1.1 101"
        label = "127.0.0.1:%d" % s.getsockname()[1]     # from here on it reads nothing
        try:
            poll(lambda: metric(proc.http, "shlight_stalled_clients_total") >= 1, timeout=120,
                 interval=0.2, what="the stalled client dropped")
            left = poll(lambda: re.search(rf"client {label} left \(code \d+, (\d+) messages sent",
                                          proc.output), 30, what="its 'left' line")
        finally:
            s.close()
        # What it was sent before the timer could start is what the buffers held: about
        # 128 KiB of ~1 KB messages now; before the fix Linux grew the send buffer to
        # megabytes (thousands of messages, 15 s here and up to 45 s in the audit).
        sent = int(left.group(1))
        assert sent < 200, f"{sent} messages queued before the client was dropped"
        assert "not reading for 2 s; disconnecting" in proc.output


def test_each_probe_s_failure_reaches_the_log():
    """Two probes whose cameras are missing: both failures are said (the repeat filter
    keyed on the text before formatting and held back probe b's line, issue 33)."""
    with ServeProcess("--probe", "a=/dev/video97", "--probe", "b=/dev/video98") as proc:
        poll(lambda: "probe a" in proc.output and "probe b" in proc.output, 60,
             what="both probes' failures in the log")
        assert proc.proc.poll() is None


@pytest.mark.parametrize("value", ["-5", "nan", "abc", "inf", "1e400"])
def test_a_bad_max_hz_in_the_url_gets_400_as_in_a_subscribe(server, value):
    """?max_hz=-5 connected with no cap, while a subscribe with it is refused (issue 33)."""
    from websockets.exceptions import InvalidStatus
    from servertools import connect
    with pytest.raises(InvalidStatus) as refused:
        with connect(server.url + f"?token=tok&max_hz={value}"):
            pass
    assert refused.value.response.status_code == 400
    assert b"max_hz must be a number >= 0" in refused.value.response.body
    with connect(server.url + "?token=tok&max_hz=2.5") as ws:      # a good one still goes
        assert ws.recv(timeout=10)


def test_the_example_s_placeholder_token_is_warned_about():
    """examples/edge/shlight-edge.env ships SHLIGHT_TOKEN=change-me for a server on 0.0.0.0
    (issue 33): a server started with it says so."""
    from pathlib import Path
    env = (Path(__file__).resolve().parents[3] / "examples" / "edge"
           / "shlight-edge.env").read_text()
    assert "SHLIGHT_TOKEN=change-me" in env and "REPLACE IT" in env
    with ServeProcess("--source", "demo", "--token", "change-me") as proc:
        poll(lambda: "placeholder 'change-me'" in proc.output, 30, what="the warning")
    with ServeProcess("--source", "demo", "--token", "a-real-secret") as proc:
        assert "placeholder" not in proc.output


def _corrupt_but_decodable_jpeg() -> bytes:
    """A JPEG that decodes (the rest of the picture grey) while libjpeg prints "Corrupt
    JPEG data: N extraneous bytes before marker 0xd9" to stderr."""
    import cv2
    import numpy as np
    from servertools import jpeg_panorama
    data = bytearray(jpeg_panorama(1024))
    assert cv2.imdecode(np.frombuffer(bytes(data), np.uint8), cv2.IMREAD_COLOR) is not None
    n = len(data) // 2
    assert data.rfind(b"\xff\xda") < n     # in its scan: a header damaged does not decode
    data[n:n + 40] = b"\0" * 40
    return bytes(data)


def test_a_camera_that_keeps_sending_bad_jpegs_is_one_log_line_not_one_a_frame():
    """libjpeg writes a line to stderr for every corrupt frame: a camera sending only such
    frames filled the log (issue 29). Its lines go through the log, one per source per 10 s,
    and the frames still light."""
    from servertools import MjpegCamera, health
    with MjpegCamera(_corrupt_but_decodable_jpeg(), fps=30) as cam:
        with ServeProcess("--source", cam.url, "--change-threshold", "0") as proc:
            poll(lambda: health(proc.http)["probes"]["default"]["frames"] >= 40, timeout=120,
                 what="40 frames decoded")
            out = proc.output
    said = [line for line in out.splitlines() if "Corrupt JPEG data" in line]
    assert 1 <= len(said) <= 3, out[-3000:]       # 40 frames in a few seconds: one line
    for line in said:
        assert "WARNING" in line and "the image decoder says: Corrupt JPEG data" in line, line
