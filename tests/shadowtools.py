"""The sun-and-sky scene of the shadow tests (tests/clients/three/test_shadows_three.py,
tests/clients/unity/test_unity_shadows.py): one small bright sun above a dim sky."""
from __future__ import annotations

import cv2
import numpy as np

from envtools import equirect_directions

SUN = np.array([0.55, 0.7, -0.45])
SUN /= np.linalg.norm(SUN)
SUN_RADIUS_DEG = 3.0


def write_sun_and_sky(path, h: int = 256) -> None:
    """A float panorama: a sky of radiance 0.3 above the horizon, 0.05 below, and a sun disc
    of SUN_RADIUS_DEG toward SUN, radiance 150 (E⊥ ≈ 0.6 π·(radius)²·150 ≈ 1.3)."""
    d = equirect_directions(h, 2 * h)
    img = np.where(d[..., 1:2] > 0, 0.3, 0.05).astype(np.float32).repeat(3, axis=-1)
    img[d @ SUN > np.cos(np.radians(SUN_RADIUS_DEG))] = 150.0
    assert cv2.imwrite(str(path), img[..., ::-1])
