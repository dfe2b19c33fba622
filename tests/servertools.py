"""Helpers for the service tests: real servers on loopback (in a thread or as a
``shlight serve`` subprocess), a controllable MJPEG HTTP camera, and small client tools.

Nothing here mocks the network: every test talks TCP to a real server.
"""
from __future__ import annotations

import asyncio
import json
import os
import re
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import cv2
import numpy as np

from provider.bench.common import stop as stop_process

ROOT = Path(__file__).resolve().parent.parent
SHLIGHT = [sys.executable, "-m", "provider.cli"]
SERVING = re.compile(r"serving wss?://[^ ]*:(\d+)/")

#: Every wait for something to happen (poll, recv_until) is a guard against a hung test, never
#: a measure of speed: its deadline is what an idle machine needs with a margin, times PATIENCE.
#: A cube's first build or a server's start takes several times as long on 2 shared cores
#: beside a CPU hog (CI) as alone; a passing test waits only as long as the event takes.
PATIENCE = float(os.environ.get("SHLIGHT_TEST_PATIENCE", "4"))


def poll(predicate, timeout: float = 10.0, interval: float = 0.02, what: str = "condition"):
    """Wait until ``predicate()`` is truthy (returns it); AssertionError at the deadline
    (``timeout`` × PATIENCE seconds)."""
    deadline = time.monotonic() + timeout * PATIENCE
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what}")
        time.sleep(interval)


# ---- an in-process server, on its own event loop in a thread -------------------------------------

class _Loopback:
    """``url`` and ``http`` of a server on 127.0.0.1 from its ``port``."""

    @property
    def url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/"

    @property
    def http(self) -> str:
        return f"http://127.0.0.1:{self.port}"


class ServerThread(_Loopback):
    """``shlight serve ARGV`` built by the real CLI code, run on a private event loop in a
    thread (so that tests can use blocking clients). Use as a context manager."""

    def __init__(self, *argv: str):
        from provider.cli import build_parser
        from provider.cli.serve import build_server
        args = build_parser().parse_args(["serve", "--port", "0", *argv])
        self.server = build_server(args)
        self.loop = asyncio.new_event_loop()
        self._stop: asyncio.Event | None = None
        self._ready = threading.Event()
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, daemon=True, name="test-server")

    def _run(self) -> None:
        asyncio.set_event_loop(self.loop)

        async def main():
            self._stop = asyncio.Event()
            await self.server.start()
            self._ready.set()
            await self._stop.wait()
            await self.server.stop()
        try:
            self.loop.run_until_complete(main())
        except BaseException as exc:  # noqa: BLE001 - reported to the test
            self.error = exc
        finally:
            self._ready.set()
            self.loop.close()

    def __enter__(self) -> "ServerThread":
        self.thread.start()
        self._ready.wait(30 * PATIENCE)
        if self.error is not None:
            raise self.error
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self.thread.is_alive() and self._stop is not None:
            self.loop.call_soon_threadsafe(self._stop.set)
            self.thread.join(30)
        if self.thread.is_alive():  # say where it is stuck, and what the loop still runs
            import traceback
            stack = "".join(traceback.format_stack(sys._current_frames()[self.thread.ident]))
            tasks = self._pending_tasks()
            raise AssertionError(f"the server did not stop\n{stack}\npending tasks:\n{tasks}")

    def _pending_tasks(self) -> str:
        try:
            return "\n".join(repr(t) for t in asyncio.all_tasks(self.loop))
        except RuntimeError as exc:
            return f"(cannot list: {exc})"

    def call(self, fn):
        """Run ``fn()`` on the server's loop (to read its state safely) and return its result."""
        async def wrapper():
            return fn()
        return asyncio.run_coroutine_threadsafe(wrapper(), self.loop).result(10)

    @property
    def port(self) -> int:
        return self.server.port



# ---- a `shlight serve` subprocess -------------------------------------------------------------------

class ServeProcess(_Loopback):
    """``shlight serve --port 0 ARGV`` as a subprocess; the bound port is read from its log."""

    def __init__(self, *argv: str, env=None, preexec_fn=None):
        self.argv = [*SHLIGHT, "serve", "--port", "0", *argv]
        self.lines: list[str] = []
        self.port: int | None = None
        self._found = threading.Event()
        self.proc = subprocess.Popen(self.argv, cwd=ROOT, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True,
                                     env={**os.environ, **(env or {})},
                                     preexec_fn=preexec_fn)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.append(line)
            m = SERVING.search(line)
            if m and self.port is None:
                self.port = int(m.group(1))
                self._found.set()
        self._found.set()

    def __enter__(self) -> "ServeProcess":
        self._found.wait(60 * PATIENCE)
        if self.port is None:
            self.stop()
            raise AssertionError("shlight serve did not start:\n" + self.output)
        return self

    def __exit__(self, *exc) -> None:
        self.stop()

    def stop(self) -> int:
        if self.proc.poll() is None:
            stop_process(self.proc, 15)
        self._reader.join(5)
        return self.proc.returncode

    @property
    def output(self) -> str:
        return "".join(self.lines)



def run_cli(*argv: str, timeout: float = 60) -> subprocess.CompletedProcess:
    """``shlight ARGV`` as a subprocess; ``timeout`` (× PATIENCE) guards against a hang."""
    return subprocess.run([*SHLIGHT, *argv], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout * PATIENCE)


def refused(res: subprocess.CompletedProcess, *words: str) -> str:
    """The one line of a refused command (exit 2, nothing on stdout, no traceback, one line
    on stderr holding each of ``words``; progress lines, "... ...", are not counted)."""
    assert res.returncode == 2, (res.stdout, res.stderr)
    assert res.stdout == "" and "Traceback" not in res.stderr, (res.stdout, res.stderr)
    lines = [line for line in res.stderr.strip().splitlines() if not line.endswith(" ...")]
    assert len(lines) == 1, res.stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


