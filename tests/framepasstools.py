"""A spread of frames through every path of SH9's frame pass, and what each gives: the
coefficients, the clipping and clean-up counts, the meter's lux, the lights, the cube's work
image and a bracket slot's projection (tests/core/test_frame_pass.py compares them with
tests/data/frame_pass_golden.npz).

The golden file was recorded from the code before the frame pass had sinks (commit 253cf49,
C kernels built), with::

    PYTHONPATH=<checkout of 253cf49> python tests/framepasstools.py tests/data/frame_pass_golden.npz
"""
from __future__ import annotations

import sys

import numpy as np

from provider.core.radiometry.response import CameraResponse
from provider.core.reflections.environment import EnvironmentProjector
from provider.core.sh9.engine import SH9Projector


def frame_u8(w: int, h: int, seed: int = 0) -> np.ndarray:
    """Smooth walls and noise, two clipped lamps off every symmetry axis."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w]
    img = (45 + 25 * np.sin(x / (w / 9.0))[..., None] + 15 * np.cos(y / (h / 5.0))[..., None]
           + rng.integers(0, 20, (h, w, 3)))
    img[h // 5:h // 5 + 6, w // 3:w // 3 + 8] = 255
    img[h // 2:h // 2 + 5, (2 * w) // 3:(2 * w) // 3 + 5] = (255, 250, 200)
    return np.clip(img, 0, 255).astype(np.uint8)


def frame_of(dtype: str, w: int, h: int, seed: int = 0) -> np.ndarray:
    """The 8-bit frame as ``dtype``: 16-bit codes, or linear float (``float32-bad``: with
    NaN, infinite and negative samples, as a denoiser leaves them)."""
    u8 = frame_u8(w, h, seed)
    if dtype == "uint8":
        return u8
    if dtype == "uint16":
        return (u8.astype(np.uint16) * 257 + (np.arange(w) % 7).astype(np.uint16)[:, None])
    lin = (u8.astype(np.float64) / 255.0) ** 2.2 * 3.0
    lin[u8 == 255] = 40.0                       # the lamps far above the walls
    if dtype == "float32-bad":
        lin = lin.astype(np.float32)
        lin[h // 3, w // 4, 0] = np.nan
        lin[h // 3 + 1, w // 5] = np.inf
        lin[(2 * h) // 3, w // 2, 1] = -0.5
        lin[h - 1, w - 1] = -np.inf
        return lin
    return lin.astype(dtype)


def absolute_response() -> CameraResponse:
    """sRGB with an absolute scale: the meter's up-facing sum rides in the pass."""
    response = CameraResponse.srgb(8)
    response.params["absolute"] = {"cd_m2": 40.0, "f_number": 2.0, "iso": 100.0, "lux": 1.0}
    return response


TURNED = [[0.8, 0.6, 0], [-0.48, 0.64, 0.6], [0.36, -0.48, 0.8]]

