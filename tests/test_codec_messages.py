"""What the image codecs write to descriptor 2 (libjpeg's "Corrupt JPEG data ...") goes to the
log, one line per source per interval, while everything else written to descriptor 2 still
reaches the process's stderr; descriptor 2 is captured once (a pipe drained by a thread), so
a decode costs no lock and no dup2 (review of issue 29's codec_messages)."""
from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

SCRIPT = textwrap.dedent('''
    import logging, os, sys, time
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)-7s %(message)s")
    import cv2, numpy as np
    from provider.live.sources import base

    img = (np.random.default_rng(0).random((64, 128, 3)) * 255).astype(np.uint8)
    data = bytearray(cv2.imencode(".jpg", img)[1].tobytes())
    data[len(data) // 2:len(data) // 2 + 40] = bytes(40)       # decodes, with a warning
    bad = np.frombuffer(bytes(data), np.uint8)

    dup2 = []
    real_dup2 = os.dup2
    os.dup2 = lambda *a: dup2.append(a) or real_dup2(*a)

    def said(where):                     # wait on the log's state, not on a clock
        deadline = time.monotonic() + 60
        while where not in base._said and time.monotonic() < deadline:
            time.sleep(0.01)

    for i in range(20):
        with base.codec_messages("camera-A"):
            assert cv2.imdecode(bad, cv2.IMREAD_COLOR) is not None
            if i == 0:
                os.write(2, b"a C library says hello\\n")
    said("camera-A")
    installs = len(dup2)
    for _ in range(5):                   # another source: its own line
        with base.codec_messages("camera-B"):
            assert cv2.imdecode(bad, cv2.IMREAD_COLOR) is not None
    said("camera-B")
    print("python's own stderr", file=sys.stderr)
    logging.getLogger("x").info("a log line")
    print(f"dup2 calls: {installs} for 20 decodes, {len(dup2)} for 25", file=sys.stderr)
    with base.codec_messages("camera-C"):       # the last words before exit: still said
        os.write(2, b"Premature end of JPEG file\\n")
''')


def test_codec_lines_go_to_the_log_and_the_rest_to_stderr():
    p = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                       timeout=120, cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert p.returncode == 0, p.stderr
    lines = p.stderr.splitlines()
    codec = [line for line in lines if "Corrupt JPEG data" in line]
    assert len(codec) == 2, p.stderr                 # one per source, none raw
    for line, where in zip(codec, ("camera-A", "camera-B")):
        assert "WARNING" in line and f"{where}: the image decoder says: Corrupt JPEG" in line
    assert any("camera-C: the image decoder says: Premature end of JPEG file" in line
               for line in lines), p.stderr
    for other in ("a C library says hello", "python's own stderr", "INFO    a log line"):
        assert sum(other in line for line in lines) == 1, (other, p.stderr)
    # descriptor 2 was pointed at the pipe once, by the first decode: none since
    assert "dup2 calls: 1 for 20 decodes, 1 for 25" in p.stderr
