"""Each light's visibility past the occluder sphere (docs/contract.md §10,
provider/core/lights/shadows.py ``sphere_light_visibility``): the exact solid angle of two
intersecting caps against brute-force sampling of the light's disc, its limits, and the
shipped ``shSphereLightVisibility`` (GLSL) / ``SHSphereLightVisibility`` (HLSL, through SPIR-V)
against it on a real headless OpenGL context (provider/verify/lights.py).
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from provider.core.lights.shadows import cap_overlap_fraction, sphere_light_visibility
from provider.verify import harness, lights

from shadertools import evaluator_or_skip

NORMALS = harness.dense_normals(8192)


def _disc(axis, radius_deg, count=20000):
    """(count, 3) directions at equal solid angle over the cap of ``radius_deg`` about
    ``axis`` (golden-angle spiral, the bench's idea; not imported from the bench)."""
    axis = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    i = np.arange(count) + 0.5
    cos_t = 1 - (i / count) * (1 - math.cos(math.radians(radius_deg)))
    sin_t = np.sqrt(np.maximum(0.0, 1 - cos_t ** 2))
    phi = i * math.pi * (3 - math.sqrt(5))
    a = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(axis, a)
    return cos_t[:, None] * axis + sin_t[:, None] * (np.cos(phi)[:, None] * a
                                                     + np.sin(phi)[:, None] * b)


def _brute(point, centre, radius, direction, radius_deg, count=20000):
    """The share of the disc's samples whose ray from ``point`` misses the sphere."""
    to_c = np.asarray(centre, np.float64) - point
    dist = np.linalg.norm(to_c)
    rays = _disc(direction, radius_deg, count)
    return float(np.mean(rays @ (to_c / dist) <= math.sqrt(dist ** 2 - radius ** 2) / dist))


def test_the_visibility_is_the_share_of_the_disc_the_sphere_leaves_open():
    """300 random receivers, spheres and lights (0.27° to 60°), a third of them with the
    light's centre within its radius of the sphere's rim (grazing): within 2.5·10⁻³ of
    20 000 samples of the disc (the samples' own error)."""
    rng = np.random.default_rng(7)
    worst = 0.0
    for trial in range(300):
        radius_deg = float(rng.choice([0.27, 2.0, 9.0, 25.0, 60.0]))
        centre, radius = rng.normal(size=3), float(rng.uniform(0.1, 1.0))
        to_c = rng.normal(size=3)
        to_c /= np.linalg.norm(to_c)
        dist = radius / rng.uniform(0.05, 0.95)
        point = centre - to_c * dist
        if trial % 3 == 0:       # grazing: the light's centre near the sphere's rim
            alpha = math.asin(radius / dist)
            side = np.cross(to_c, rng.normal(size=3))
            side /= np.linalg.norm(side)
            g = alpha + rng.uniform(-1, 1) * math.radians(radius_deg)
            direction = math.cos(g) * to_c + math.sin(g) * side
        else:
            direction = rng.normal(size=3)
            direction /= np.linalg.norm(direction)
        got = sphere_light_visibility(point, centre, radius, direction[None], [radius_deg])
        assert got.shape == (1,)
        worst = max(worst, abs(float(got[0]) - _brute(point, centre, radius, direction,
                                                       radius_deg)))
    assert worst < 2.5e-3, worst


def test_a_suns_disc_half_behind_the_rim_is_half_seen():
    """A 0.27° sun whose centre sits on the rim of a wide sphere's cap: about half seen (a
    bit under: the rim curves around the disc), and the shadow's edge is 2 × 0.27° wide."""
    alpha = 0.5
    at = [float(cap_overlap_fraction(math.radians(0.27), alpha, alpha + t * math.radians(0.27)))
          for t in (-1.0, -0.5, 0.0, 0.5, 1.0)]
    assert at[0] == 1.0 and at[-1] == 0.0
    assert 0.49 < at[2] < 0.5 and at[1] > at[2] > at[3]
    assert abs(at[1] + at[3] - 1.0) < 5e-3          # nearly symmetric about the rim


def test_the_limits_point_light_nested_and_apart():
    up = np.array([0.0, 1.0, 0.0])
    p = np.zeros(3)
    # sphere overhead at 2, radius 1: α = 30°
    for deg, want in ((0.0, 0.0), (10.0, 0.0)):              # the disc inside the sphere
        assert sphere_light_visibility(p, 2 * up, 1.0, up[None], [deg])[0] == want
    tilted = np.array([math.sin(math.radians(31)), math.cos(math.radians(31)), 0.0])
    assert sphere_light_visibility(p, 2 * up, 1.0, tilted[None], [0.0])[0] == 1.0   # a point past the rim
    sideways = np.array([1.0, 0.0, 0.0])
    assert sphere_light_visibility(p, 2 * up, 1.0, sideways[None], [40.0])[0] == 1.0  # apart
    # a small sphere (α = 5.74°) wholly inside a 60° light: 1 − sin²(α/2)/sin²(a/2)
    a, al = math.radians(60), math.asin(0.1)
    got = sphere_light_visibility(p, 10 * up, 1.0, up[None], [60.0])[0]
    assert got == pytest.approx(1 - math.sin(al / 2) ** 2 / math.sin(a / 2) ** 2, abs=1e-12)


def test_a_receiver_inside_the_sphere_sees_no_light_and_bad_input_is_refused():
    d = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    points = np.array([[0.0, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, -5.0, 0.0]])
    v = sphere_light_visibility(points, np.zeros(3), 1.0, d, [1.0, 30.0])
    assert v.shape == (3, 2)
    assert np.all(v[:2] == 0.0) and v[2, 1] == 1.0 and v[2, 0] == 0.0
    with pytest.raises(ValueError, match="angular radius"):
        sphere_light_visibility(points, np.zeros(3), 1.0, d, [1.0, 91.0])
    with pytest.raises(ValueError, match="angular radii"):
        sphere_light_visibility(points, np.zeros(3), 1.0, d, [1.0])
    with pytest.raises(ValueError, match="radius"):
        sphere_light_visibility(points, np.zeros(3), 0.0, d, [1.0, 2.0])


# ---- the shaders (real OpenGL; HLSL through glslang + spirv-cross) --------------------------

@pytest.fixture(scope="module", params=["glsl", "hlsl"])
def shader_path(request, ctx):
    evaluator_or_skip(lights.SphereLightEvaluator, ctx, request.param)
    return request.param


def test_every_sphere_light_case_matches_the_cpu(ctx, shader_path):
    """A point, a sun, a lamp and a window behind far, near and surrounding spheres, the
    sphere's direction swept over 8192 normals: within OCCLUDED_TOLERANCE (2.4·10⁻⁴) of the
    CPU's visibility, once the float32 normal's 2·10⁻⁶ rad is allowed for."""
    results = lights.run_sphere_light_cases(ctx, shader_path, NORMALS, lights.OCCLUDED_TOLERANCE)
    assert len(results) == 12
    assert all(r.passed for r in results), [(r.case, r.max_rel) for r in results if not r.passed]
    assert max(r.max_rel for r in results) < 2.5e-4


def test_a_radius_uploaded_in_degrees_is_visibly_wrong(ctx):
    """The uniform is in radians: a lamp's 6 given as degrees is off by over 0.1 somewhere."""
    ev = lights.SphereLightEvaluator(ctx, "glsl")
    light = np.array([0.3, 0.8, -0.52]) / np.linalg.norm([0.3, 0.8, -0.52])
    ev.light = np.append(light, 6.0).astype(np.float32)        # wrong: degrees
    ev.at = np.array([3.0, 0.3, 0, 0], np.float32)
    v = ev.evaluate(np.zeros((3, 4, 4)), NORMALS)[0][:, 0]
    n = NORMALS.astype(np.float64)
    want = sphere_light_visibility(-n * 3.0, np.zeros(3), 0.3, light[None], [6.0])[:, 0]
    assert np.abs(v - want).max() > 0.1
