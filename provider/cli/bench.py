"""``shlight bench``: its command-line options."""
from __future__ import annotations

import argparse
from pathlib import Path

#: The real panoramas of a source checkout (the default test frames).
HDRI_DIR = Path(__file__).resolve().parents[2] / "tests" / "data" / "hdri"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="bench-results", help="output folder (default ./bench-results)")
    p.add_argument("--quick", action="store_true",
                   help="small sizes, few repetitions (a smoke run, numbers are rough)")
    p.add_argument("--hdri", default=str(HDRI_DIR),
                   help="folder of equirect .exr/.hdr panoramas used as test frames")
    p.add_argument("--repeat", type=int, default=15, help="timed runs per path (median)")
    p.add_argument("--no-instructions", action="store_true",
                   help="skip the callgrind instruction count (slow: ~1 min)")
    p.add_argument("--sections", default="speed,edge,fill,scenes",
                   help="comma list of: speed, edge, fill, scenes, server, radiometry")


def run(args) -> int:
    from ..bench import run as run_bench
    return run_bench(args)
