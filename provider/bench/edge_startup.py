"""Start-up in instructions: building the Theta S SH9 + lights and 32² cube projectors with
the table cache (:mod:`provider.core.table_cache`) cold, then warm.

Time on this machine says little about a 1 GHz board; callgrind's instruction count does
not depend on the machine's load. Three processes run under callgrind with one fresh cache
folder: one that only imports what a start imports (the baseline), a first start (tables
built and written) and a second start (tables read). A start's instructions are its
process's total; its build's are that total less the baseline's (the interpreter, numpy and
OpenCV loading, the same in every start). ``python -m provider.bench.edge --startup``
prints them; ``shlight bench --sections edge`` adds them to its page.
"""
from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

from .common import SINGLE_CORE_ENV

#: The folder that holds the ``provider`` package (for the profiled subprocess).
PACKAGE_ROOT = Path(__file__).resolve().parents[2]
#: The Theta S live frame and the reflection cube ``serve --environment`` builds for it.
THETA_SIZE, CUBE_SIZE = (1280, 720), 32

_STARTUP_SNIPPET = r"""
import sys
import cv2
cv2.setNumThreads(1)
from provider.core.sh9.engine import SH9Projector
from provider.core.reflections.environment import EnvironmentProjector
width, height, cube, build = (int(v) for v in sys.argv[1:5])
if build:
    SH9Projector(width, height, "dual-fisheye", lights="auto")
    EnvironmentProjector(width, height, "dual-fisheye", size=cube)
"""

#: The counted processes: (name, builds the projectors?), run in this order on one folder.
STARTS = (("baseline", 0), ("first", 1), ("second", 1))


def callgrind_instructions(argv: list, env: dict, tmp: Path) -> int:
    """callgrind's total instructions of one ``python argv`` process."""
    outfile = tmp / f"cg.{len(list(tmp.iterdir()))}.out"
    env = {**env, "PYTHONHASHSEED": "0"}    # the count varies ±1.5 % with the hash seed
    # valgrind runs no AVX-512: OpenBLAS forced onto such a kernel dies of SIGILL under it
    if env.get("OPENBLAS_CORETYPE", "").lower() in ("skylakex", "cooperlake", "sapphirerapids"):
        del env["OPENBLAS_CORETYPE"]
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={outfile}",
                    sys.executable, *argv], check=True, capture_output=True, env=env)
    for line in outfile.read_text().splitlines():
        if line.startswith(("totals:", "summary:")):
            return int(line.split()[1])
    raise RuntimeError("callgrind wrote no totals")


def startup_instructions(size: tuple = THETA_SIZE, cube: int = CUBE_SIZE) -> dict:
    """{"baseline", "first", "second"}: callgrind's instructions of a process that imports
    the engine and builds nothing, of a first start (the SH9 + lights and cube projectors of
    a ``size`` dual fisheye built, their tables written to an empty cache), and of a second
    start (the tables read)."""
    counts = {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        script, cache = tmp / "start.py", tmp / "cache"
        script.write_text(_STARTUP_SNIPPET)
        (tmp / "cg").mkdir()
        env = {**os.environ, **SINGLE_CORE_ENV, "PYTHONPATH": str(PACKAGE_ROOT),
               "SHLIGHT_CACHE_DIR": str(cache), "SHLIGHT_TABLE_CACHE": "1"}
        for name, build in STARTS:
            counts[name] = callgrind_instructions(
                [str(script), str(size[0]), str(size[1]), str(cube), str(build)], env, tmp / "cg")
    return counts


def startup_lines(counts: dict, ips: float = 1e9) -> list:
    """The page's lines for :func:`startup_instructions`' counts (x86-64 instructions)."""
    base = counts["baseline"]
    rows = [("first start: tables built, written to the cache", counts["first"]),
            ("second start: tables read from the cache", counts["second"])]
    lines = ["| start | process instructions | build instructions (less the imports) | "
             f"est. s at {ips / 1e9:g} GHz, 1/cycle |", "|---|---:|---:|---:|"]
    for what, n in rows:
        lines.append(f"| {what} | {n / 1e9:.2f} G | {(n - base) / 1e9:.3f} G | "
                     f"{n / ips:.1f} |")
    first, second = counts["first"], counts["second"]
    lines += ["", f"Imports alone (the baseline process): {base / 1e9:.2f} G. The second start "
              f"costs {second / first:.3f} of the first's instructions "
              f"({(second - base) / max(first - base, 1):.4f} of its build)."]
    return lines


def startup_section() -> tuple[list, dict]:
    """The edge page's start-up section (its lines) and :func:`startup_instructions`' counts
    at the Theta S size."""
    from .common import _progress
    _progress("bench edge: start-up under callgrind (three processes, minutes)")
    counts = startup_instructions()
    return (["", "## Start-up in instructions: Theta S SH9 + lights and its 32² cube", "",
             "Three processes under callgrind share one empty table-cache folder: one that "
             "imports the engine and builds nothing, a first start (the SH9 + lights and 32² "
             "cube projectors of the 1280×720 dual fisheye built, their tables written) and "
             "a second (the tables read). x86-64 instructions; the seconds are an estimate "
             "at one instruction a cycle.", ""]
            + startup_lines(counts)), counts
