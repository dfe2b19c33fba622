"""Idle cost of ``shlight serve``: CPU use with the demo source and no client at all.

A provider runs all day beside a Unity editor, so what it costs while nobody listens
matters as much as how many clients it holds. A real ``shlight serve`` subprocess (the
demo source at its default 30 fps, default options, default thread pools: what a user
runs) is started, left to settle, and its CPU time (all threads, from ``/proc/PID/stat``)
is read before and after a window of wall-clock time. Written to ``OUT/server_idle.md``
and ``OUT/server_idle.json``; ``shlight bench --sections server`` runs it after the load
steps.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

from .common import cpu_seconds, stop

_SERVING = re.compile(r"serving ws://[^ ]*:(\d+)/")


def _threads(pid: int) -> int:
    try:
        return len(os.listdir(f"/proc/{pid}/task"))
    except OSError:
        return 0


def measure_idle(seconds: float = 10.0, settle: float = 3.0, extra_args=(), env=None) -> dict:
    """CPU use of an idle ``shlight serve`` (demo source, no client), as a fraction of one
    core, over ``seconds`` after ``settle`` seconds of serving."""
    if not os.path.exists("/proc/self/stat"):
        raise RuntimeError("the idle measurement reads /proc (Linux only)")
    argv = [sys.executable, "-m", "provider.cli", "serve", "--port", "0", "--source", "demo",
            *extra_args]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=env)
    ready = threading.Event()
    lines: list[str] = []

    def drain():
        for line in proc.stdout:
            lines.append(line)
            if _SERVING.search(line):
                ready.set()
        ready.set()
    threading.Thread(target=drain, daemon=True).start()
    try:
        if not ready.wait(60) or proc.poll() is not None:
            raise RuntimeError("shlight serve did not start: " + "".join(lines[-5:]))
        time.sleep(settle)
        cpu0, t0 = cpu_seconds(proc.pid), time.monotonic()
        time.sleep(seconds)
        cpu1, t1 = cpu_seconds(proc.pid), time.monotonic()
        threads = _threads(proc.pid)
    finally:
        stop(proc)
    return {"cpu_fraction_of_one_core": round((cpu1 - cpu0) / (t1 - t0), 4),
            "seconds": round(t1 - t0, 2), "threads": threads,
            "command": " ".join(["shlight", *argv[3:]]),
            "cpus": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
            else os.cpu_count()}


def bench_idle(out: Path, quick: bool = False, progress=print) -> dict:
    """Measure, write ``server_idle.md`` / ``.json`` and return the result."""
    seconds = 5.0 if quick else 10.0
    progress(f"bench server idle: `shlight serve` (demo, no client) for {seconds:g} s "
             f"after a {3:g} s settle (about {seconds + 5:.0f} s)")
    # As a user runs it: without the one-core pinning this benchmark set for itself.
    from .common import SINGLE_CORE_ENV
    env = {k: v for k, v in os.environ.items() if k not in SINGLE_CORE_ENV}
    r = measure_idle(seconds, env=env)
    out.mkdir(parents=True, exist_ok=True)
    (out / "server_idle.json").write_text(json.dumps(r, indent=2) + "\n")
    lines = ["# Server at idle: demo source, no client", "",
             f"`{r['command']}` with default options and thread pools, on a machine with "
             f"{r['cpus']} CPUs: CPU time of all its threads (/proc) over {r['seconds']} s "
             "of wall time, after it served for 3 s.", "",
             "| CPU (% of one core) | threads |", "|---:|---:|",
             f"| {r['cpu_fraction_of_one_core'] * 100:.1f} % | {r['threads']} |"]
    (out / "server_idle.md").write_text("\n".join(lines) + "\n")
    progress(f"server idle: {r['cpu_fraction_of_one_core'] * 100:.1f} % of one core "
             f"({r['threads']} threads)")
    return r
