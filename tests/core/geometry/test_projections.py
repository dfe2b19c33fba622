"""Projections: one analytic environment rendered into every projection gives the same
lighting; weights integrate to the solid angle seen; properties hold for any input."""
import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st, HealthCheck

from provider.core.geometry import sh
from provider.core.sh9.engine import SH9Projector, InputError, compute_sh9
from provider.core.geometry.projections import (CubeMap, DualFisheye, Equirect, Fisheye,
                                                make_projection, ProjectionError)

import reference as ref
from projectiontools import equirect_reference, smooth_env


def render(projection, env=smooth_env):
    d = projection.directions()
    valid = projection.solid_angle > 0
    return np.where(valid[..., None], env(d), 0).astype(np.float32)


@pytest.mark.parametrize("projection", [
    Equirect(512, 256), CubeMap(6 * 96, 96), DualFisheye(1280, 720), DualFisheye(640, 360)],
    ids=["equirect", "cubemap", "dual-fisheye", "dual-fisheye-small"])
def test_every_full_sphere_projection_gives_the_same_lighting(projection):
    expected = equirect_reference()
    got = SH9Projector(projection.width, projection.height, projection).project(
        render(projection)).coefficients
    assert ref.rel_rms(ref.sh_irradiance(got), ref.sh_irradiance(expected)) < 2e-3


def test_fisheye_gives_the_lighting_of_the_hemisphere_it_sees():
    p = Fisheye(640, 480, fill="zero")
    expected = equirect_reference(mask=lambda d: d[..., 1] >= 0)
    got = SH9Projector(640, 480, p).project(render(p)).coefficients
    assert ref.rel_rms(ref.sh_irradiance(got), ref.sh_irradiance(expected)) < 3e-3


def test_fisheye_with_calibration_matches_equidistant_model():
    """cv2.fisheye with zero distortion and f = radius/(fov/2) is the equidistant model
    expressed as r = f·θ_d (Kannala-Brandt with k = 0 is equidistant)."""
    f = 240 / math.radians(85)
    K = np.array([[f, 0, 320], [0, f, 240], [0, 0, 1]])
    a = Fisheye(640, 480, fov_deg=170, K=K, D=np.zeros(4), fill="zero")
    b = Fisheye(640, 480, fov_deg=170, radius=240, fill="zero")
    assert np.allclose(a.solid_angle, b.solid_angle, rtol=1e-3, atol=1e-9)
    assert abs(a.coverage - b.coverage) < 1e-3 * b.coverage


def test_fisheye_calibration_refused_beyond_180_degrees():
    with pytest.raises(InputError, match="below 180"):
        SH9Projector(640, 480, "fisheye", fov_deg=200, K=np.eye(3), D=np.zeros(4))


@pytest.mark.parametrize("fov", [120, 180, 200, 240])
def test_fisheye_weights_sum_to_the_cap_it_sees(fov):
    p = Fisheye(800, 800, fov_deg=fov, fill="zero")
    expected = 2 * math.pi * (1 - math.cos(math.radians(fov / 2)))
    assert p.coverage == pytest.approx(expected, rel=2e-3)
    assert p.sh_weights[:, 0].sum() / 0.282095 == pytest.approx(expected, rel=2e-3)


@pytest.mark.parametrize("projection", [Equirect(64, 32), CubeMap(96, 16), DualFisheye(1280, 720)])
def test_full_sphere_weights_sum_to_4pi(projection):
    assert projection.coverage == pytest.approx(4 * math.pi, rel=1e-6)


def test_default_fisheye_mount_looks_up_with_image_top_toward_plus_z():
    p = Fisheye(401, 401)
    d = p.directions()
    assert np.allclose(d[200, 200], [0, 1, 0], atol=1e-2)       # centre: +Y (up)
    assert d[200, 390] @ [1, 0, 0] > 0.95                         # right edge: +X
    assert d[10, 200] @ [0, 0, 1] > 0.95                          # top edge: +Z


def test_dual_fisheye_front_lens_looks_down_minus_z():
    """The right circle is the front (Ricoh's sample pair, tests/core/geometry/test_theta_front.py)."""
    p = DualFisheye(1280, 720)
    d = p.directions()
    assert d[319, 959] @ [0, 0, -1] > 0.999   # right circle centre: −Z (panorama front)
    assert d[319, 319] @ [0, 0, 1] > 0.999    # left circle centre: +Z
    assert d[319, 1240] @ [1, 0, 0] > 0.9     # right lens, image right: +X
    assert DualFisheye(1280, 720, front="left").directions()[319, 319] @ [0, 0, -1] > 0.999


def test_cubemap_faces_follow_opengl_order():
    p = CubeMap(6 * 8, 8)
    d = p.directions()
    for face, axis in enumerate([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]):
        assert d[4, face * 8 + 4] @ axis > 0.95


