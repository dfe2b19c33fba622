"""``--sections edge``: a 640×480 fisheye frame against a 1 GHz core's budget."""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

from .common import SINGLE_CORE_ENV, _median_ms, _progress

#: The folder that holds the ``provider`` package (for the profiled subprocess).
PACKAGE_ROOT = Path(__file__).resolve().parents[2]

_CALLGRIND_SNIPPET = r"""
import sys, numpy as np, cv2
cv2.setNumThreads(1)
from provider import SH9Projector
ds, n = int(sys.argv[1]), int(sys.argv[2])
p = SH9Projector(640, 480, "fisheye", downsample=ds)
frame = np.random.default_rng(0).integers(0, 256, (480, 640, 3), dtype=np.uint8)
p.project(frame)
for _ in range(n):
    p.project(frame)
"""


def _callgrind_instructions(ds, n):
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / "edge.py"
        script.write_text(_CALLGRIND_SNIPPET)
        outfile = Path(tmp) / "cg.out"
        cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={outfile}",
               sys.executable, str(script), str(ds), str(n)]
        subprocess.run(cmd, check=True, capture_output=True,
                       env={**os.environ, **SINGLE_CORE_ENV,
                            "PYTHONPATH": str(PACKAGE_ROOT)})
        for line in outfile.read_text().splitlines():
            if line.startswith("totals:") or line.startswith("summary:"):
                return int(line.split()[1])
    raise RuntimeError("callgrind wrote no totals")


def bench_edge(hdri, out: Path, args):
    import shutil
    import numpy as np
    import cv2
    from ..core.sh9.engine import SH9Projector
    repeat = 5 if args.quick else 50
    frame = np.random.default_rng(0).integers(0, 256, (480, 640, 3), dtype=np.uint8)
    floor = _median_ms(lambda: cv2.sumElems(frame), repeat)
    lines = ["# Edge device: 640×480 uint8 fisheye frame, one core", "",
             "Budget: a single 1 GHz core at 30 fps has 33 ms and, at about one instruction "
             "per cycle, ~33 M instructions per frame.", "",
             "| path | ms/frame | × floor | instructions/frame | fits 33 M? |", "|---|---:|---:|---:|---|"]
    have_valgrind = shutil.which("valgrind") and args.instructions
    for ds in (1, 2, 4):
        _progress(f"bench edge fisheye downsample {ds}")
        p = SH9Projector(640, 480, "fisheye", downsample=ds)
        ms = _median_ms(lambda: p.project(frame), repeat)
        ins = "n/a (valgrind not installed)" if not shutil.which("valgrind") else \
            "not counted (--instructions counts them)"
        fits = ""
        if have_valgrind:
            n1, n2 = (1, 3) if args.quick else (2, 12)
            per = (_callgrind_instructions(ds, n2) - _callgrind_instructions(ds, n1)) / (n2 - n1)
            ins = f"{per / 1e6:.1f} M"
            fits = "yes" if per < 33e6 else "no"
        label = "exact" if ds == 1 else f"fast /{ds}"
        lines.append(f"| {label} | {ms:.2f} | {ms / floor:.1f} | {ins} | {fits} |")
    lines += ["", "Instructions are counted by `valgrind --tool=callgrind` as the difference "
              "between two runs of different frame counts (start-up cancels out); x86-64 "
              "instructions with SIMD, so an ARM core without NEON needs more."]
    (out / "fisheye_edge.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
