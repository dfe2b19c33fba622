"""``shlight bench --sections server``: frame-to-client latency and clients per core.

A real ``shlight serve`` subprocess (the demo source at 30 fps, every frame sent:
``--change-threshold 0``) is pinned to one CPU; this process, pinned to the other CPUs
where there are any, connects WebSocket clients in steps (25, 50, 100, ...). For each
step it records, over a few seconds:

* messages per second each client received (median and 5th percentile);
* frame-to-client latency, p50 and p99: receive time − the message's ``time`` (the
  capture time of its frame), so it covers projection, fan-out and the socket;
* the server's CPU use (from /proc: all its threads), as a fraction of one core.

A step *holds* when the median client gets ≥ 90 % of the source's frame rate and the
slowest 5 % get ≥ 75 %. The report gives the largest step that held and an estimate of
the clients one core holds at 30 Hz from a straight-line fit of the server's CPU use
against the client count (CPU = a + b·N, so N = (1 − a)/b). Written to
``OUT/server.md`` and ``OUT/server.json``. Then :mod:`provider.bench.faults`: 1,000 and
2,000 clients, plain, beside a flooding client, and with ``max_hz`` 30.

Run alone: ``python -m provider.bench.server --out DIR [--quick]``.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import threading
import time
from pathlib import Path

from .common import cpu_seconds, stop

_SEQ = re.compile(rb'"seq":(\d+)')
_TIME = re.compile(rb'"time":([0-9.eE+-]+)')
_SERVING = re.compile(r"serving wss?://[^ ]*:(\d+)/")


def _priority() -> None:
    """As root, run ahead of other work on a shared machine (nice −10), so that the numbers
    are the server's and not the neighbours'; otherwise leave the priority alone."""
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        try:
            os.nice(-10)
        except OSError:
            pass


def _loadavg() -> str:
    try:
        with open("/proc/loadavg") as f:
            return " ".join(f.read().split()[:3])
    except OSError:
        return "?"


def _pick_cpus():
    try:
        cpus = sorted(os.sched_getaffinity(0))
    except AttributeError:          # not Linux
        return None, None
    if len(cpus) < 2:
        return None, None
    return {cpus[0]}, set(cpus[1:])


def _start_server(fps: float, server_cpus, extra=()):
    argv = [sys.executable, "-m", "provider.cli", "serve", "--port", "0", "--source", "demo",
            "--fps", str(fps), "--change-threshold", "0", "--max-clients", "100000",
            "--log-level", "info", *extra]
    def preexec():
        if server_cpus:
            os.sched_setaffinity(0, server_cpus)
        _priority()
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            preexec_fn=preexec, cwd=Path(__file__).resolve().parents[2])
    found = {}
    ready = threading.Event()

    def drain():
        for line in proc.stdout:
            m = _SERVING.search(line)
            if m and "port" not in found:
                found["port"] = int(m.group(1))
                ready.set()
            if "Traceback" in line:
                found.setdefault("traceback", line)
        ready.set()
    threading.Thread(target=drain, daemon=True).start()
    ready.wait(60)
    if "port" not in found:
        proc.kill()
        raise RuntimeError("shlight serve did not start")
    return proc, found["port"]


def _pct(values, q):
    if not len(values):
        return float("nan")
    values = sorted(values)
    return values[min(len(values) - 1, int(round(q / 100 * (len(values) - 1))))]


def _run_steps(port: int, pid: int, steps, seconds: float, fps: float, progress, client_cpus):
    from .loadgen import LoadGenerator
    procs = max(2, len(client_cpus or ()))
    gen = LoadGenerator("127.0.0.1", port, "/", procs=procs, cpus=client_cpus)
    rows = []
    try:
        for n in steps:
            errors = gen.connect(n)
            if gen.clients < n:
                progress(f"  only {gen.clients} of {n} clients connected: {errors}")
                break
            time.sleep(1.0)                               # settle: backlog from connecting
            cpu0, t0 = cpu_seconds(pid), time.monotonic()
            counts, lats, gen_cpu = gen.measure(seconds)
            cpu1, t1 = cpu_seconds(pid), time.monotonic()
            wall = t1 - t0 - 0.2                          # the measurement's lead time
            rates = sorted(max(c, 0) / seconds for c in counts)
            row = {"clients": n, "seconds": round(seconds, 2),
                   "rate_median": round(_pct(rates, 50), 2), "rate_p5": round(_pct(rates, 5), 2),
                   "latency_p50_ms": round(_pct(lats, 50) * 1e3, 2),
                   "latency_p99_ms": round(_pct(lats, 99) * 1e3, 2),
                   "server_cpu": round((cpu1 - cpu0) / max(wall, 1e-3), 3),
                   "loadgen_cpu": round(gen_cpu / seconds, 3),
                   "loadgen_procs": procs, "dropped": sum(1 for c in counts if c < 0)}
            row["holds"] = bool(row["rate_median"] >= 0.9 * fps and row["rate_p5"] >= 0.75 * fps)
            rows.append(row)
            progress(f"  {n:5d} clients: {row['rate_median']:.1f} msg/s each (p5 "
                     f"{row['rate_p5']:.1f}), latency p50 {row['latency_p50_ms']:.1f} ms "
                     f"p99 {row['latency_p99_ms']:.1f} ms, server CPU "
                     f"{row['server_cpu'] * 100:.0f} % of a core, load generator "
                     f"{row['loadgen_cpu'] * 100:.0f} % ({procs} processes)")
            if not row["holds"] or row["server_cpu"] > 0.97:
                break
    finally:
        gen.close()
    return rows


def _fit(rows):
    """(a, b) of server CPU ≈ a + b·clients by least squares, or None."""
    pts = [(r["clients"], r["server_cpu"]) for r in rows if r["holds"]]
    if len(pts) < 2:
        return None
    n = len(pts)
    mx = sum(x for x, _ in pts) / n
    my = sum(y for _, y in pts) / n
    sxx = sum((x - mx) ** 2 for x, _ in pts)
    if sxx == 0:
        return None
    b = sum((x - mx) * (y - my) for x, y in pts) / sxx
    return my - b * mx, b


def measure(out: Path, quick: bool = False, fps: float = 30.0, progress=print,
            steps=None) -> dict:
    server_cpus, client_cpus = _pick_cpus()
    saved = os.sched_getaffinity(0) if client_cpus else None
    if client_cpus:
        os.sched_setaffinity(0, client_cpus)
    try:
        return _measure(out, quick, fps, progress, server_cpus, client_cpus, steps)
    finally:
        if saved:
            os.sched_setaffinity(0, saved)


def _measure(out: Path, quick, fps, progress, server_cpus, client_cpus, steps=None) -> dict:
    steps = steps or ([25, 100, 200] if quick else [25, 100, 200, 500, 1000, 1500])
    seconds = 2.0 if quick else 5.0
    proc, port = _start_server(fps, server_cpus)
    try:
        progress(f"server benchmark: demo source at {fps:g} fps, every frame sent; server on "
                 f"CPU {sorted(server_cpus) if server_cpus else 'any'}")
        time.sleep(1.0)
        rows = _run_steps(port, proc.pid, steps, seconds, fps, progress, client_cpus)
    finally:
        stop(proc)
    from .mqtt_path import measure_mqtt
    mqtt = measure_mqtt(_start_server, cpu_seconds, fps, seconds, server_cpus, client_cpus,
                        progress, counts=(1,) if quick else (1, 100))
    from .faults import measure_faults
    faults = measure_faults(_start_server, _pct, fps, (200,) if quick else (1000, 2000),
                            2.0 if quick else 3.0, server_cpus, client_cpus, progress)
    held = [r["clients"] for r in rows if r["holds"]]
    fit = _fit(rows)
    estimate = None
    if fit and fit[1] > 0 and fit[0] < 1:
        estimate = int((1 - fit[0]) / fit[1])
    limited_by_loadgen = bool(rows) and rows[-1]["loadgen_cpu"] > 0.9 * max(
        1, len(client_cpus or ()))
    base = next((r for r in rows if r["clients"] == 200), rows[-1] if rows else None)
    result = {"fps": fps, "steps": rows, "largest_step_held": max(held) if held else 0,
              "clients_per_core_estimate": estimate, "limited_by_load_generator": limited_by_loadgen,
              "latency_p50_ms": base and base["latency_p50_ms"],
              "latency_p99_ms": base and base["latency_p99_ms"],
              "latency_at_clients": base and base["clients"], "quick": quick, "mqtt": mqtt,
              "load": _loadavg(), "faults": faults}
    out.mkdir(parents=True, exist_ok=True)
    (out / "server.json").write_text(json.dumps(result, indent=2) + "\n")
    lines = ["# Server: frame-to-client latency and clients per core", "",
             f"`shlight serve`, demo source at {fps:g} fps with every frame sent, pinned to one "
             "CPU; clients in another process. Latency: receive time − frame capture time. "
             "A step holds when the median client gets ≥ 90 % of the frame rate and the "
             "slowest 5 % get ≥ 75 %. Server CPU per message: its CPU time divided by the "
             "messages the clients received (the figure least disturbed by other work on a "
             "shared machine)." + (" Quick run: rough numbers." if quick else ""), "",
             f"Load average when it ended: {result['load']}.", "",
             "| clients | msg/s per client (median) | p5 | latency p50 (ms) | latency p99 (ms) "
             "| server CPU (core) | server µs per message | load generator CPU (processes) "
             "| holds |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|:---:|"]
    for r in rows:
        per = r["server_cpu"] / max(r["clients"] * r["rate_median"], 1e-9) * 1e6
        lines.append(f"| {r['clients']} | {r['rate_median']:.1f} | {r['rate_p5']:.1f} | "
                     f"{r['latency_p50_ms']:.1f} | {r['latency_p99_ms']:.1f} | "
                     f"{r['server_cpu']:.2f} | {per:.1f} | {r['loadgen_cpu']:.2f} "
                     f"({r['loadgen_procs']}) | {'yes' if r['holds'] else 'no'} |")
    lines += ["", f"Largest step held at {fps:g} Hz: **{result['largest_step_held']} clients**."]
    if estimate is not None:
        lines.append(f"One core holds about **{estimate} clients** at {fps:g} Hz "
                     f"(server CPU ≈ {fit[0]:.3f} + {fit[1] * 1e3:.3f}e-3 × clients).")
    if limited_by_loadgen:
        lines.append("The load generator saturated its CPU first: the server holds at least "
                     "this many.")
    lines += ["", "## MQTT path", "",
              "`shlight serve --mqtt` → a local mosquitto (on the load generator's CPU) → "
              "paho subscribers. Latency: receive time at the subscriber − frame capture "
              "time. The server publishes one message per frame whatever the number of "
              "subscribers; the broker fans out.", ""]
    if "rows" in mqtt:
        lines += ["| subscribers | msg/s each (median) | latency p50 (ms) | latency p99 (ms) "
                  "| server CPU (core) | broker CPU (core) |", "|---:|---:|---:|---:|---:|---:|"]
        for r in mqtt["rows"]:
            lines.append(f"| {r['subscribers']} | {r['rate_median']:.1f} | "
                         f"{r['latency_p50_ms']:.1f} | {r['latency_p99_ms']:.1f} | "
                         f"{r['server_cpu']:.2f} | {r['broker_cpu']:.2f} |")
    else:
        lines.append(f"Skipped: {mqtt.get('skipped')}.")
    from .faults import markdown as faults_markdown
    lines += faults_markdown(faults, fps, result["load"])
    (out / "server.md").write_text("\n".join(lines) + "\n")
    progress(f"server: latency p50 {result['latency_p50_ms']} ms, p99 "
             f"{result['latency_p99_ms']} ms at {result['latency_at_clients']} clients; "
             f"one core holds ~{estimate} clients at {fps:g} Hz (largest step held: "
             f"{result['largest_step_held']})")
    return result


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m provider.bench.server", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", default="bench-results")
    p.add_argument("--quick", action="store_true")
    p.add_argument("--fps", type=float, default=30.0)
    p.add_argument("--steps", default=None, help="client counts, e.g. 200,500,1000")
    args = p.parse_args(argv)
    steps = [int(x) for x in args.steps.split(",")] if args.steps else None
    measure(Path(args.out), quick=args.quick, fps=args.fps, steps=steps)
    return 0


if __name__ == "__main__":
    sys.exit(main())