#: name -> (width, height, projection, dtype, projector options, extras); extras: "work"
#: (a cube's work image filled by the pass), "part" (a bracket slot through another table),
#: "lux" (exposure given: the meter's sum read), "estimate" (the error estimate).
CASES = {
    "equirect-u8": (128, 64, "equirect", "uint8", {}, ()),
    "equirect-u16": (128, 64, "equirect", "uint16", {}, ()),
    "equirect-f32": (128, 64, "equirect", "float32", {}, ("estimate",)),
    "equirect-f16": (128, 64, "equirect", "float16", {}, ()),
    "equirect-f64": (128, 64, "equirect", "float64", {}, ()),
    "equirect-f32-bad": (128, 64, "equirect", "float32-bad", {}, ()),
    "equirect-u8-lights": (128, 64, "equirect", "uint8", {"lights": "auto"}, ()),
    "equirect-f32-lights": (128, 64, "equirect", "float32-bad", {"lights": "auto"}, ()),
    "equirect-u8-work": (128, 64, "equirect", "uint8", {}, ("work",)),
    "equirect-u16-work": (128, 64, "equirect", "uint16", {}, ("work",)),
    "equirect-u8-part": (128, 64, "equirect", "uint8", {}, ("part",)),
    "equirect-u8-lux": (128, 64, "equirect", "uint8", {"response": "absolute"}, ("lux",)),
    "equirect-u8-turned-lux": (128, 64, "equirect", "uint8",
                               {"response": "absolute", "rotation": TURNED}, ("lux",)),
    "equirect-f32-turned-lux": (128, 64, "equirect", "float32",
                                {"response": "absolute", "rotation": TURNED}, ("lux",)),
    "equirect-u8-down2": (128, 64, "equirect", "uint8", {"downsample": 2}, ()),
    "fisheye-u8": (192, 128, "fisheye", "uint8", {}, ("estimate",)),
    "fisheye-u8-lights": (192, 128, "fisheye", "uint8", {"lights": "auto"}, ()),
    "fisheye-u8-lux": (192, 128, "fisheye", "uint8", {"response": "absolute"}, ("lux",)),
    "fisheye-u8-work": (192, 128, "fisheye", "uint8", {}, ("work",)),
    "fisheye-u16": (192, 128, "fisheye", "uint16", {}, ()),
    "fisheye-u16-lights": (192, 128, "fisheye", "uint16", {"lights": "auto"}, ()),
    "fisheye-u16-work": (192, 128, "fisheye", "uint16", {}, ("work",)),
    "fisheye-f32-bad": (192, 128, "fisheye", "float32-bad", {}, ()),
    "fisheye-f32-lux": (192, 128, "fisheye", "float32", {"response": "absolute"}, ("lux",)),
    "fisheye-u8-part": (192, 128, "fisheye", "uint8", {}, ("part",)),
    "fisheye-dense-u8": (192, 128, "fisheye", "uint8", {"center": (95.3, 64.1)}, ()),
    "fisheye-dense-u16-lux": (192, 128, "fisheye", "uint16",
                              {"center": (95.3, 64.1), "response": "absolute"}, ("lux",)),
    "fisheye-u8-down2": (192, 128, "fisheye", "uint8", {"downsample": 2}, ("estimate",)),
    "fisheye-u16-down2": (192, 128, "fisheye", "uint16", {"downsample": 2}, ()),
    "fisheye-f32-down2": (192, 128, "fisheye", "float32-bad", {"downsample": 2}, ()),
    "fisheye-u8-down2-lights": (192, 128, "fisheye", "uint8",
                                {"downsample": 2, "lights": "auto"}, ()),
    "fisheye-u8-down4": (192, 128, "fisheye", "uint8", {"downsample": 4}, ()),
    "theta-u8-lights": (640, 360, "dual-fisheye", "uint8", {"lights": "auto"}, ()),
    "theta-folded-u8-lights": (1280, 720, "dual-fisheye", "uint8", {"lights": "auto"}, ()),
    "theta-folded-u16-lux": (1280, 720, "dual-fisheye", "uint16", {"response": "absolute"},
                             ("lux",)),
    "theta-u8-work": (640, 360, "dual-fisheye", "uint8", {}, ("work",)),
    "theta-u16-lights": (640, 360, "dual-fisheye", "uint16", {"lights": "auto"}, ()),
    "theta-f32-lights": (640, 360, "dual-fisheye", "float32", {"lights": "auto"}, ()),
    "cubemap-u8": (192, 32, "cubemap", "uint8", {}, ()),
    "cubemap-u8-down2": (192, 32, "cubemap", "uint8", {"downsample": 2}, ()),
}


def run_case(name: str) -> dict:
    """name/what -> array: everything the case's pass gives."""
    w, h, projection, dtype, options, extras = CASES[name]
    options = dict(options)
    if options.get("response") == "absolute":
        options["response"] = absolute_response()
    projector = SH9Projector(w, h, projection, **options)
    frame = frame_of(dtype, w, h)
    out = {}
    if "part" in extras:
        table = (projector._lut(frame.dtype) * np.float32(0.5)).astype(np.float32)
        coeffs, clipped, stats = projector.project_part(frame, table)
        out["coefficients"], out["clipped"] = coeffs, np.float64(clipped)
        out["clipped_fraction"] = np.float64(stats["clipped_fraction"])
        return out
    work = None
    if "work" in extras:
        cube = EnvironmentProjector(w, h, projection, size=8)
        work = cube.new_work(projector)
        assert work is not None, name
    kwargs = {"exposure_s": 1 / 60, "gain": 2.0} if "lux" in extras else {}
    result = projector.project(frame, error_estimate="estimate" in extras, work=work,
                               **kwargs)
    out["coefficients"] = np.asarray(result.coefficients, np.float64)
    for key in ("clipped_fraction", "clipped_light_fraction", "negative_pixels",
                "nonfinite_pixels", "negative_energy_fraction", "illuminance_lux",
                "error_estimate", "light_error", "sh9_error", "light_candidates"):
        if key in result.stats:
            out[key] = np.float64(result.stats[key])
    out["stats_keys"] = np.array(list(result.stats), dtype=str)
    if result.ambient_coefficients is not None:
        out["lights"] = np.array([np.r_[L.direction, L.irradiance, L.flux, L.spread_deg]
                                  for L in result.lights], np.float64).reshape(-1, 10)
        out["ambient"] = np.asarray(result.ambient_coefficients, np.float64)
    if work is not None:
        out["work_complete"] = np.bool_(work.complete)
        if work.complete:   # its row and column sums: small, and any changed texel shows
            out["work_rows"] = work.array.sum(axis=1, dtype=np.float64)
            out["work_cols"] = work.array.sum(axis=0, dtype=np.float64)
    return out


def run_all() -> dict:
    """case/what -> array, for every case."""
    return {f"{name}/{key}": value for name in CASES for key, value in run_case(name).items()}


if __name__ == "__main__":
    from provider.cli.threads import limit_blas_threads
    limit_blas_threads()
    np.savez_compressed(sys.argv[1], **run_all())
