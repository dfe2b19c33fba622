"""``--sections edge``: the edge device's frames against a 1 GHz in-order core's budget.

Three workloads, each counted in instructions by valgrind's callgrind as the difference
between a run of 4 frames and a run of 1 (start-up and the first frame cancel out), divided
by 3 — the steady-state instructions of one frame:

* **theta**: SH9 with lights (``lights="auto"``) of a Ricoh Theta S live frame (1280×720
  dual fisheye, 8-bit) of a lit room, whose ceiling panels the extractor takes as lights
  (:mod:`provider.bench.edge_frames`);
* **cube**: a 32² reflection cube update of the same frame (its own decode);
* **pi**: SH9 of a Raspberry Pi camera's 640×480 fisheye frame (8-bit), exact and fast;
* **equirect**: SH9 of a 1920×960 equirect frame (8-bit; issue 44's one-pass kernel).

Each count is also given against reading the same frame once (``cv2.sumElems``, counted the
same way: :class:`PlainRead`), the floor any pass over its bytes stands on.

A 1 GHz in-order core (Cortex-A53: Pi Zero 2 W, Pi 3) retires roughly one instruction a
cycle on such code, so the frames per second it means is ``1e9 / instructions``: an
*estimate* (x86-64 instructions with SIMD, counted here; ARM NEON is narrower, memory
slower). Projectors are built once outside valgrind and pickled into the counted runs, so
the count costs seconds, not the minutes the precomputation would take under emulation.
Without valgrind the section says so and reports times only. ``python -m
provider.bench.edge --calls theta`` lists the calls one frame makes instead (no valgrind).

With the counts comes each frame's **DRAM traffic** (issue 44): valgrind's cachegrind with a
Cortex-A53's caches (32 KB L1s, the Pi Zero 2 W's and Pi 3's 512 KB L2 as the last level),
the last-level misses of 4 frames minus 1, over 3, times 64 B a line (fills; write-backs are
not simulated), for each workload and for the Theta frame's SH9 fold alone (its decode and
its weights: what its tables cost). ``python -m provider.bench.edge --traffic`` prints them.

The section also measures what the edge board's 512 MB must hold: a process that builds the
Theta S SH9 + lights and 32² cube projectors and projects frames, its peak and steady
resident memory and the CPU seconds of its build, with the table cache
(:mod:`provider.core.table_cache`) off, then on (a first start writes, a later one reads);
``python -m provider.bench.edge --memory`` prints just that, and ``--startup`` the
instructions of a first start and of a second one that reads the cache
(:mod:`provider.bench.edge_startup`).
"""
from __future__ import annotations

import os
import pickle
import shutil
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

from .common import SINGLE_CORE_ENV, _median_ms, _progress

#: The folder that holds the ``provider`` package (for the profiled subprocess).
PACKAGE_ROOT = Path(__file__).resolve().parents[2]

#: Frames of the two counted runs: (4 − 1) frames' instructions / 3 = one frame's.
FRAMES_LONG, FRAMES_SHORT = 4, 1
#: Instructions a 1 GHz core at ~1 instruction per cycle retires in a second.
EDGE_IPS = 1e9

_CALLGRIND_SNIPPET = r"""
import gc, pickle, sys, weakref
import cv2
cv2.setNumThreads(1)
with open(sys.argv[1], "rb") as fh:
    work, frame = pickle.load(fh)
if hasattr(work, "_clipped"):      # its weak proxy to the projector unpickles as a copy
    work._clipped.p = weakref.proxy(work)
n = int(sys.argv[2])
work.project(frame)                      # the first frame: lazy tables, caches
# A collection now, not one during the counted frames: where the import's garbage crosses
# the collector's threshold shifts with any module's size (a 1-frame run cost 63 k
# instructions more than a 4-frame one, a 256×128 plain read a third of that).
gc.collect()
for _ in range(n):
    work.project(frame)
"""


