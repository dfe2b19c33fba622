"""``--sections fill`` and ``--sections scenes``: accuracy on the real panoramas (fisheye
fill models; SH9 truncation, ringing, deringing and order choice)."""
from __future__ import annotations

from pathlib import Path

from .common import _progress


def fisheye_from_equirect(hdr, projection):
    """Resample an equirect panorama into a fisheye frame of ``projection`` (test input)."""
    import cv2
    import numpy as np
    h, w = hdr.shape[:2]
    d = projection.directions()
    theta = np.arccos(np.clip(d[..., 1], -1, 1))
    phi = np.arctan2(d[..., 0], -d[..., 2])
    mapx = ((phi / (2 * np.pi) + 0.5) * w - 0.5).astype(np.float32)
    mapy = (theta / np.pi * h - 0.5).astype(np.float32)
    fish = cv2.remap(np.maximum(hdr, 0), mapx, mapy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    fish[projection.solid_angle == 0] = 0
    return fish


def bench_fill(hdri, out: Path, args):
    import numpy as np
    from ..core.geometry import sh
    from ..core.sh9.engine import SH9Projector
    from ..core.radiometry.images import read_image
    from ..core.geometry.projections import Fisheye
    panoramas = [(p.stem, read_image(p)) for p in hdri]
    models = [("zero", 0.0)] + [(m, a) for m in ("ground", "mirror") for a in (0.05, 0.1, 0.2, 0.3)]
    names = [n for n, _ in panoramas]
    lines = ["# Fisheye (180°, looking up): error of the unseen-hemisphere models", "",
             "Relative RMS irradiance error over the whole sphere of normals against the full "
             "panorama, for a fisheye frame resampled from each real panorama.", "",
             "| model | albedo | " + " | ".join(names) + " | mean | max |",
             "|---|---:|" + "---:|" * (len(names) + 2)]
    truth = {n: SH9Projector(hdr.shape[1], hdr.shape[0]).project(hdr).coefficients
             for n, hdr in panoramas}
    size = 256 if args.quick else 512
    for model, albedo in models:
        _progress(f"bench fill {model} {albedo}")
        p = Fisheye(size, size, fill=model, albedo=albedo)
        proj = SH9Projector(size, size, p)
        errs = [sh.irradiance_error(proj.project(fisheye_from_equirect(hdr, p)).coefficients,
                                    truth[n]) for n, hdr in panoramas]
        lines.append(f"| {model} | {albedo:g} | " + " | ".join(f"{e * 100:.1f} %" for e in errs)
                     + f" | {np.mean(errs) * 100:.1f} % | {np.max(errs) * 100:.1f} % |")
    (out / "fisheye_fill.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def bench_scenes(hdri, out: Path, args):
    """SH9 truncation, ringing, deringing cost and the order auto choice per panorama."""
    import numpy as np
    from ..core.geometry import sh
    from ..core.sh9.engine import SH9Projector
    from ..core.radiometry.images import read_image
    from ..verify.pictures import brute_force_irradiance
    from ..core.geometry.projections import Equirect
    lines = ["# Real scenes: what SH9 misses, ringing, and what deringing costs", "",
             "Per panorama (512×256 float, provider/data/hdri). *Truncation*: relative RMS "
             "irradiance error of exact order-2 SH against brute-force irradiance "
             "(∫ L max(n·ω, 0) dω over every pixel) at 512 normals, and its largest error at one "
             "normal as a fraction of the mean irradiance; *min E*: the lowest order-2 "
             "irradiance over the sphere, as a fraction of the mean (negative = rings); "
             "*dering*: the sinc⁴ cutoff `--dering auto` chose and its irradiance change "
             "against exact order 2; *order auto*: the order `--order auto` keeps at the "
             "default 2 % budget and its error.", "",
             "| scene | truncation | max error | min E / mean | dering cutoff | dering cost "
             "| dering truncation | order auto | its error |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    normals = sh.fibonacci_sphere(512)
    for path in hdri:
        _progress(f"bench scenes {path.stem}")
        hdr = read_image(path)
        h, w = hdr.shape[:2]
        pano = Equirect(w, h)
        exact = SH9Projector(w, h).project(hdr)
        dered = SH9Projector(w, h, dering="auto").project(hdr)
        auto = SH9Projector(w, h, order="auto").project(hdr)
        flux = np.maximum(np.nan_to_num(hdr), 0) * pano.solid_angle[..., None]
        truth = brute_force_irradiance(pano.directions().reshape(-1, 3), flux.reshape(-1, 3),
                                       normals)
        E = sh.irradiance(exact.coefficients, normals)
        E_d = sh.irradiance(dered.coefficients, normals)
        rel = np.abs(E - truth).max() / np.abs(truth).mean()
        Es = sh.sphere_irradiance(exact.coefficients)
        min_rel = float((Es.min(axis=0) / Es.mean(axis=0)).min())
        cutoff = dered.stats["window_cutoff"]
        lines.append(
            f"| {path.stem} | {sh.relative_rms(E, truth) * 100:.1f} % | {rel * 100:.1f} % "
            f"| {min_rel:+.3f} | {'–' if cutoff is None else f'{cutoff:.2f}'} "
            f"| {dered.stats['order_error'] * 100:.2f} % | {sh.relative_rms(E_d, truth) * 100:.1f} % "
            f"| {auto.stats['order']} | {auto.stats['order_error'] * 100:.2f} % |")
    (out / "scenes.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
