"""A provider that runs all day costs next to nothing and says things once.

* thread pools are sized on purpose: the command line runs numpy's BLAS with one thread (its
  idle workers spun between frames, a whole core for a server with no client);
* a source that cannot work (no such camera, a stream that refuses) is reported once and
  retried quietly, without OpenCV's or FFmpeg's own lines at every attempt;
* ``error_estimate`` (SH9's own error on this scene) reaches the live messages, not only
  ``shlight compute``'s.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
import socket
import subprocess
import sys

import pytest

from servertools import (ROOT, ServeProcess, ServerThread, connect, health, poll, recv_json,
                         recv_until, run_cli)

HDRI = os.path.join(str(Path(__file__).resolve().parents[2]), "data", "hdri")
BRIDGE = os.path.join(HDRI, "bridge.exr")

_THREADS_AFTER_A_BIG_PRODUCT = (
    "import os, sys\n"
    "if sys.argv[1] == 'cli':\n    import provider.cli\n"
    "import numpy as np\n"
    "a = np.ones((1024, 1024))\n"
    "for _ in range(3):\n    a @ a\n"
    "print(len(os.listdir('/proc/self/task')))\n")


@pytest.mark.skipif(not os.path.isdir("/proc/self/task"), reason="counts threads in /proc")
def test_the_command_line_runs_blas_with_one_thread():
    clean = {k: v for k, v in os.environ.items() if not k.endswith(("_NUM_THREADS",
                                                                     "_MAXIMUM_THREADS"))}

    def threads(mode):
        res = subprocess.run([sys.executable, "-c", _THREADS_AFTER_A_BIG_PRODUCT, mode],
                             capture_output=True, text=True, env=clean, cwd=ROOT, timeout=120)
        assert res.returncode == 0, res.stderr
        return int(res.stdout)
    if len(os.sched_getaffinity(0)) < 2 or threads("plain") < 2:
        pytest.skip("this numpy starts no BLAS threads here (one CPU, or a serial BLAS)")
    assert threads("cli") == 1
    # ...and a user's explicit choice is kept
    res = subprocess.run([sys.executable, "-c",
                          "import os, provider.cli; print(os.environ['OPENBLAS_NUM_THREADS'])"],
                         capture_output=True, text=True, cwd=ROOT, timeout=60,
                         env={**clean, "OPENBLAS_NUM_THREADS": "3"})
    assert res.stdout.strip() == "3"


def _lines(output: str, level: str) -> list[str]:
    return [line for line in output.splitlines() if f" {level} " in line]


def test_a_camera_that_is_not_there_is_reported_once_then_retried_quietly():
    with ServeProcess("--source", "97", "--reconnect-max", "0.2") as srv:
        poll(lambda: health(srv.http)["probes"]["default"]["reconnects"] >= 4, timeout=30,
             what="reconnection attempts")
        out = srv.output
    warnings = _lines(out, "WARNING")
    assert len(warnings) == 1 and "no camera at /dev/video97" in warnings[0], out
    assert "WARN:" not in out and "still no source" not in out, out


def test_a_refusing_stream_is_reported_once_without_ffmpeg_noise():
    with socket.socket() as s:                  # a port nothing listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    with ServeProcess("--source", f"rtsp://127.0.0.1:{port}/live", "--reconnect-max", "0.2",
                      "--source-timeout", "1") as srv:
        poll(lambda: health(srv.http)["probes"]["default"]["reconnects"] >= 3, timeout=60,
             what="reconnection attempts")
        out = srv.output
    warnings = _lines(out, "WARNING")
    assert len(warnings) == 1 and "OpenCV cannot open" in warnings[0], out
    assert "WARN:" not in out and "Connection refused" not in out, out


def test_picamera2_missing_is_said_once():
    try:
        import picamera2  # noqa: F401
        pytest.skip("picamera2 is installed here")
    except ImportError:
        pass
    with ServeProcess("--source", "picamera2", "--reconnect-max", "0.2") as srv:
        poll(lambda: health(srv.http)["probes"]["default"]["reconnects"] >= 3, timeout=30,
             what="reconnection attempts")
        out = srv.output
    assert out.count("picamera2 is not installed") == 1, out


def test_error_estimate_reaches_live_messages():
    ref = json.loads(run_cli("compute", BRIDGE).stdout)
    assert 0 < ref["error_estimate"] < 0.3
    with ServerThread("--source", BRIDGE, "--fps", "10") as srv:
        with connect(srv.url) as ws:
            assert recv_json(ws)["type"] == "hello"
            msg = recv_until(ws, lambda m: m.get("type") == "sh9")
    assert msg["error_estimate"] == pytest.approx(ref["error_estimate"], rel=1e-9)
    # estimated about once a second, carried by every message in between
    with ServerThread("--source", "demo", "--change-threshold", "0") as srv:
        with connect(srv.url) as ws:
            assert recv_json(ws)["type"] == "hello"
            msgs = [recv_until(ws, lambda m: m.get("type") == "sh9") for _ in range(45)]
    values = [m.get("error_estimate") for m in msgs]
    assert all(isinstance(v, float) and 0 <= v < 0.5 for v in values), values
