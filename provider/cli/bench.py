"""``shlight bench``: its command-line options."""
from __future__ import annotations

import argparse
from pathlib import Path

#: The real panoramas shipped with the package (CC0; the tests' frames too).
HDRI_DIR = Path(__file__).resolve().parents[1] / "data" / "hdri"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="bench-results", help="output folder (default ./bench-results)")
    p.add_argument("--quick", action="store_true",
                   help="small sizes, few repetitions (a smoke run, numbers are rough)")
    p.add_argument("--hdri", default=str(HDRI_DIR),
                   help="folder of equirect .exr/.hdr panoramas used as test frames")
    p.add_argument("--repeat", type=int, default=15, help="timed runs per path (median)")
    p.add_argument("--instructions", action=argparse.BooleanOptionalAction, default=None,
                   help="count instructions per frame with valgrind's callgrind in the edge "
                        "section (slow: about 2 min; default: on, off with --quick)")
    p.add_argument("--sections", default="speed,edge,fill,scenes",
                   help="comma list of: speed, edge, fill, scenes, server, radiometry, probes, "
                        "environment (each "
                        "says what it costs before it starts)")


def run(args) -> int:
    from ..bench import run as run_bench
    return run_bench(args)