class PlainRead:
    """The floor a frame's projection is measured against: reading its bytes once
    (``cv2.sumElems``), counted by callgrind as the workloads are."""

    def project(self, frame):
        import cv2
        return cv2.sumElems(frame)


def plain_read() -> PlainRead:
    """A :class:`PlainRead` of the importable module: under ``python -m`` this file runs as
    ``__main__``, whose classes the counted process could not unpickle."""
    from .edge import PlainRead as importable
    return importable()


def edge_frame(width: int, height: int, seed: int = 0):
    """A deterministic 8-bit test frame: smooth walls, noise and one small clipped lamp per
    lens (what makes the lights' extractor do its work)."""
    import cv2
    import numpy as np
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width]
    walls = (80 + 60 * np.sin(x / (width / 14.0))[..., None]
             + 40 * np.cos(y / (height / 10.0))[..., None])
    frame = np.clip(walls + rng.integers(0, 20, (height, width, 3)), 0, 255).astype(np.uint8)
    r = max(2, width // 100)
    cv2.circle(frame, (int(width * 0.23), int(height * 0.28)), r, (255, 255, 255), -1)
    cv2.circle(frame, (int(width * 0.70), int(height * 0.40)), r, (255, 240, 200), -1)
    return frame


class FoldOnly:
    """The SH9 fold's own pass of a folded projector's 8-bit frame (the C kernel's decode and
    products, no lights, no clipping tally): what the fold's weights cost a frame. Has the
    ``project(frame)`` the counted runs call; pickles with its projector."""

    def __init__(self, projector):
        self.p = projector

    def project(self, frame):
        import numpy as np
        fold = self.p._fold
        state = fold.new()
        fold.decode_project(frame, self.p._lut(np.uint8), state)
        return fold.coefficients(state)


def edge_workloads() -> dict:
    """name -> (description, projector builder, frame): the section's counted workloads."""
    from ..core.sh9.engine import SH9Projector
    from ..core.reflections.environment import EnvironmentProjector
    from .edge_frames import lit_theta_frame
    theta = lit_theta_frame(1280, 720)
    pi = edge_frame(640, 480, seed=1)
    equirect = edge_frame(1920, 960, seed=2)
    return {
        "theta": ("Theta S 1280×720 dual fisheye, SH9 + lights",
                  lambda: SH9Projector(1280, 720, "dual-fisheye", lights="auto"), theta),
        "cube": ("Theta S 1280×720 dual fisheye, 32² cube update",
                 lambda: EnvironmentProjector(1280, 720, "dual-fisheye", size=32), theta),
        "pi": ("Pi camera 640×480 fisheye, SH9 exact",
               lambda: SH9Projector(640, 480, "fisheye"), pi),
        "pi-fast": ("Pi camera 640×480 fisheye, SH9 --downsample 2",
                    lambda: SH9Projector(640, 480, "fisheye", downsample=2), pi),
        "equirect": ("equirect 1920×960, SH9 exact",
                     lambda: SH9Projector(1920, 960), equirect),
    }


_MEMORY_SNIPPET = r"""
import json, time
from provider.bench.edge import edge_workloads
workloads = edge_workloads()
t0 = time.process_time()
sh9, cube = (workloads[name][1]() for name in ("theta", "cube"))
build = time.process_time() - t0
frame = workloads["theta"][2]
for _ in range(3):                   # as serve --environment: one decode for both
    work = cube.new_work(sh9)
    sh9.project(frame, work=work)
    cube.project(frame, work=work)
status = dict(line.split(":", 1) for line in open("/proc/self/status"))
print(json.dumps({"build_cpu_s": build, "peak_mb": int(status["VmHWM"].split()[0]) / 1024,
                  "steady_mb": int(status["VmRSS"].split()[0]) / 1024}))
"""
#: The memory runs: (what, SHLIGHT_TABLE_CACHE); the cache's runs share one fresh folder.
MEMORY_RUNS = (("tables built (`--no-table-cache`)", "0"),
               ("first start: tables built and written to the cache", "1"),
               ("later start: tables read from the cache", "1"))


def memory_and_startup() -> list:
    """[(what, build CPU s, peak MB, steady MB)] of a process that builds the Theta S SH9 +
    lights and 32² cube projectors and projects three frames, as ``serve`` does: with the
    table cache off, then twice with it on (the second start reads the tables)."""
    import json
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for what, switch in MEMORY_RUNS:
            env = {**os.environ, **SINGLE_CORE_ENV, "PYTHONPATH": str(PACKAGE_ROOT),
                   "SHLIGHT_CACHE_DIR": tmp, "SHLIGHT_TABLE_CACHE": switch}
            out = subprocess.run([sys.executable, "-c", _MEMORY_SNIPPET], env=env, check=True,
                                 capture_output=True, text=True).stdout
            got = json.loads(out.strip().splitlines()[-1])
            rows.append((what, got["build_cpu_s"], got["peak_mb"], got["steady_mb"]))
    return rows


#: OpenBLAS's kernels that need AVX-512 (OPENBLAS_CORETYPE names, lower case).
AVX512_CORETYPES = ("skylakex", "cooperlake", "sapphirerapids")


def _callgrind_total(pickled: Path, frames: int, tmp: Path) -> int:
    script = tmp / "edge_frames.py"
    script.write_text(_CALLGRIND_SNIPPET)
    outfile = tmp / f"cg.{frames}.out"
    cmd = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={outfile}",
           sys.executable, str(script), str(pickled), str(frames)]
    subprocess.run(cmd, check=True, capture_output=True, env=_valgrind_env())
    for line in outfile.read_text().splitlines():
        if line.startswith("totals:") or line.startswith("summary:"):
            return int(line.split()[1])
    raise RuntimeError("callgrind wrote no totals")


