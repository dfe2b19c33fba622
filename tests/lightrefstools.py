"""The lights' reference outputs (tests/core/lights/test_lights_reference.py): what the lights of a spread
of frames were before the per-frame path was made cheaper, so that a faster path is held to
finding the same lights.

``python tests/lightrefstools.py`` records them into tests/data/lights_reference.npz (run it
only where the lights are *meant* to change, and say why in the commit).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

from provider.bench.edge_frames import to_dual_fisheye

HERE = Path(__file__).resolve().parent
REFERENCE = HERE / "data" / "lights_reference.npz"


def _hdri(name):
    from provider.core.radiometry.images import read_image
    return read_image(HERE / "data" / "hdri" / f"{name}.exr")


def sun_sky(width=1024, height=512):
    """A plain sky of radiance 1 with a 0.5° sun of radiance 10⁴ (float32 equirect)."""
    y, x = np.mgrid[0:height, 0:width] + 0.5
    theta, phi = y / height * math.pi, (x / width - 0.5) * 2 * math.pi
    d = np.stack([np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], -1)
    sun = np.array([0.5, 0.6, -0.3])
    sun /= np.linalg.norm(sun)
    frame = np.ones((height, width, 3), np.float32)
    frame[d @ sun > math.cos(math.radians(0.5))] = 1e4
    return frame


def cases():
    """name -> (projector builder, [frames]): several frames go through one tracker."""
    from provider.bench.edge_frames import lit_theta_frame
    from provider.bench.common import _to_srgb8
    from provider.core.sh9.engine import SH9Projector

    def equirect(w, h):
        return lambda: SH9Projector(w, h, "equirect", lights="auto")

    def theta():
        return SH9Projector(1280, 720, "dual-fisheye", lights="auto")

    lit = lit_theta_frame(1280, 720)
    dawn8 = _to_srgb8(to_dual_fisheye(_hdri("dawn")), 0.5)
    out = {
        "theta-lit-room": (theta, [lit] * 5),
        "theta-venice-float": (theta, [to_dual_fisheye(_hdri("venice"))]),
        "theta-sky-float": (theta, [to_dual_fisheye(_hdri("sky"))]),
        "theta-bridge-float": (theta, [to_dual_fisheye(_hdri("bridge"))]),
        "theta-lab-float": (theta, [to_dual_fisheye(_hdri("lab"))]),
        "theta-dawn-8bit": (theta, [dawn8]),
        "theta-sun": (theta, [to_dual_fisheye(sun_sky())]),
        "theta-dark": (theta, [np.full((720, 1280, 3), 90, np.uint8)]),
        "equirect-sun": (equirect(1024, 512), [sun_sky()]),
        "equirect-flat": (equirect(512, 256), [np.ones((256, 512, 3), np.float32)]),
    }
    pi = np.full((480, 640, 3), 0.3, np.float32)        # a Pi camera's fisheye (ground fill)
    pi[200:215, 300:315] = 400.0                           # a lamp
    pi[100:104, 100:140] = 150.0                           # a tube
    out["fisheye-pi-lamps"] = (lambda: SH9Projector(640, 480, "fisheye", lights="auto"), [pi])
    for name in ("sky", "lab", "apartment", "bridge", "city", "night"):
        out[f"equirect-{name}"] = (equirect(512, 256), [_hdri(name)])
    return out


def lights_of(result) -> dict:
    """The arrays that say what a frame's lights are (one frame's SH9Result)."""
    L = result.lights
    return {
        "direction": np.array([x.direction for x in L]).reshape(-1, 3),
        "irradiance": np.array([x.irradiance for x in L]).reshape(-1, 3),
        "flux": np.array([x.flux for x in L]).reshape(-1, 3),
        "spread_deg": np.array([x.spread_deg for x in L], np.float64),
        "angular_radius_deg": np.array([x.angular_radius_deg for x in L], np.float64),
        "level": np.array([x.level for x in L], np.float64),
        "ident": np.array([[x.key, x.source, x.chain] for x in L], np.int64).reshape(-1, 3),
        "ambient": np.asarray(result.ambient_coefficients, np.float64),
        "errors": np.array([result.stats["light_error"], result.stats["sh9_error"]]),
        "candidates": np.array([result.stats["light_candidates"]], np.int64),
    }


def run_case(build, frames) -> list:
    """[lights_of(result)] of each frame through one projector and one tracker, and of the
    first frame again with the per-frame greedy choice (no tracker)."""
    from provider.core.lights.tracking import LightTracker
    projector, tracker = build(), LightTracker()
    got = [lights_of(projector.project(f, tracker=tracker)) for f in frames]
    got.append(lights_of(projector.project(frames[0])))
    return got


def flatten(name, per_frame) -> dict:
    return {f"{name}/{i}/{k}": v for i, d in enumerate(per_frame) for k, v in d.items()}


def record(path=REFERENCE) -> None:
    arrays = {}
    for name, (build, frames) in cases().items():
        arrays.update(flatten(name, run_case(build, frames)))
        print(name, "lights:", [len(arrays[f"{name}/{i}/level"])
                                for i in range(len(frames) + 1)], flush=True)
    np.savez_compressed(path, **arrays)


if __name__ == "__main__":
    sys.path.insert(0, str(HERE.parent))
    from provider.cli.threads import limit_blas_threads
    limit_blas_threads()
    record()
