"""The reflections picture: spheres of roughness 0 → 1 lit by a real panorama through the shipped
image-based lighting (shaders/ibl.glsl), beside the CPU reference of the same formula.

Top: the panorama (centre looks along −Z). Then two rows of six spheres, perceptual roughness
0, 0.2, … 1: a metal (albedo 0, F0 0.95) and a red dielectric (albedo (0.8, 0.1, 0.08),
F0 0.04), each lit by SH9 diffuse plus the prefiltered cube's specular, rendered by the GLSL
shader in front of the environment (the cube's mip 0 along each camera ray, sampled on the
CPU). Last row: |shader − reference| / scale, the harness's error measure, as a heat map
scaled to the tolerance. The cube is the provider's (``compute_environment``) where
provider.core has it; until then mip 0 by nearest lookup of the panorama and 2×2 box mips.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from ..core.sh9.engine import compute_sh9
from ..core.radiometry.images import read_image
from . import cubemap, ibl
from .pictures import _display, _label

#: Roughness of the spheres, left to right.
ROUGHNESS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
#: (label, albedo, F0) of the two rows.
MATERIALS = (("metal", (0.0, 0.0, 0.0), (0.95, 0.95, 0.95)),
             ("red dielectric", (0.8, 0.1, 0.08), (0.04, 0.04, 0.04)))
#: Preferred panoramas for the docs picture (structure a reflection shows), in order.
PREFERRED = ("bridge", "venice", "lab")


def cube_description() -> str:
    try:
        from ..core.reflections.environment import compute_environment  # noqa: F401
    except ImportError:
        return "nearest mip 0 + box mips (stand-in)"
    return "compute_environment, GGX-prefiltered"


def reflections_picture(ctx, image: np.ndarray, title: str, size: int = 160,
                        cube_size: int = 32, eye=(0.0, 0.35, ibl.EYE_DISTANCE)):
    """(RGB uint8 picture, statistics) for one equirect panorama."""
    mips = cubemap.cube_from_equirect(image, cube_size)
    matrices = compute_sh9(image, error_estimate=False).matrices
    case = ibl.IblCase(f"picture:{title}", mips, matrices, dtype="f2")
    sampler = cubemap.CubeSampler(case.reference_mips())
    evaluator = ibl.IblEvaluator(ctx, "glsl")
    normals, views, mask, rays = ibl.sphere_view(size, eye, fov_y=48.0)
    background = sampler.sample(rays.reshape(-1, 3), 0.0)[0].reshape(size, size, 3)
    n, v = normals[mask], views[mask]
    shown, refs, errs = [], [], []
    cube = cubemap.upload_cube(ctx, mips, "f2")
    try:
        for _, albedo, f0 in MATERIALS:
            row = []
            for rough in ROUGHNESS:
                inputs = (n, v, np.broadcast_to(albedo, n.shape), np.broadcast_to(f0, n.shape),
                          np.full(len(n), rough))
                got = evaluator.evaluate(cube, len(mips), matrices, *inputs)
                want = ibl.reference(sampler, matrices, *inputs)
                img = background.copy()
                img[mask] = got["colour"]
                row.append(img)
                ref = background.copy()
                ref[mask] = want["colour"]
                refs.append(ref)
                err = np.zeros((size, size))
                err[mask] = (np.abs(got["colour"] - want["colour"]) / want["scale"]).max(-1)
                errs.append(err)
            shown.append(row)
    finally:
        cube.release()
    spheres = np.concatenate([np.stack(r)[:, mask] for r in shown], axis=None)
    exposure = 0.5 / max(float(np.median(spheres)), 1e-12)
    tol = case.tolerance()
    rows = []
    for (label, _, _), row in zip(MATERIALS, shown):
        panels = [_label(_display(img, exposure), f"{label}, roughness {r:.1f}", 0.4)
                  for img, r in zip(row, ROUGHNESS)]
        rows.append(np.hstack(panels))
    heat = []
    for err, r in zip(errs[: len(ROUGHNESS)], ROUGHNESS):
        v8 = np.round(np.clip(err / tol, 0, 1) * 255).astype(np.uint8)
        h = np.ascontiguousarray(cv2.applyColorMap(v8, cv2.COLORMAP_INFERNO)[..., ::-1])
        h[~mask] = 40
        heat.append(_label(h, f"|shader - CPU|, r {r:.1f}", 0.4))
    width = size * len(ROUGHNESS)
    pano = cv2.resize(np.maximum(np.asarray(image, np.float32), 0), (width, width // 2),
                      interpolation=cv2.INTER_AREA)
    pano = _display(pano, exposure)
    max_rel = float(max(e.max() for e in errs))
    _label(pano, f"{title}: SH9 diffuse + {cube_size}x{cube_size} cube ({len(mips)} mips, "
                 f"RGBA16F) specular; heat: error / tolerance {tol:.1e}, max {max_rel:.1e}")
    picture = np.vstack([pano, *rows, np.hstack(heat)])
    stats = {"max_rel": max_rel, "tolerance": tol, "cube": cube_description(),
             "mips": len(mips), "exposure": exposure}
    return picture, stats


def write_ibl_picture(ctx, panoramas, out_dir: Path, size: int = 160) -> dict | None:
    """``reflections_NAME.png`` in ``out_dir`` for the first preferred panorama given (else
    the first one); None without panoramas."""
    paths = [Path(p) for p in panoramas]
    if not paths:
        return None
    by_name = {p.stem: p for p in paths}
    path = next((by_name[n] for n in PREFERRED if n in by_name), paths[0])
    picture, stats = reflections_picture(ctx, read_image(path), path.stem, size)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    file = out_dir / f"reflections_{path.stem}.png"
    cv2.imwrite(str(file), picture[..., ::-1])
    return {"file": str(file), "panorama": str(path), **stats}
