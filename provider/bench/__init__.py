"""`shlight bench`: speed against error, on one core, as ratios to a floor.

The floor is reading the frame once (``cv2.sumElems`` on the same frame, same run): these
machines are shared and noisy, so only ratios measured side by side mean anything.

Sections (all written to ``--out``, default ./bench-results):

* ``speed_vs_error.md`` / ``.png``: time per frame and relative RMS irradiance error of each
  path (exact, the linear-domain fast paths, the paper's 8-bit 64×48 pipeline) for frame
  sizes 640×320, 1920×960, 3840×1920, uint8 and float. Test frames are the real panoramas
  shipped in provider/data/hdri, resized; the error is against the float64 exact projection
  of the *same* frame, and for uint8 also against the HDR original (what clipping costs).
* ``fisheye_edge.md``: the edge workloads (a Theta S 1280×720 dual-fisheye 8-bit frame's
  SH9 with lights, its 32² cube update, a Pi camera's 640×480 fisheye exact and
  ``--downsample 2``): time, and instructions per frame counted by ``valgrind
  --tool=callgrind`` ((4 frames − 1 frame) / 3), with the fps they mean on a 1 GHz in-order
  core (an estimate; see :mod:`provider.bench.edge`); the count is most of a run's time, so
  ``--quick`` skips it unless ``--instructions``; without valgrind the section says so;
  and the peak and steady resident memory and build CPU time of a process serving the Theta
  S SH9 + lights and its cube, with the table cache off, writing and reading.
* ``fisheye_fill.md``: error of each lower-hemisphere fill model on the real panoramas.
* ``scenes.md``: per real panorama, what SH9 itself misses (truncation error against
  brute-force irradiance), whether order 2 rings negative, what ``--dering auto`` costs,
  and which order ``--order auto`` keeps.
* ``lights.md`` (with ``scenes``): per real panorama, SH9 alone against ambient +
  directional lights (``--lights auto``), RMS and max error, the lights kept, and the
  per-frame cost of the lights as a ratio to the plain exact path (see
  :mod:`provider.bench.lights`).
* ``radiometry.md`` / ``.png`` (only with ``--sections radiometry``, see
  :mod:`provider.bench.radiometry`): a simulated 8-bit camera on the real panoramas, one
  frame (sRGB-assumed, true curve, calibrated) and brackets against the HDR truth, and the
  per-frame cost of the live merged path.
* ``server.md`` / ``server.json`` (only with ``--sections server``, see
  :mod:`provider.bench.server`): frame-to-client latency p50/p99 of a real ``shlight serve``
  and the number of clients one core keeps at 30 Hz; then ``server_idle.md`` /
  ``server_idle.json`` (:mod:`provider.bench.idle`): the CPU of a server with no client.
* ``probes.md`` / ``.png`` (only with ``--sections probes``, see :mod:`provider.bench.probes`):
  mirror balls and angular maps rendered from the real panoramas against the panorama's
  own SH9: resolution, the unseen cone, the camera's reflection, perspective.
* ``environment.md`` / ``.png`` (only with ``--sections environment``, see
  :mod:`provider.bench.environment`): the reflection cube's cost per update against the SH9
  path, its error against a float64 brute force per size and roughness, and its bytes.
* ``shadows.md`` / ``.png`` (only with ``--sections shadows``, see
  :mod:`provider.bench.shadows`): a floating sphere's floor shadow per real panorama, by
  brute force against the light model (SH9 only, lights as points, lights as discs).
* ``points.md`` (only with ``--sections points``, see :mod:`provider.bench.points`): the
  light at 40 points of an analytic room from 8 probes, each method's error against its
  cost (the nearest probe, inverse distance, Unity's tetrahedra, parallax through the box).
* ``passthrough.md`` (only with ``--sections passthrough``, see
  :mod:`provider.bench.headset_sim`): a simulated headset's camera fitted against the sphere
  on perturbed rooms, ms per view against the error in stops, and the naive way's error.

Before it starts, the run lists the sections with what each costs; each section then says
when it starts and how long it took.
"""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from .common import SINGLE_CORE_ENV, _progress