#: A Cortex-A53's caches as cachegrind simulates them (size, ways, line bytes): 32 KB L1s
#: and the Pi Zero 2 W's and Pi 3's 512 KB shared L2 as the last level.
A53_CACHES = ("--I1=32768,2,64", "--D1=32768,4,64", "--LL=524288,16,64")
LINE_BYTES = 64


def _cachegrind_misses(pickled: Path, frames: int, tmp: Path) -> int:
    """Last-level misses (instruction reads, data reads and writes) of ``frames`` frames
    after the first, through :data:`A53_CACHES`."""
    script = tmp / "edge_frames.py"
    script.write_text(_CALLGRIND_SNIPPET)
    outfile = tmp / f"cachegrind.{frames}.out"
    cmd = ["valgrind", "--tool=cachegrind", "--cache-sim=yes", "--branch-sim=no",
           *A53_CACHES, f"--cachegrind-out-file={outfile}",
           sys.executable, str(script), str(pickled), str(frames)]
    subprocess.run(cmd, check=True, capture_output=True, env=_valgrind_env())
    events = summary = None
    for line in outfile.read_text().splitlines():
        if line.startswith("events:"):
            events = line.split()[1:]
        elif line.startswith("summary:"):
            summary = [int(v) for v in line.split()[1:]]
    if events is None or summary is None:
        raise RuntimeError("cachegrind wrote no summary")
    got = dict(zip(events, summary))
    return got["ILmr"] + got["DLmr"] + got["DLmw"]


def dram_bytes_per_frame(projector, frame) -> float:
    """Steady-state bytes a frame of ``projector.project(frame)`` moves between a
    Cortex-A53-like 512 KB last-level cache and DRAM: cachegrind's last-level misses of
    FRAMES_LONG frames minus FRAMES_SHORT, over the difference, × 64 B a line (fills only:
    write-backs of dirty lines are not simulated)."""
    return LINE_BYTES * _per_frame(_cachegrind_misses, projector, frame)


