"""``--sections scenes``, lights: SH9 alone against ambient + directional lights
(``lights="auto"``, docs/contract.md §10) per real panorama, and what lights cost per frame.

Accuracy: irradiance against brute force ∫ L max(0, n·ω) dω summed over every pixel of the
full-resolution frame at 4096 Fibonacci normals (1024 with ``--quick``). *RMS*: relative
RMS over normals and RGB; *max*: the largest |E − T| / T at one normal (luminance), which
sits on the dark side of a bright source. *Engine*: what the engine itself reports per
frame (``sh9_error`` → ``light_error``, on its coarse copy).

Cost: ``SH9Projector.project`` with ``lights="auto"`` against the plain exact path
(``lights="off"``) on the same frame, interleaved medians on one core, as a ratio of the
extra time to the plain path: for the 512×256 float panoramas, and for 1920×960 8-bit sRGB
camera frames made from them (auto exposure; the sun clips, so fewer lights are found).
"""
from __future__ import annotations

import time
from pathlib import Path

from .common import _auto_exposure, _progress, _to_srgb8


def _interleaved_ms(fns, repeat):
    """Median wall-clock ms of each callable, timed in turn so both see the same machine
    load, and the median process CPU ms (less disturbed by other work on a shared machine;
    BLAS and OpenCV run on one thread here)."""
    for f in fns:
        f()
    wall, cpu = [[] for _ in fns], [[] for _ in fns]
    for _ in range(repeat):
        for i, f in enumerate(fns):
            c0, t0 = time.process_time(), time.perf_counter()
            f()
            wall[i].append(time.perf_counter() - t0)
            cpu[i].append(time.process_time() - c0)
    med = [sorted(t)[len(t) // 2] * 1e3 for t in wall + cpu]
    return med[:len(fns)], med[len(fns):]


def _spread(values) -> str:
    """"median 0.50 (0.40–0.70)"."""
    v = sorted(values)
    return f"median {v[len(v) // 2]:.2f} ({v[0]:.2f}–{v[-1]:.2f})"


def _errors(E, T):
    """(relative RMS, max per-normal relative luminance error) of E against truth T."""
    import numpy as np
    from ..core.geometry import sh
    from ..core.lights.extractor import LUMA
    EY, TY = E @ LUMA, T @ LUMA
    return sh.relative_rms(E, T), float(np.max(np.abs(EY - TY) / np.maximum(TY, 1e-30)))


def bench_lights(hdri, out: Path, args):
    import cv2
    import numpy as np
    from ..core.geometry import sh
    from ..core.sh9.engine import SH9Projector
    from ..core.radiometry.images import read_image
    from ..core.lights.extractor import LUMA
    from ..core.geometry.projections import Equirect
    from ..verify.pictures import brute_force_irradiance
    normals = sh.fibonacci_sphere(1024 if args.quick else 4096)
    repeat = max(3, args.repeat if not args.quick else 3)
    lines = ["# Lights: SH9 alone against ambient + directional lights", "",
             __doc__.split("\n\n", 1)[1].strip(), "",
             "| scene | SH9 RMS | SH9 max | A+L RMS | A+L max | Δ RMS (points) | lights kept "
             "(spread, level × mean, share of the flux) | engine: sh9_error → light_error "
             "| cost: plain ms | + lights ms | extra ÷ plain (wall / CPU) |",
             "|---|---:|---:|---:|---:|---:|---|---|---:|---:|---:|"]
    rows = []
    for path in hdri:
        _progress(f"bench lights {path.stem}")
        hdr = read_image(path)
        h, w = hdr.shape[:2]
        plain, lit = SH9Projector(w, h), SH9Projector(w, h, lights="auto")
        r = lit.project(hdr)
        pano = Equirect(w, h)
        flux = np.maximum(np.nan_to_num(hdr), 0) * pano.solid_angle[..., None]
        truth = brute_force_irradiance(pano.directions().reshape(-1, 3), flux.reshape(-1, 3),
                                       normals)
        e0 = _errors(r.irradiance(normals), truth)
        e1 = _errors(r.irradiance_with_lights(normals), truth)
        total = float(flux.reshape(-1, 3).sum(axis=0) @ LUMA)
        kept = "; ".join(f"{light.spread_deg:.1f}°, {light.level:g}×, "
                         f"{(light.irradiance @ LUMA) / total:.0%}" for light in r.lights)
        (t0, t1), (c0, c1) = _interleaved_ms([lambda: plain.project(hdr),
                                              lambda: lit.project(hdr)], repeat)
        rows.append((path.stem, e0, e1, len(r.lights), (t1 - t0) / t0, (c1 - c0) / c0))
        lines.append(
            f"| {path.stem} | {e0[0]:.2%} | {e0[1]:.1%} | **{e1[0]:.2%}** | {e1[1]:.1%} | "
            f"{100 * (e1[0] - e0[0]):+.2f} | {len(r.lights)}{': ' + kept if kept else ''} | "
            f"{r.stats['sh9_error']:.2%} → {r.stats['light_error']:.2%} | {t0:.2f} | "
            f"{t1 - t0:.2f} | {(t1 - t0) / t0:.2f} / {(c1 - c0) / c0:.2f} |")
    worst = max(100 * (x[2][0] - x[1][0]) for x in rows)
    best = min(x[2][0] / x[1][0] for x in rows if x[3])
    lines += ["", f"Worst change against SH9: {worst:+.2f} points of RMS (target: at most "
              f"+0.20). Largest improvement: A+L error {best:.2f} × SH9's. Extra cost of the "
              f"lights at {w}×{h} float: {_spread([x[4] for x in rows])} × the plain exact "
              f"path by wall clock, {_spread([x[5] for x in rows])} by CPU time.", ""]

    W, H = (640, 320) if args.quick else (1920, 960)
    lines += [f"## Cost on {W}×{H} 8-bit sRGB camera frames", "",
              "Each panorama resized, auto-exposed (median to 18 % grey) and encoded as an "
              "8-bit camera would; the engine builds the detection copy while it linearises "
              "the frame band by band.", "",
              "| scene | plain ms | + lights ms | extra ÷ plain (wall / CPU) | lights | clipped |",
              "|---|---:|---:|---:|---:|---:|"]
    plain, lit = SH9Projector(W, H), SH9Projector(W, H, lights="auto")
    extra = []
    for path in hdri:
        _progress(f"bench lights {path.stem} {W}×{H} uint8")
        hdr = cv2.resize(np.maximum(np.nan_to_num(read_image(path)), 0), (W, H),
                         interpolation=cv2.INTER_LINEAR)
        frame = _to_srgb8(hdr, _auto_exposure(hdr))
        r = lit.project(frame)
        (t0, t1), (c0, c1) = _interleaved_ms([lambda: plain.project(frame),
                                              lambda: lit.project(frame)], repeat)
        extra.append(((t1 - t0) / t0, (c1 - c0) / c0))
        lines.append(f"| {path.stem} | {t0:.2f} | {t1 - t0:.2f} | {(t1 - t0) / t0:.2f} / "
                     f"{(c1 - c0) / c0:.2f} | {len(r.lights)} | "
                     f"{r.stats['clipped_fraction']:.2%} |")
    lines += ["", f"Extra cost: {_spread([e[0] for e in extra])} × the plain exact path by "
              f"wall clock, {_spread([e[1] for e in extra])} by CPU time. With `--lights off` "
              "the exact path does no lights work at all (the tests hold its output "
              "bit-identical)."]
    (out / "lights.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