def test_equirect_centre_looks_down_minus_z_and_u075_down_plus_x():
    d = Equirect(400, 200).directions()
    assert d[100, 200] @ [0, 0, -1] > 0.999
    assert d[100, 300] @ [1, 0, 0] > 0.999
    assert d[0, 0] @ [0, 1, 0] > 0.999


@pytest.mark.parametrize("fill", ["ground", "mirror"])
def test_fill_models_in_a_uniform_world(fill):
    """Uniform sky of radiance 1 seen by a 180° lens: both models fill the lower hemisphere
    with radiance = albedo, exactly."""
    albedo = 0.4
    p = Fisheye(512, 512, fill=fill, albedo=albedo)
    r = SH9Projector(512, 512, p).project(np.where(
        (p.solid_angle > 0)[..., None], 1.0, 0.0).astype(np.float32))
    expected = equirect_reference(env=lambda d: np.ones(d.shape[:-1] + (3,)),
                                  mask=lambda d: np.where(d[..., 1] >= 0, 1.0, albedo))
    assert ref.rel_rms(ref.sh_irradiance(r.coefficients), ref.sh_irradiance(expected)) < 3e-3


def test_unknown_projection_and_fill_give_clear_errors():
    with pytest.raises(ProjectionError, match="unknown projection"):
        make_projection("mercator", 10, 10)
    with pytest.raises(InputError, match="fill"):
        SH9Projector(64, 64, "fisheye", fill="bogus")
    with pytest.raises(InputError, match="6:1"):
        SH9Projector(64, 64, "cubemap")


def test_fisheye_rotation_option_rotates_the_coefficients():
    p = Fisheye(320, 240, fill="zero")
    img = render(p)
    R = sh.rotation_from_euler(0, 90, 0)  # camera mounted looking at the horizon (−Z → ...)
    a = SH9Projector(320, 240, "fisheye", fill="zero", rotation=R).project(img).coefficients
    b = SH9Projector(320, 240, "fisheye", fill="zero").project(img).coefficients
    assert np.allclose(a, sh.rotate_coefficients(b, R), atol=1e-9)


# -- properties -------------------------------------------------------------------------------

images = st.integers(0, 2**31 - 1).map(
    lambda seed: np.random.default_rng(seed).gamma(0.5, 2.0, (16, 32, 3)).astype(np.float32))
scalars = st.floats(0.01, 100.0)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(images, images, scalars, scalars)
def test_projection_is_linear(a, b, x, y):
    p = SH9Projector(32, 16)
    lhs = p.project((x * a + y * b).astype(np.float32)).coefficients
    rhs = x * p.project(a).coefficients + y * p.project(b).coefficients
    assert np.allclose(lhs, rhs, rtol=1e-4, atol=1e-4 * np.abs(rhs).max())


@settings(max_examples=25, deadline=None)
@given(images, st.floats(-180, 180), st.floats(-90, 90), st.floats(-180, 180))
def test_rotation_equivariance(img, yaw, pitch, roll):
    """Irradiance of the rotated lighting at R·n equals the original's at n."""
    R = sh.rotation_from_euler(yaw, pitch, roll)
    L = SH9Projector(32, 16).project(img).coefficients
    Lr = sh.rotate_coefficients(L, R)
    n = ref.NORMALS[:200]
    assert np.allclose(sh.irradiance(Lr, n @ R.T), sh.irradiance(L, n), atol=1e-9 * (1 + abs(L).max()))
    M = sh.rotate_matrices(sh.irradiance_matrices(L), R)
    assert np.allclose(sh.irradiance_from_matrices(M, n @ R.T),
                       sh.irradiance_from_matrices(sh.irradiance_matrices(L), n),
                       atol=1e-9 * (1 + abs(L).max()))


@settings(max_examples=10, deadline=None)
@given(st.sampled_from([(8, 4), (16, 8), (40, 20), (64, 32), (256, 128)]))
def test_weights_sum_to_4pi_for_any_equirect_size(size):
    p = SH9Projector(*size)
    r = p.project(np.ones(size[::-1] + (3,), np.float32))
    assert r.coefficients[0, 0] == pytest.approx(0.282095 * 4 * math.pi, rel=1e-6)


@settings(max_examples=10, deadline=None)
@given(st.sampled_from([32, 64, 128]), st.floats(-1, 1), st.floats(-1, 1))
def test_smooth_environment_is_invariant_to_image_size(height, gx, gz):
    env = lambda d: np.repeat((2 + gx * d[..., 0] + gz * d[..., 2] + d[..., 1] ** 2)[..., None], 3, -1)
    small = compute_sh9(ref.render_equirect(env, 2 * height, height).astype(np.float32))
    big = compute_sh9(ref.render_equirect(env, 1024, 512).astype(np.float32))
    assert ref.rel_rms(ref.sh_irradiance(small.coefficients), ref.sh_irradiance(big.coefficients)) < 1e-3
