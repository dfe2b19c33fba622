"""What runs on which Raspberry Pi: the edge page's table of boards, from the section's own
counts (instructions per frame, start-up instructions) and its memory run.

Every figure is an **estimate** from callgrind's x86-64 counts at one instruction a cycle
on one core (the frame's projection is one thread; the board's other cores take the camera,
the server and the clients): fps = clock / instructions per frame, start-up seconds =
clock / start-up instructions. An in-order Cortex-A53 (Zero 2 W, Pi 3) retires about one
instruction a cycle on such code; the out-of-order A72 (Pi 4) and A76 (Pi 5) more, so their
rows are floors. ``python -m provider.bench.edge --boards`` prints the table (it runs the
counts, the memory run and the start-up counts: ~15 min), ``shlight bench --sections edge``
adds it to its page.
"""
from __future__ import annotations

#: (board, CPU, clock GHz, memory MB, 64-bit OS?): the clock each board's firmware runs at
#: by default (the Pi 3 B+ at 1.4, the Pi 4 B at 1.8 since 2020's boards: their older
#: siblings at 1.2 and 1.5 GHz run ~15 % slower).
BOARDS = (
    ("Pi Zero 2 W", "4× Cortex-A53", 1.0, "512 MB", True),
    ("Pi 3 B+", "4× Cortex-A53", 1.4, "1 GB", True),
    ("Pi 4 B", "4× Cortex-A72", 1.8, "1-8 GB", True),
    ("Pi 5", "4× Cortex-A76", 2.4, "1-16 GB", True),
    ("Pi Zero (W)", "1× ARM1176 (ARMv6, no NEON)", 1.0, "512 MB", False),
)


def _fps(ghz: float, per_frame: float | None) -> str:
    return f"~{ghz * 1e9 / per_frame:.0f}" if per_frame else "n/a"


def board_lines(per_frame: dict, startup: dict | None = None,
                peak_mb: float | None = None) -> list:
    """Markdown lines: one row a board. ``per_frame``: workload name ("theta", "cube", "pi")
    -> x86-64 instructions a frame; ``startup``: the start-up counts
    (:func:`provider.bench.edge_startup.startup_instructions`); ``peak_mb``: the memory
    run's peak with the tables built."""
    theta, cube, pi = (per_frame.get(k) for k in ("theta", "cube", "pi"))
    both = theta + cube if theta and cube else None
    lines = ["| board (OS) | CPU, clock | memory | Theta S SH9 + lights, est. fps | "
             "+ its 32² cube, est. fps | Pi camera 640×480 SH9, est. fps | "
             "start-up, first / cached, est. s |", "|---|---|---|---:|---:|---:|---:|"]
    for board, cpu, ghz, memory, arm64 in BOARDS:
        if not arm64:
            lines.append(f"| {board} (32-bit only) | {cpu}, {ghz:g} GHz | {memory} | "
                         "not estimated | not estimated | not estimated | not estimated |")
            continue
        start = (f"{startup['first'] / (ghz * 1e9):.0f} / {startup['second'] / (ghz * 1e9):.1f}"
                 if startup else "n/a")
        lines.append(f"| {board} (64-bit) | {cpu}, {ghz:g} GHz | {memory} | "
                     f"{_fps(ghz, theta)} | {_fps(ghz, both)} | {_fps(ghz, pi)} | {start} |")
    counts = ", ".join(f"{k} {v / 1e6:.1f} M" for k, v in per_frame.items() if v)
    lines += ["", f"Estimates at one instruction a cycle on one core, from x86-64 counts "
              "(the cube's column: SH9 + lights and the cube update summed, each with its "
              "own decode, where serve shares one; callgrind; instructions a frame: "
              f"{counts}"
              + (f"; start-up {startup['first'] / 1e9:.2f} G first, "
                 f"{startup['second'] / 1e9:.2f} G cached" if startup else "") + ")."]
    if peak_mb:
        lines.append(f"Memory: the Theta S SH9 + lights and cube process peaks at {peak_mb:.0f} "
                     "MB resident with its tables built (the memory run above, x86-64).")
    return lines
