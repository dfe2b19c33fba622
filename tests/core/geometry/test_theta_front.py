"""Which Theta circle is the front (issue 32): Ricoh's own pair of one scene as a dual-fisheye
still and as its stitched equirect (theta-api-specs, not shipped: no licence; its SH9 moments
are, with their provenance, in tests/data/ricoh_sample_pair/) agree in direction only with the
right circle as the front, the default of every Theta profile."""
import json
import math
from pathlib import Path

import numpy as np
import pytest

from provider.core.geometry import sh
from provider.core.geometry.projections import DualFisheye

PAIR = json.loads((Path(__file__).resolve().parents[2] / "data" / "ricoh_sample_pair" / "moments.json")
                  .read_text())
LUMA = np.array([0.2126, 0.7152, 0.0722])


def mounted(projection):
    """World SH9 (9, 3) of the pair's dual-fisheye still through the lenses of ``projection``."""
    out = np.zeros((9, 3))
    for lens, local in zip(projection.lenses, (PAIR["left_circle_local"],
                                               PAIR["right_circle_local"])):
        f, r, u = lens.frame
        out += sh.sh_rotation(np.stack([r, u, f], axis=1)) @ np.asarray(local)
    return out


def main_direction(c):
    """Unit direction of band 1 of the luminance (x, y, z), and its strength / L00."""
    y = np.asarray(c) @ LUMA
    v = np.array([y[3], y[1], y[2]])
    return v / np.linalg.norm(v), np.linalg.norm(v) / y[0]


def angle_deg(a, b):
    return math.degrees(math.acos(np.clip(a @ b, -1, 1)))


def test_the_right_circle_is_the_front_as_ricohs_pair_shows():
    eq = np.asarray(PAIR["equirect"])
    want, strength = main_direction(eq)
    assert strength > 0.1          # the scene has a clear main light direction to compare
    right = mounted(DualFisheye(640, 320, lens="theta-v"))
    left = mounted(DualFisheye(640, 320, lens="theta-v", front="left"))
    assert angle_deg(main_direction(right)[0], want) < 12      # measured 9.1°
    assert angle_deg(main_direction(left)[0], want) > 90       # measured 139.6°
    # after normalising by L00 the whole of bands 1 and 2 agree too (the stitch and the
    # lenses see the same room), and the wrong front does not
    norm = [c / (c[0] @ LUMA) for c in (eq, right, left)]
    rel = [np.linalg.norm(x[1:] - norm[0][1:]) / np.linalg.norm(norm[0][1:]) for x in norm[1:]]
    assert rel[0] < 0.4 and rel[1] > 2 * rel[0]     # measured 0.36 and 0.90


@pytest.mark.parametrize("lens,size", [("equidistant", (1280, 720)), ("theta-s", (1280, 720)),
                                       ("theta-sc", (1920, 1080)), ("theta-sc2", (1280, 720)),
                                       ("theta-v", (640, 320)), ("theta-z1", (730, 365)),
                                       ("theta-x", (688, 344))])
def test_every_profile_puts_the_front_on_the_right(lens, size):
    """The right circle's centre looks along −Z, the stitched panorama's centre; its image
    right is +X; the left circle looks along +Z."""
    w, h = size
    p = DualFisheye(w, h, lens=lens)
    (lx, ly), (rx, ry) = [(lens_.cx, lens_.cy) for lens_ in p.lenses]
    d, _ = p.pixel_to_direction(np.array([rx, lx, rx + 0.4 * w / 4]), np.array([ry, ly, ry]))
    assert d[0] @ [0, 0, -1] > 0.999 and d[1] @ [0, 0, 1] > 0.999 and d[2] @ [1, 0, 0] > 0.5