# ---- HTTP helpers ------------------------------------------------------------------------------------

def http_get(url: str, headers=None, timeout: float = 10.0) -> tuple[int, dict, bytes]:
    """(status, headers, body) of a GET; HTTP errors are returned, not raised."""
    req = urllib.request.Request(url, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=timeout) as resp:
            return resp.status, dict(resp.headers), resp.read()
    except urllib.error.HTTPError as exc:
        return exc.code, dict(exc.headers), exc.read()


def health(base: str) -> dict:
    status, _, body = http_get(base + "/healthz")
    assert status == 200
    return json.loads(body)


def metric(base: str, name: str, token: str | None = None, **labels) -> float:
    """The value of one Prometheus sample from /metrics."""
    headers = {"Authorization": f"Bearer {token}"} if token else {}
    status, _, body = http_get(base + "/metrics", headers)
    assert status == 200, body
    want = ",".join(f'{k}="{v}"' for k, v in labels.items())
    for line in body.decode().splitlines():
        if line.startswith("#"):
            continue
        key, _, value = line.rpartition(" ")
        if key == name + (f"{{{want}}}" if want else ""):
            return float(value)
    raise AssertionError(f"no sample {name} {labels} in /metrics")


# ---- WebSocket client helpers -------------------------------------------------------------------------

def connect(url: str, **kwargs):
    """``websockets.sync.client.connect`` for tests: the client buffers what it has not
    read yet (``max_queue=None``) so that closing never waits behind a paused reader,
    and gives up closing after 2 s."""
    from websockets.sync.client import connect as ws_connect
    kwargs.setdefault("max_queue", None)
    kwargs.setdefault("close_timeout", 2)
    return ws_connect(url, **kwargs)


def recv_json(ws, timeout: float = 10.0) -> dict:
    return json.loads(ws.recv(timeout=timeout))


def recv_until(ws, predicate, timeout: float = 10.0, what: str = "message") -> dict:
    """Read messages until one satisfies ``predicate`` (returned); AssertionError at the
    deadline (``timeout`` × PATIENCE seconds)."""
    deadline = time.monotonic() + timeout * PATIENCE
    last = None
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            raise AssertionError(
                f"no {what} within {timeout * PATIENCE:g} s; last message: {last}")
        try:
            msg = recv_json(ws, timeout=left)
        except TimeoutError:
            continue
        last = msg
        if predicate(msg):
            return msg


def collect(ws, seconds: float) -> list[dict]:
    """Every message received during ``seconds``."""
    out = []
    deadline = time.monotonic() + seconds
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            return out
        try:
            out.append(recv_json(ws, timeout=left))
        except TimeoutError:
            return out


def coefficients(msg: dict) -> np.ndarray:
    return np.asarray(msg["coefficients"], np.float64)


# ---- a camera the test controls: MJPEG over HTTP ---------------------------------------------------------

def jpeg_panorama(width: int = 64, value: tuple[int, int, int] = (200, 180, 160),
                  lamp: bool = False) -> bytes:
    """A small 2:1 equirect JPEG (RGB ``value``; optionally a bright patch on one side)."""
    img = np.zeros((width // 2, width, 3), np.uint8)
    img[:] = value
    if lamp:
        img[width // 8: width // 4, 3 * width // 4 - 4: 3 * width // 4 + 4] = 255
    ok, data = cv2.imencode(".jpg", img[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 95])
    assert ok
    return data.tobytes()


class MjpegCamera:
    """A local multipart/x-mixed-replace MJPEG server whose behaviour the test switches:

    * ``mode = "stream"``: a frame every 1/``fps`` s (``frame``, or the queued ``inject``
      frames first);
    * ``"stall"``: connections stay open but nothing is sent;
    * ``"down"``: open connections are closed and new requests get HTTP 503.
    """

    BOUNDARY = "shlightframe"

    def __init__(self, frame: bytes, fps: float = 20.0, content_length: bool = True):
        self.frame, self.fps, self.content_length = frame, fps, content_length
        self.mode = "stream"
        self.inject: list[bytes] = []
        self.requests = 0
        self.frames_sent = 0
        self._lock = threading.Lock()
        camera = self

        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_GET(self):
                camera.requests += 1
                if camera.mode == "down":
                    self.send_error(503, "camera offline")
                    return
                self.send_response(200)
                self.send_header("Content-Type",
                                 f"multipart/x-mixed-replace; boundary={camera.BOUNDARY}")
                self.send_header("Cache-Control", "no-cache")
                self.end_headers()
                try:
                    camera._stream(self.wfile)
                except (BrokenPipeError, ConnectionResetError, OSError):
                    pass

        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.httpd.daemon_threads = True
        self._thread = threading.Thread(target=self.httpd.serve_forever, daemon=True,
                                        kwargs={"poll_interval": 0.05})

    def _stream(self, out) -> None:
        while not self._closed:
            mode = self.mode
            if mode == "down":
                return
            if mode == "stall":
                time.sleep(0.02)
                continue
            with self._lock:
                data = self.inject.pop(0) if self.inject else self.frame
            head = f"--{self.BOUNDARY}\r\nContent-Type: image/jpeg\r\n"
            if self.content_length:
                head += f"Content-Length: {len(data)}\r\n"
            out.write(head.encode() + b"\r\n" + data + b"\r\n")
            out.flush()
            self.frames_sent += 1
            time.sleep(1.0 / self.fps)

    _closed = False

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.httpd.server_address[1]}/stream.mjpg"

    def __enter__(self) -> "MjpegCamera":
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._closed = True
        self.httpd.shutdown()
        self.httpd.server_close()