def run(args) -> int:
    """Run the chosen sections (arguments: :mod:`provider.cli.bench`)."""
    # One core: BLAS and OpenCV threads must be pinned before numpy/cv2 start their pools.
    if any(os.environ.get(k) != v for k, v in SINGLE_CORE_ENV.items()):
        env = {**os.environ, **SINGLE_CORE_ENV}
        instructions = [] if args.instructions is None else \
            ["--instructions" if args.instructions else "--no-instructions"]
        argv = [sys.executable, "-m", "provider.cli", "bench"] + sys.argv[2:] \
            if len(sys.argv) > 1 and sys.argv[1] == "bench" else \
            [sys.executable, "-m", "provider.cli", "bench", "--out", args.out] + \
            (["--quick"] if args.quick else []) + ["--sections", args.sections, "--hdri", args.hdri,
                                                    "--repeat", str(args.repeat)] + instructions
        return subprocess.call(argv, env=env)
    import cv2
    cv2.setNumThreads(1)
    from ..core.errors import InputError
    out = Path(args.out)
    hdri = sorted(Path(args.hdri).glob("*.exr")) + sorted(Path(args.hdri).glob("*.hdr"))
    if not hdri:
        raise InputError(f"no .exr/.hdr panoramas in {args.hdri}")
    order = [s.strip() for s in args.sections.split(",") if s.strip()]
    unknown = set(order) - set(SECTION_COST_S)
    if unknown:
        raise InputError(f"unknown bench sections: {', '.join(sorted(unknown))} "
                         f"(sections: {', '.join(SECTION_COST_S)})")
    sections = [s for s in SECTION_COST_S if s in order]
    if args.instructions is None:       # callgrind is most of a quick run's time: opt in
        args.instructions = not args.quick
    out.mkdir(parents=True, exist_ok=True)
    costs = {s: _cost(s, args) for s in sections}
    _progress(f"shlight bench: {', '.join(f'{s} (~{_duration(c)})' for s, c in costs.items())}"
              f"; about {_duration(sum(costs.values()))} in all on a 2-core x86-64 "
              f"machine{' (--quick: rough numbers)' if args.quick else ''}")
    for i, name in enumerate(sections, 1):
        _progress(f"[{i}/{len(sections)}] {name}: {SECTION_WHAT[name]} (~{_duration(costs[name])})")
        t0 = time.monotonic()
        _SECTIONS[name](hdri, out, args)
        _progress(f"[{i}/{len(sections)}] {name} done in {_duration(time.monotonic() - t0)}")
    print(f"results in {out}/")
    return 0


#: What each section measures, and about what it costs (seconds, measured on this
#: project's 2-core x86-64 machine): (--quick, full); "edge" adds the callgrind count.
SECTION_WHAT = {
    "speed": "time per frame against irradiance error, per path and frame size",
    "edge": "Theta S frame + lights, 32² cube, Pi fisheye: instructions against a 1 GHz core",
    "fill": "fisheye fill models on the real panoramas",
    "scenes": "what SH9 misses on each real panorama; SH9 against ambient + lights",
    "server": "latency and clients per core of a real shlight serve, then its idle CPU",
    "radiometry": "a simulated 8-bit camera: one frame, calibrated, brackets, against HDR",
    "probes": "mirror balls and angular maps from the real panoramas against their SH9",
    "environment": "the reflection cube: cost against SH9, error against brute force, bytes",
    "shadows": "a floating sphere's floor shadow: brute force against the light model",
    "passthrough": "a simulated headset's camera fitted against the sphere: ms/view, stops",
    "points": "the light at 40 points of a room from 8 probes: each method's error and cost",
}
SECTION_COST_S = {"speed": (5, 40), "edge": (40, 55), "fill": (2, 10), "scenes": (20, 50),
                  "server": (20, 70), "radiometry": (20, 40), "probes": (15, 150),
                  "environment": (60, 400), "shadows": (15, 60), "passthrough": (30, 120),
                  "points": (15, 90)}
# valgrind runs Python and numpy under emulation: the frames' counts ~300 s, the start-up's
# (a first start builds 43 G instructions of tables) ~200 s more
INSTRUCTIONS_COST_S = (500, 500)


def _cost(section: str, args) -> float:
    quick = 0 if args.quick else 1
    cost = SECTION_COST_S[section][quick]
    if section == "edge" and args.instructions:
        cost += INSTRUCTIONS_COST_S[quick]
    return cost


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 100 else f"{seconds / 60:.1f} min"


def _speed(hdri, out, args):
    from .speed import bench_speed
    bench_speed(hdri, out, args)


def _edge(hdri, out, args):
    from .edge import bench_edge
    bench_edge(hdri, out, args)


def _fill(hdri, out, args):
    from .scenes import bench_fill
    bench_fill(hdri, out, args)


def _scenes(hdri, out, args):
    from .lights import bench_lights
    from .scenes import bench_scenes
    bench_scenes(hdri, out, args)
    bench_lights(hdri, out, args)


def _server(hdri, out, args):
    try:
        from . import server as server_bench
    except ImportError as exc:
        print(f"server benchmark unavailable: {exc}", file=sys.stderr)
    else:
        server_bench.main(["--out", str(out)] + (["--quick"] if args.quick else []))
    from .idle import bench_idle    # what the server costs with no client at all
    bench_idle(out, args.quick, _progress)


def _radiometry(hdri, out, args):
    from .radiometry import bench_radiometry
    bench_radiometry(hdri, out, args)


def _probes(hdri, out, args):
    from .probes import bench_probes
    bench_probes(hdri, out, args)


def _environment(hdri, out, args):
    from .environment import bench_environment
    bench_environment(hdri, out, args)


def _shadows(hdri, out, args):
    from .shadows import bench_shadows
    bench_shadows(hdri, out, args)


def _points(hdri, out, args):
    from .points import bench_points
    bench_points(hdri, out, args)


def _passthrough(hdri, out, args):
    from .headset_sim import bench_passthrough
    bench_passthrough(hdri, out, args)


_SECTIONS = {"speed": _speed, "edge": _edge, "fill": _fill, "scenes": _scenes, "server": _server,
             "radiometry": _radiometry, "probes": _probes, "environment": _environment,
             "shadows": _shadows, "passthrough": _passthrough, "points": _points}
