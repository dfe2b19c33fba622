"""`shlight validate-shaders`, reflections: the harness extension (:func:`provider.verify.harness.run`)
that runs the image-based-lighting checks of :mod:`provider.verify.ibl` through each shader path,
summarises them with their own tolerance, and draws the picture of
:mod:`provider.verify.ibl_pictures`.
"""
from __future__ import annotations

from pathlib import Path

from .harness import FLOAT32_TOLERANCE
from .ibl import (IblComparison, IblEvaluator, filters_in_float, panorama_cases, run_case,
                  sphere_inputs, synthetic_cases, unity_frame_check)
from .ibl_pictures import write_ibl_picture


def compare(ctx, path: str, normals, panoramas, vectors, tolerance) -> list[IblComparison]:
    """Every IBL case through one shader path; ``tolerance`` (the SH9 one, default 32u) scales
    :func:`provider.verify.ibl.ibl_tolerance` alike."""
    factor = tolerance / FLOAT32_TOLERANCE
    evaluator = IblEvaluator(ctx, path)
    inputs = sphere_inputs()
    cases = synthetic_cases() + panorama_cases(panoramas)
    # a GPU's texture unit filters with 8-bit weights (Mesa's llvmpipe in float32): the
    # lookup is then held to what those weights allow, the shader's own terms are not
    hardware = not filters_in_float(ctx.info.get("GL_RENDERER"))
    out = [run_case(evaluator, case, inputs, case.tolerance(factor), hardware)
           for case in cases]
    return out + [unity_frame_check(ctx, path, inputs, cases[0].tolerance(factor), hardware)]


def demo_checks(ctx) -> list:
    return []


def summary(results, paths) -> list[str]:
    """One line per shader path: the reflection comparisons' worst error and tolerance."""
    lines = []
    for p in paths:
        mine = [r for r in results if isinstance(r, IblComparison) and r.path == p]
        if mine:
            worst = max(mine, key=lambda r: r.max_rel / (r.lookup_tolerance or r.tolerance))
            hw = ("" if worst.lookup_tolerance in (None, worst.tolerance) else
                  f"; lookups {worst.lookup_tolerance:.2e}: a hardware texture unit's 8-bit "
                  "filter weights")
            lines.append(f"{p}: {len(mine)} reflection comparisons, worst max relative error "
                         f"{worst.max_rel:.2e} ({worst.case}, tolerance {worst.tolerance:.2e}{hw})")
    return lines


def pictures(ctx, panoramas, out_dir) -> list[dict]:
    pic = write_ibl_picture(ctx, panoramas, out_dir)
    if pic is None:
        return []
    print(f"picture {pic['file']}: spheres of roughness 0 to 1 lit by {Path(pic['panorama']).stem} "
          f"(cube {pic['cube']}), shader vs CPU reference max relative error "
          f"{pic['max_rel']:.1e}")
    return [pic]
