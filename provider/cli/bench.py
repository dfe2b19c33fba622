"""``shlight bench``: its command-line options."""
from __future__ import annotations

import argparse
from pathlib import Path

#: The real panoramas shipped with the package (CC0; the tests' frames too).
HDRI_DIR = Path(__file__).resolve().parents[1] / "data" / "hdri"
#: Most timed runs per path (``--repeat``): a median of more is no steadier on a busy
#: machine's clock, and a mistyped billion would run for days.
MAX_REPEAT = 1000


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", default="bench-results", help="output folder (default ./bench-results)")
    p.add_argument("--quick", action="store_true",
                   help="small sizes, few repetitions (a smoke run, numbers are rough)")
    p.add_argument("--hdri", default=str(HDRI_DIR),
                   help="folder of equirect .exr/.hdr panoramas used as test frames")
    p.add_argument("--repeat", type=int, default=15,
                   help=f"timed runs per path (median; 1 to {MAX_REPEAT}, default 15)")
    p.add_argument("--instructions", action=argparse.BooleanOptionalAction, default=None,
                   help="count instructions per frame with valgrind's callgrind in the edge "
                        "section, and a first and a cached start's (slow: about 8 min; "
                        "default: on, off with --quick)")
    p.add_argument("--sections", default="speed,edge,fill,scenes",
                   help="comma list of: speed, edge, fill, scenes, server, radiometry, probes, "
                        "environment, shadows, passthrough, points (each "
                        "says what it costs before it starts)")


def check_arguments(args) -> None:
    """Every option checked before any work starts (exit 2, nothing written)."""
    import os
    from ..bench import SECTION_COST_S
    from ..core.errors import InputError
    if not 1 <= args.repeat <= MAX_REPEAT:
        raise InputError(f"--repeat must be at least 1 and at most {MAX_REPEAT} (timed runs "
                         f"per path; default 15), got {args.repeat}")
    order = [s.strip() for s in args.sections.split(",") if s.strip()]
    if not order:
        raise InputError(f"--sections names no section (sections: {', '.join(SECTION_COST_S)})")
    unknown = sorted(set(order) - set(SECTION_COST_S))
    if unknown:
        raise InputError(f"unknown bench sections: {', '.join(unknown)} "
                         f"(sections: {', '.join(SECTION_COST_S)})")
    from .outputs import output_folder
    output_folder(args.out, holds="the results")
    if not os.path.isdir(args.hdri):
        raise InputError(f"--hdri {args.hdri}: no such folder")


def run(args) -> int:
    from ..bench import run as run_bench
    check_arguments(args)
    return run_bench(args)
