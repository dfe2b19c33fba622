"""``points``: the light at points of a room from eight positioned probes, each method's
error against its cost (``shlight bench --sections points``; docs/probes.md).

In the analytic room of :mod:`.room` (exact light at any point), eight probes' panoramas and
40 random points (10 with ``--quick``): one probe in the middle, the nearest probe, inverse
distance, Unity's tetrahedra (:mod:`provider.core.probes.tetrahedra`), and the parallax
through the room's box (:mod:`provider.core.probes.parallax`) at 16, 32 and 64 rows, also
with the box typed 10 and 30 cm too large (a tape measure's mistakes). Error: relative RMS
irradiance over normals against the exact SH9 at the point, median and 90th percentile; cost:
the median time per point on one core (the tetrahedra's once-per-set cost apart).
"""
from __future__ import annotations

import time

import numpy as np

from ..core.geometry import sh
from ..core.geometry.projections import Equirect
from ..core.probes import Box, Tetrahedra, blend, inverse_distance, nearest, reproject
from . import room
from .common import _progress


def _timed(fn, repeat: int = 3):
    best, value = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        value = fn()
        best = min(best, time.perf_counter() - t0)
    return value, best


def bench_points(hdri, out, args) -> list[dict]:
    quick = args.quick
    probe_rows = 64 if quick else 128
    images = [room.panorama(p, probe_rows) for p in room.PROBES]
    weights = Equirect(2 * probe_rows, probe_rows).sh_weights
    coefficients = np.array([weights.T @ i.reshape(-1, 3).astype(np.float64) for i in images])
    points = room.random_points(10 if quick else 40)
    _progress(f"  points: the exact light at {len(points)} points")
    exact = [room.exact_sh9(x, 128 if quick else 256) for x in points]
    tetrahedra, once = _timed(lambda: Tetrahedra(room.PROBES))
    middle = room.exact_sh9((room.LO + room.HI) / 2, 128 if quick else 256)
    rows = []

    def measure(name, estimate, note=""):
        errors, times = [], []
        for x, ref in zip(points, exact):
            c, dt = _timed(lambda: estimate(x), 1 if quick else 3)
            errors.append(sh.irradiance_error(c, ref))
            times.append(dt)
        rows.append({"method": name, "median": float(np.median(errors)),
                     "p90": float(np.percentile(errors, 90)), "max": float(max(errors)),
                     "ms": 1e3 * float(np.median(times)), "note": note})
        _progress(f"  points: {name}: {rows[-1]['median']:.1%} median")

    measure("one probe in the middle", lambda x: middle, "the room's own light there")
    measure("the nearest probe", lambda x: blend(coefficients, nearest(room.PROBES, x)))
    measure("inverse distance²", lambda x: blend(coefficients,
                                                  inverse_distance(room.PROBES, x)))
    inside = sum(tetrahedra.weights(x)[1] for x in points)
    measure("tetrahedra (Unity's; no room)",
            lambda x: blend(coefficients, tetrahedra.weights(x)[0]),
            f"{inside} of {len(points)} points inside the hull; the tetrahedra once: "
            f"{1e3 * once:.1f} ms")
    for height in (16, 32, 64):
        w = Equirect(2 * height, height).sh_weights
        box = Box(room.LO, room.HI)
        measure(f"parallax through the box, {height} rows",
                lambda x, w=w, box=box, h=height:
                w.T @ reproject(x, room.PROBES, images, box, h).reshape(-1, 3))
    for off in (0.1, 0.3):
        w = Equirect(128, 64).sh_weights
        box = Box(room.LO - off, room.HI + off)
        measure(f"parallax, 64 rows, the box {100 * off:.0f} cm too large on every side",
                lambda x, w=w, box=box:
                w.T @ reproject(x, room.PROBES, images, box, 64).reshape(-1, 3))
    _write(out, rows, len(points), probe_rows, quick)
    return rows


def _write(out, rows, n, probe_rows, quick) -> None:
    lines = [f"# The light at {n} points of a room from 8 probes",
             "", f"Analytic room (provider/bench/room.py: 6 × 3 × 5 m, two ceiling panels, a "
             f"window, matt walls); the probes' panoramas {2 * probe_rows} × {probe_rows}; "
             "relative RMS irradiance error over normals against the exact SH9 at each point; "
             "time per point on one core." + (" --quick: rough numbers." if quick else ""),
             "", "| method | median | 90th pct | max | ms per point | note |",
             "|---|---:|---:|---:|---:|---|"]
    for r in rows:
        lines.append(f"| {r['method']} | {r['median']:.1%} | {r['p90']:.1%} | "
                     f"{r['max']:.1%} | {r['ms']:.2f} | {r['note']} |")
    (out / "points.md").write_text("\n".join(lines) + "\n")