def _per_frame(count, projector, frame) -> float:
    """``count(pickled work, frames, folder)`` of FRAMES_LONG frames minus FRAMES_SHORT,
    over the difference: the steady state of one frame, start-up and the first frame
    cancelled out."""
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        pickled = tmp / "work.pickle"
        with open(pickled, "wb") as fh:
            pickle.dump((projector, frame), fh, protocol=pickle.HIGHEST_PROTOCOL)
        long = count(pickled, FRAMES_LONG, tmp)
        short = count(pickled, FRAMES_SHORT, tmp)
    return (long - short) / (FRAMES_LONG - FRAMES_SHORT)


def _valgrind_env() -> dict:
    # One hash seed: a set's or dict's order, and so the count, varies ±1.5 % with it.
    env = {**os.environ, **SINGLE_CORE_ENV, "PYTHONPATH": str(PACKAGE_ROOT),
           "PYTHONHASHSEED": "0"}
    if env.get("OPENBLAS_CORETYPE", "").lower() in AVX512_CORETYPES:
        # valgrind runs no AVX-512: OpenBLAS forced onto such a kernel dies of SIGILL under
        # it; left to itself, it picks a kernel for the CPU valgrind emulates
        del env["OPENBLAS_CORETYPE"]
    return env


def instructions_per_frame(projector, frame) -> float:
    """Steady-state x86-64 instructions of ``projector.project(frame)``: callgrind's count
    of FRAMES_LONG frames minus FRAMES_SHORT, over the difference."""
    return _per_frame(_callgrind_total, projector, frame)


def calls_per_frame(projector, frame) -> tuple[Counter, Counter]:
    """What one steady-state ``projector.project(frame)`` calls (``sys.setprofile``):
    (calls into C by calling function, Python-level calls by function), each keyed
    ``"module.py:function"``. Deterministic, unlike time: each C call costs thousands of
    instructions of argument parsing and array wrapping whatever its size (issue 34)."""
    projector.project(frame)                 # the first frame: lazy tables, caches
    c_calls, py_calls = Counter(), Counter()

    def where(code):
        return f"{code.co_filename.rsplit('/', 1)[-1]}:{code.co_name}"

    def profile(fr, event, arg):
        if event == "c_call":
            c_calls[where(fr.f_code)] += 1
        elif event == "call":
            py_calls[where(fr.f_code)] += 1

    sys.setprofile(profile)
    try:
        projector.project(frame)
    finally:
        sys.setprofile(None)
    return c_calls, py_calls


def lens_fold_kernel() -> bool:
    """Whether the C fold kernel is built (the fold-alone count needs it)."""
    from ..core.sh9 import lens_fold
    return lens_fold.KERNEL


def valgrind_missing() -> str | None:
    """Why instructions cannot be counted here, or None."""
    if shutil.which("valgrind") is None:
        return "valgrind is not installed (apt-get install valgrind): instructions not counted"
    return None


