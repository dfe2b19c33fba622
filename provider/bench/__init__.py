"""`shlight bench`: speed against error, on one core, as ratios to a floor.

The floor is reading the frame once (``cv2.sumElems`` on the same frame, same run): these
machines are shared and noisy, so only ratios measured side by side mean anything.

Sections (all written to ``--out``, default ./bench-results):

* ``speed_vs_error.md`` / ``.png``: time per frame and relative RMS irradiance error of each
  path (exact, the linear-domain fast paths, the paper's 8-bit 64×48 pipeline) for frame
  sizes 640×320, 1920×960, 3840×1920, uint8 and float. Test frames are the real panoramas
  in tests/data/hdri, resized; the error is against the float64 exact projection of the
  *same* frame, and for uint8 also against the HDR original (what clipping costs).
* ``fisheye_edge.md``: a 640×480 uint8 fisheye frame per path: time, and instructions per
  frame counted by ``valgrind --tool=callgrind`` (a 1 GHz core at IPC≈1 runs 33 M
  instructions in a 30 fps frame).
* ``fisheye_fill.md``: error of each lower-hemisphere fill model on the real panoramas.
* ``scenes.md``: per real panorama, what SH9 itself misses (truncation error against
  brute-force irradiance), whether order 2 rings negative, what ``--dering auto`` costs,
  and which order ``--order auto`` keeps.
* ``radiometry.md`` / ``.png`` (only with ``--sections radiometry``, see
  :mod:`provider.bench.radiometry`): a simulated 8-bit camera on the real panoramas, one
  frame (sRGB-assumed, true curve, calibrated) and brackets against the HDR truth, and the
  per-frame cost of the live merged path.
* ``server.md`` / ``server.json`` (only with ``--sections server``, see
  :mod:`provider.bench.server`): frame-to-client latency p50/p99 of a real ``shlight serve``
  and the number of clients one core keeps at 30 Hz.
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from .common import SINGLE_CORE_ENV


def run(args) -> int:
    """Run the chosen sections (arguments: :mod:`provider.cli.bench`)."""
    # One core: BLAS and OpenCV threads must be pinned before numpy/cv2 start their pools.
    if any(os.environ.get(k) != v for k, v in SINGLE_CORE_ENV.items()):
        env = {**os.environ, **SINGLE_CORE_ENV}
        argv = [sys.executable, "-m", "provider.cli", "bench"] + sys.argv[2:] \
            if len(sys.argv) > 1 and sys.argv[1] == "bench" else \
            [sys.executable, "-m", "provider.cli", "bench", "--out", args.out] + \
            (["--quick"] if args.quick else []) + ["--sections", args.sections, "--hdri", args.hdri,
                                                    "--repeat", str(args.repeat)] + \
            (["--no-instructions"] if args.no_instructions else [])
        return subprocess.call(argv, env=env)
    import cv2
    cv2.setNumThreads(1)
    from ..core.errors import InputError
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    hdri = sorted(Path(args.hdri).glob("*.exr")) + sorted(Path(args.hdri).glob("*.hdr"))
    if not hdri:
        raise InputError(f"no .exr/.hdr panoramas in {args.hdri}")
    sections = {s.strip() for s in args.sections.split(",") if s.strip()}
    unknown = sections - {"speed", "edge", "fill", "scenes", "server", "radiometry"}
    if unknown:
        raise InputError(f"unknown bench sections: {', '.join(sorted(unknown))}")
    if "speed" in sections:
        from .speed import bench_speed
        bench_speed(hdri, out, args)
    if "edge" in sections:
        from .edge import bench_edge
        bench_edge(hdri, out, args)
    if "fill" in sections:
        from .scenes import bench_fill
        bench_fill(hdri, out, args)
    if "scenes" in sections:
        from .scenes import bench_scenes
        bench_scenes(hdri, out, args)
    if "radiometry" in sections:
        from .radiometry import bench_radiometry
        bench_radiometry(hdri, out, args)
    if "server" in sections:
        try:
            from . import server as server_bench
        except ImportError as exc:
            print(f"server benchmark unavailable: {exc}", file=sys.stderr)
        else:
            server_bench.main(["--out", str(out)] + (["--quick"] if args.quick else []))
    print(f"results in {out}/")
    return 0