def bench_edge(hdri, out: Path, args):
    import cv2
    repeat = 5 if args.quick else 30
    workloads = edge_workloads()
    missing = valgrind_missing()
    count = args.instructions and missing is None
    counted, memory_rows = {}, []          # for the boards' table (provider.bench.edge_boards)
    traffic = {}
    lines = ["# Edge device: instructions per frame against a 1 GHz core", "",
             "One core. At about one instruction per cycle, a 1 GHz in-order core (Cortex-A53: "
             "Pi Zero 2 W, Pi 3) has ~33 M instructions per frame at 30 fps. The fps column is "
             "an **estimate**: 10⁹ / instructions per frame (x86-64 instructions with SIMD "
             "counted by callgrind; ARM's NEON is narrower and its memory slower).", "",
             "| workload | ms/frame (this machine) | × floor | instructions/frame | "
             "× read | est. fps at 1 GHz | DRAM MB/frame (A53 caches) |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    reads = {}                      # frame shape -> instructions of one plain read
    for name, (what, build, frame) in workloads.items():
        _progress(f"bench edge {name}")
        projector = build()
        floor = _median_ms(lambda: cv2.sumElems(frame), repeat)
        ms = _median_ms(lambda: projector.project(frame), repeat)
        if count:
            _progress(f"bench edge {name}: callgrind ({FRAMES_LONG} and {FRAMES_SHORT} frames)")
            per = counted[name] = instructions_per_frame(projector, frame)
            if frame.shape not in reads:
                reads[frame.shape] = instructions_per_frame(plain_read(), frame)
            ins, fps = f"{per / 1e6:.1f} M", f"~{EDGE_IPS / per:.0f}"
            read = f"{per / reads[frame.shape]:.1f}"
            _progress(f"bench edge {name}: cachegrind, A53 caches")
            traffic[name] = dram_bytes_per_frame(projector, frame)
            dram = f"{traffic[name] / 1e6:.1f}"
        elif missing:
            ins, read, fps, dram = "n/a (valgrind not installed)", "n/a", "n/a", "n/a"
        else:
            ins, read, fps, dram = ("not counted (--instructions counts them)", "n/a", "n/a",
                                    "n/a")
        lines.append(f"| {what} | {ms:.2f} | {ms / floor:.1f} | {ins} | {read} | {fps} | {dram} |")
    lines += ["", "Instructions: `valgrind --tool=callgrind`, the difference between "
              f"{FRAMES_LONG} frames and {FRAMES_SHORT} frame divided by "
              f"{FRAMES_LONG - FRAMES_SHORT} (start-up cancels out). × floor: time over "
              "`cv2.sumElems` of the same frame (reading it once), measured in the same run; × "
              "read: instructions over those of that read, counted the same way."]
    if traffic:
        lines += ["", "DRAM traffic: `valgrind --tool=cachegrind` with a Cortex-A53's caches (" +
                  ", ".join(A53_CACHES) + "), last-level misses × 64 B, the same difference "
                  "of frames; the frame itself is its width × height × 3 bytes."]
        if "theta" in workloads and lens_fold_kernel():
            _progress("bench edge: the Theta frame's SH9 fold alone (cachegrind)")
            p, frame = workloads["theta"][1](), workloads["theta"][2]
            fold = FoldOnly(p)
            lines += [f"The Theta frame's SH9 fold alone (decode and weights, "
                      f"{frame.nbytes / 1e6:.2f} MB of frame): "
                      f"{dram_bytes_per_frame(fold, frame) / 1e6:.2f} MB a frame, "
                      f"{instructions_per_frame(fold, frame) / 1e6:.1f} M instructions; its "
                      f"weights {p._fold.table_floats * 4 / 1e6:.2f} MB."]
    if missing:
        lines += ["", missing + "."]
    if {"theta", "cube"} <= set(workloads) and sys.platform.startswith("linux"):
        _progress("bench edge: memory and start-up (three processes)")
        lines += ["", "## Memory and start-up: Theta S SH9 + lights and its 32² cube", "",
                  "One process builds both projectors and projects three frames, as `shlight "
                  "serve --environment --lights auto` does; peak and steady resident memory "
                  "(VmHWM, VmRSS) and the CPU seconds of the build (this machine).", "",
                  "| start | build CPU s | peak RSS MB | steady RSS MB |", "|---|---:|---:|---:|"]
        memory_rows = memory_and_startup()
        for what, cpu, peak, steady in memory_rows:
            lines.append(f"| {what} | {cpu:.2f} | {peak:.0f} | {steady:.0f} |")
    if count:
        lines += _startup_and_boards(counted, memory_rows)
    (out / "fisheye_edge.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def main(argv=None) -> int:
    """``python -m provider.bench.edge [--calls] [workload ...]``: print instructions per
    frame, or (``--calls``) the calls one frame makes, by calling function; ``--memory``:
    the memory and start-up runs."""
    import argparse
    workloads = edge_workloads()
    parser = argparse.ArgumentParser(
        prog="python -m provider.bench.edge",
        description="Instructions per frame of the edge workloads (valgrind's callgrind), "
                    "or with --calls the calls one frame makes, by calling function.")
    parser.add_argument("workloads", nargs="*", metavar="WORKLOAD",
                        help="any of: " + ", ".join(workloads) + " (default: all)")
    parser.add_argument("--calls", action="store_true",
                        help="count the calls into C and Python a frame makes, not instructions")
    parser.add_argument("--memory", action="store_true",
                        help="build CPU, peak and steady RSS: cache off, first start, later start")
    parser.add_argument("--startup", action="store_true",
                        help="instructions of a first start and of a second one reading "
                             "the table cache (callgrind)")
    parser.add_argument("--boards", action="store_true",
                        help="what runs on which Raspberry Pi: counts, memory and start-up "
                             "(~15 min)")
    parser.add_argument("--traffic", action="store_true",
                        help="DRAM bytes a frame through a Cortex-A53's caches (cachegrind), "
                             "not instructions")
    args = parser.parse_args(argv)
    if args.boards:
        return _print_boards()
    if args.startup:
        return _print_startup()
    if args.memory:
        for what, cpu, peak, steady in memory_and_startup():
            print(f"{what}: build {cpu:.2f} s CPU, peak {peak:.0f} MB, steady {steady:.0f} MB")
        return 0
    unknown = [n for n in args.workloads if n not in workloads]
    if unknown:
        parser.error(f"no workload {', '.join(unknown)}: choose from {', '.join(workloads)}")
    names = args.workloads or list(workloads)
    if args.calls:
        for name in names:
            what, build, frame = workloads[name]
            c_calls, py_calls = calls_per_frame(build(), frame)
            print(f"{name}: {what}: {sum(c_calls.values())} calls into C, "
                  f"{sum(py_calls.values())} Python calls a frame; C calls from:")
            for where, n in c_calls.most_common(12):
                print(f"  {n:5d}  {where}")
        return 0
    missing = valgrind_missing()
    if missing:
        print(missing)
        return 1
    for name in names:
        what, build, frame = workloads[name]
        if args.traffic:
            per = dram_bytes_per_frame(build(), frame)
            print(f"{name}: {what}: {per / 1e6:.2f} MB a frame between a 512 KB last-level "
                  f"cache and DRAM (the frame: {frame.nbytes / 1e6:.2f} MB)", flush=True)
            continue
        per = instructions_per_frame(build(), frame)
        read = instructions_per_frame(plain_read(), frame)
        print(f"{name}: {what}: {per / 1e6:.1f} M instructions/frame "
              f"({per / read:.1f}× a plain read of the frame, {read / 1e6:.2f} M), "
              f"~{EDGE_IPS / per:.0f} fps at 1 GHz (estimate)", flush=True)
    return 0


def _startup_and_boards(counted: dict, memory_rows: list) -> list:
    """The page's start-up section (provider.bench.edge_startup) and its table of boards
    (provider.bench.edge_boards) from this run's counts."""
    from .edge_boards import board_lines
    from .edge_startup import startup_section
    lines, startup = startup_section()
    peak = memory_rows[0][2] if memory_rows else None
    return lines + ["", "## What runs on which Raspberry Pi (estimates)", ""] + board_lines(
        counted, startup, peak)


def _print_boards() -> int:
    """``--boards``: count the workloads, the memory run and the start-up, print the table."""
    from .edge_boards import board_lines
    from .edge_startup import startup_instructions
    missing = valgrind_missing()
    if missing:
        print(missing)
        return 1
    workloads = edge_workloads()
    counted = {name: instructions_per_frame(workloads[name][1](), workloads[name][2])
               for name in ("theta", "cube", "pi")}
    rows = memory_and_startup()
    print("\n".join(board_lines(counted, startup_instructions(), rows[0][2])))
    return 0


def _print_startup() -> int:
    """``--startup``: the start-up section's table (provider.bench.edge_startup)."""
    from .edge_startup import startup_instructions, startup_lines
    missing = valgrind_missing()
    if missing:
        print(missing)
        return 1
    print("\n".join(startup_lines(startup_instructions())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
