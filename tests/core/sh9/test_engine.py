"""The SH9 engine against analytic answers and a float64 brute-force reference."""
import math

import numpy as np
import pytest

import provider
from provider.core.geometry import sh
from provider.core.sh9.engine import SH9Projector, InputError, compute_sh9, srgb_to_linear
from provider.live.wire.message import coefficient_message

import reference as ref
from conftest import HDRI_NAMES

PI = math.pi


def cap_coefficients(axis, half_angle, radiance):
    """Exact SH of a uniform disc (spherical cap) of the given radiance around ``axis``."""
    c = math.cos(half_angle)
    local = np.zeros(9)
    local[0] = 0.282095 * 2 * PI * (1 - c)
    local[2] = 0.488603 * PI * (1 - c * c)
    local[6] = 0.315392 * 2 * PI * (c - c ** 3)
    # rotate local +Z onto axis
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    helper = np.array([1.0, 0, 0]) if abs(a[0]) < 0.9 else np.array([0, 1.0, 0])
    xa = np.cross(helper, a); xa /= np.linalg.norm(xa)
    ya = np.cross(a, xa)
    R = np.stack([xa, ya, a], axis=1)
    return np.outer(sh.rotate_coefficients(local[:, None], R)[:, 0], radiance)


def test_furnace_uniform_environment():
    """Radiance 1 everywhere: E = π for every normal, a white surface shows exactly 1."""
    img = np.ones((256, 512, 3), np.float32)
    r = compute_sh9(img)
    assert r.coefficients[0] == pytest.approx([2 * math.sqrt(PI)] * 3, rel=1e-6)
    assert np.abs(r.coefficients[1:]).max() < 1e-5  # float32 accumulation
    E = sh.irradiance_from_matrices(r.matrices, ref.NORMALS)
    assert np.allclose(E, PI, rtol=1e-5)
    assert np.allclose(E / PI, 1.0, rtol=1e-5)  # white Lambertian surface


def test_constant_environment_scales_linearly():
    for L in (0.01, 3.0, 2e4):
        r = compute_sh9(np.full((64, 128, 3), L, np.float32))
        assert np.allclose(r.irradiance(ref.NORMALS), PI * L, rtol=1e-5)


def test_small_bright_disc_matches_analytic_cap():
    axis = np.array([0.3, 0.8, -0.52])
    axis /= np.linalg.norm(axis)
    alpha = math.radians(8)
    color = np.array([2e3, 1.5e3, 1e3])

    def env(d):
        inside = (d @ axis) >= math.cos(alpha)
        return 0.1 + inside[..., None] * color

    img = ref.render_equirect(env, 512, 256, supersample=4)
    expected = cap_coefficients(axis, alpha, color)
    expected[0] += 0.1 * 0.282095 * 4 * PI
    got = compute_sh9(img.astype(np.float32)).coefficients
    assert ref.rel_rms(ref.sh_irradiance(got), ref.sh_irradiance(expected)) < 2e-3


@pytest.mark.parametrize("k", range(9))
def test_pure_basis_function_gives_its_coefficient(k):
    def env(d):
        y = ref.basis(d)[..., k] / 1.1  # |Y| <= 1.09: keeps radiance positive
        return np.repeat((1.0 + y)[..., None], 3, axis=-1)

    img = ref.render_equirect(env, 512, 256).astype(np.float32)
    got = compute_sh9(img).coefficients[:, 0]
    expected = np.zeros(9)
    expected[0] = 0.282095 * 4 * PI
    expected[k] += 1 / 1.1
    assert np.allclose(got, expected, atol=2e-4)


def test_linear_gradient_is_bands_0_and_1_only():
    g = np.array([0.3, -0.5, 0.2])

    def env(d):
        return np.repeat((1.0 + d @ g)[..., None], 3, axis=-1)

    got = compute_sh9(ref.render_equirect(env, 512, 256).astype(np.float32)).coefficients[:, 0]
    expected = np.zeros(9)
    expected[0] = 0.282095 * 4 * PI
    # ∫ (g·ω) Y1m dω = 0.488603 · 4π/3 · g_component ; order y, z, x
    expected[1:4] = 0.488603 * 4 * PI / 3 * g[[1, 2, 0]]
    assert np.allclose(got, expected, atol=1e-4)


def test_matrix_matches_sh_irradiance_and_is_symmetric():
    rng = np.random.default_rng(1)
    L = rng.normal(size=(9, 3))
    M = provider.irradiance_matrices(L)
    assert np.allclose(M, np.transpose(M, (0, 2, 1)))
    E_matrix = sh.irradiance_from_matrices(M, ref.NORMALS)
    E_sum = ref.sh_irradiance(L)
    assert np.abs(E_matrix - E_sum).max() < 1e-5 * np.abs(E_sum).max()


@pytest.mark.parametrize("name", HDRI_NAMES)
def test_exact_path_matches_float64_reference_on_real_panoramas(name, hdri):
    img = hdri(name)
    r = compute_sh9(img)
    expected = ref.project_equirect(img)
    assert ref.rel_rms(ref.sh_irradiance(r.coefficients), ref.sh_irradiance(expected)) < 1e-4
    # the matrices the shaders get carry the same irradiance
    E = sh.irradiance_from_matrices(r.matrices, ref.NORMALS)
    assert ref.rel_rms(E, ref.sh_irradiance(expected)) < 1e-4


@pytest.mark.parametrize("name", HDRI_NAMES)
def test_fast_path_within_half_a_percent(name, hdri):
    """The fast path where it is offered (a fisheye: its weights are per pixel) stays within
    half a percent of the exact one."""
    from provider.bench.scenes import fisheye_from_equirect
    from provider.core.geometry.projections import make_projection
    fish = fisheye_from_equirect(hdri(name), make_projection("fisheye", 256, 256))
    fast = SH9Projector(256, 256, "fisheye", downsample=2).project(fish)
    exact = SH9Projector(256, 256, "fisheye").project(fish)
    assert ref.rel_rms(ref.sh_irradiance(fast.coefficients),
                       ref.sh_irradiance(exact.coefficients)) < 5e-3


def test_the_fast_path_is_withdrawn_on_equirect_frames(hdri):
    """--downsample never paid on an equirect (its exact weights are separable: 1.25-1.9× slower
    with it in the bench, issue 34): the frame is projected exactly, and the projector says
    so in one warning that every command prints."""
    img = hdri("bridge")
    p = SH9Projector(512, 256, downsample=2)
    assert p.downsample == 1 and len(p.warnings) == 1
    assert "--downsample on an equirect frame is withdrawn" in p.warnings[0]
    np.testing.assert_array_equal(p.project(img).coefficients,
                                  SH9Projector(512, 256).project(img).coefficients)
    assert not SH9Projector(512, 256).warnings


@pytest.mark.parametrize("name", HDRI_NAMES)
def test_error_estimate_tracks_true_sh9_truncation(name, hdri):
    """The per-frame error estimate is close to the truncation error measured by brute force."""
    img = hdri(name)
    r = compute_sh9(img)
    true_err = ref.rel_rms(ref.sh_irradiance(r.coefficients), ref.brute_irradiance(img))
    est = r.stats["error_estimate"]
    assert 0.5 * true_err - 2e-3 < est < 2 * true_err + 2e-3, (est, true_err)


def test_srgb_frames_are_linearised_before_averaging():
    """An 8-bit checkerboard of 0 and 255 has mean linear radiance 0.5, not sRGB(127.5)."""
    img = np.zeros((64, 128, 3), np.uint8)
    img[::2, ::2] = 255
    img[1::2, 1::2] = 255
    r = compute_sh9(img)
    mean_radiance = r.coefficients[0, 0] / (0.282095 * 4 * PI)
    assert mean_radiance == pytest.approx(0.5, rel=2e-3)
    assert r.stats["clipped_fraction"] == pytest.approx(0.5)


@pytest.mark.parametrize("factor", [2, 3, 4, 8])
def test_8bit_fast_path_equals_linear_area_average(factor, hdri):
    """The 8-bit fast path (a fisheye's: withdrawn on equirect frames) equals projecting the
    area-average of the linearised frame (sRGB decoded before averaging, never after)."""
    from provider.bench.scenes import fisheye_from_equirect
    from provider.core.geometry.projections import make_projection
    h = 24 * 10  # 240 rows: divisible by every factor
    img = fisheye_from_equirect(hdri("bridge"), make_projection("fisheye", h, h))
    enc = np.clip(img / 8, 0, 1)
    enc = np.where(enc <= 0.0031308, 12.92 * enc, 1.055 * enc ** (1 / 2.4) - 0.055)
    u8 = np.round(enc * 255).astype(np.uint8)
    lin = np.asarray(srgb_to_linear(u8 / 255.0), np.float64)
    fast = SH9Projector(h, h, "fisheye", downsample=factor).project(u8)
    small = lin.reshape(h // factor, factor, h // factor, factor, 3).mean(axis=(1, 3))
    expected = SH9Projector(h // factor, h // factor, "fisheye").project(small.astype(np.float32))
    assert ref.rel_rms(ref.sh_irradiance(fast.coefficients),
                       ref.sh_irradiance(expected.coefficients)) < 1e-5
    assert fast.stats["clipped_fraction"] == pytest.approx(np.count_nonzero(u8 == 255) / u8.size)


def test_16_bit_and_exposure():
    img16 = np.full((32, 64, 3), 65535, np.uint16)
    r = compute_sh9(img16, exposure=2.0)
    assert r.coefficients[0, 0] / (0.282095 * 4 * PI) == pytest.approx(2.0, rel=1e-5)
    lin = compute_sh9(np.full((32, 64, 3), 32768, np.uint16), encoding="linear")
    assert lin.coefficients[0, 0] / (0.282095 * 4 * PI) == pytest.approx(32768 / 65535, rel=1e-5)


def test_sun_ten_thousand_times_the_sky(hdri):
    """Sky: a sun of ~22,000 over a sky of ~0.7; float32 accumulation must hold up."""
    img = np.ones((256, 512, 3), np.float32)
    img[40:43, 300:303] = 1e4 * 50  # a sun far brighter than 10^4 × the sky
    r = compute_sh9(img)
    expected = ref.project_equirect(img)
    # (the reference samples Y at pixel centres, the engine integrates Y over each pixel)
    assert ref.rel_rms(ref.sh_irradiance(r.coefficients), ref.sh_irradiance(expected)) < 1e-4
    assert r.stats["clipped_fraction"] == 0 and r.stats["negative_pixels"] == 0


def test_clipped_8bit_frame_reports_clipping():
    img = np.full((64, 128, 3), 60, np.uint8)
    img[5:15, 40:60] = 255
    r = compute_sh9(img)
    assert r.stats["clipped_fraction"] == pytest.approx(10 * 20 / (64 * 128))


def test_nonfinite_and_negative_pixels_are_zeroed_and_counted():
    img = np.ones((32, 64, 3), np.float32)
    img[0, 0] = np.nan
    img[1, 1, 2] = np.inf
    img[2, 2] = -5
    img[3, 3, 0] = -1
    r = compute_sh9(img)
    assert r.stats["nonfinite_pixels"] == 2
    assert r.stats["negative_pixels"] == 2
    clean = img.copy()
    clean[0, 0] = clean[1, 1, 2] = clean[2, 2] = clean[3, 3, 0] = 0
    assert np.allclose(r.coefficients, compute_sh9(clean).coefficients)
    assert np.all(np.isfinite(r.matrices))


def test_float_frames_are_cleaned_band_by_band_like_the_whole_frame():
    """The clean-up inside the projection pass (provider.core.radiometry.float_clean) gives the counts
    and coefficients of cleaning the whole frame first, in every band, in every dtype."""
    from provider.core.sh9.engine import SH9Projector
    rng = np.random.default_rng(3)
    img = rng.random((96, 192, 3)).astype(np.float32)
    img[rng.random((96, 192)) < 0.02, 1] = -0.25        # negatives in every band
    img[70, 5] = [np.nan, -np.inf, 1]                   # one pixel, two bad channels
    img[90, 100, 2] = np.inf
    clean = np.where(np.isfinite(img) & (img > 0), img, 0).astype(np.float32)
    bad = ~np.isfinite(img)
    negative = (img < 0) & ~bad
    want = compute_sh9(clean, error_estimate=False).coefficients
    for dtype in (np.float32, np.float64, np.float16):
        frame = img.astype(dtype)
        for lights in ("off", "auto"):
            p = SH9Projector(192, 96, lights=lights, error_estimate=True)
            r = p.project(frame)
            assert r.stats["nonfinite_pixels"] == int(bad.any(axis=2).sum())
            assert r.stats["negative_pixels"] == int((negative & ~bad.any(axis=2)[..., None])
                                                     .any(axis=2).sum())
            kept = clean.astype(np.float64).sum()
            lost = -img[negative & ~bad.any(axis=2)[..., None]].astype(np.float64).sum()
            assert r.stats["negative_energy_fraction"] == pytest.approx(lost / kept, rel=1e-3)
            if dtype != np.float16:
                assert np.allclose(r.coefficients, want, rtol=1e-5, atol=1e-7)
            assert np.isfinite(r.stats["error_estimate"])
        assert np.array_equal(p._clean_float(frame, {}), clean.astype(dtype).astype(np.float32))
    assert p._clean_float(clean, {}) is clean   # a clean float32 frame is not copied


@pytest.mark.parametrize("fill", [np.nan, -1.0, np.inf])
def test_frame_with_no_usable_light_is_refused_not_served_as_darkness(fill):
    img = np.full((32, 64, 3), fill, np.float32)
    with pytest.raises(InputError, match="no usable light"):
        compute_sh9(img)


def test_all_black_frame_gives_zeros_without_division_by_zero():
    for img in (np.zeros((32, 64, 3), np.uint8), np.zeros((32, 64, 3), np.float32)):
        r = compute_sh9(img)
        assert np.all(r.coefficients == 0) and np.all(r.matrices == 0)
        assert r.stats["error_estimate"] == 0.0
        assert r.stats["min_irradiance"] == [0.0, 0.0, 0.0]
        coefficient_message(r)  # finite, serialisable


@pytest.mark.parametrize("shape,dtype,match", [
    ((0, 0, 3), np.float32, "empty"),
    ((32, 96, 3), np.float32, "2:1"),
    ((32, 64, 2), np.float32, "channels"),
    ((32, 64, 5), np.uint8, "channels"),
    ((32, 64, 3), np.int32, "pixel type"),
])
def test_bad_frames_raise_clear_errors(shape, dtype, match):
    with pytest.raises(InputError, match=match):
        compute_sh9(np.zeros(shape, dtype))


def test_wrong_frame_size_for_a_projector():
    p = SH9Projector(128, 64)
    with pytest.raises(InputError, match="built for 128×64"):
        p.project(np.zeros((32, 64, 3), np.float32))


def test_grey_and_rgba_frames_are_accepted():
    grey = np.full((32, 64), 0.5, np.float32)
    rgba = np.full((32, 64, 4), 0.5, np.float32)
    a, b = compute_sh9(grey), compute_sh9(rgba)
    assert np.allclose(a.coefficients, b.coefficients)


def test_sensor_rotation_is_applied_to_coefficients(hdri):
    img = hdri("bridge")
    R = sh.rotation_from_euler(40, 25, -10)
    rotated = compute_sh9(img, rotation=R).coefficients
    plain = compute_sh9(img).coefficients
    assert np.allclose(rotated, sh.rotate_coefficients(plain, R), atol=1e-9)
    # the irradiance of the rotated environment at R n equals the original at n
    assert np.allclose(sh.irradiance(rotated, ref.NORMALS @ R.T), sh.irradiance(plain, ref.NORMALS))


def test_yaw_equivariance_by_rolling_columns(hdri):
    """Rolling an equirect by a quarter turn is a 90° rotation about +Y."""
    img = hdri("city")
    rolled = np.roll(img, 128, axis=1)  # u -> u + 0.25: φ += π/2
    R = sh.rotation_from_euler(-90)  # content moves from φ to φ + π/2: yaw −90° about +Y
    a = sh.rotate_coefficients(compute_sh9(img).coefficients, R)
    b = compute_sh9(rolled).coefficients
    assert ref.rel_rms(ref.sh_irradiance(a), ref.sh_irradiance(b)) < 1e-6


def test_one_sided_light_lands_on_the_right_side():
    """A light only from +X (u = 0.75) lights normals facing +X, not −X; same for +Y, −Z."""
    for u, v, axis in ((0.75, 0.5, [1, 0, 0]), (0.5, 0.5, [0, 0, -1]), (0.5, 0.02, [0, 1, 0])):
        img = np.zeros((64, 128, 3), np.float32)
        img[int(v * 64), int(u * 128)] = 100.0
        r = compute_sh9(img)
        a = np.array(axis, float)
        E_pos, E_neg = r.irradiance(np.stack([a, -a]))[:, 0]
        assert E_pos > 10 * max(E_neg, 1e-9), (axis, E_pos, E_neg)


def test_dering_makes_lab_non_negative_at_a_reported_cost(hdri):
    img = hdri("lab")
    raw = compute_sh9(img)
    assert raw.stats["ringing"] and min(raw.stats["min_irradiance"]) < 0
    d = compute_sh9(img, dering="auto")
    assert min(d.stats["min_irradiance"]) >= 0
    E = sh.irradiance(d.coefficients, sh.fibonacci_sphere(20000))
    assert E.min() > -1e-3 * E.mean()
    assert 0 < d.stats["window_cutoff"] and 0 < d.stats["order_error"] < 0.2
    # a scene that does not ring is left exactly as it is
    ok = compute_sh9(hdri("apartment"), dering="auto")
    assert ok.stats["window_cutoff"] is None and ok.stats["order_error"] == 0


@pytest.mark.parametrize("name", HDRI_NAMES)
def test_dering_on_every_real_panorama(name, hdri):
    d = compute_sh9(hdri(name), dering="auto")
    assert min(d.stats["min_irradiance"]) >= 0


def test_order_auto_picks_the_lowest_order_within_budget():
    const = compute_sh9(np.ones((32, 64, 3), np.float32), order="auto")
    assert const.stats["order"] == 0
    img = np.ones((64, 128, 3), np.float32)
    img[:8] = 50  # bright ceiling: needs band 1 at least
    r = compute_sh9(img, order="auto", order_budget=0.02)
    full = compute_sh9(img)
    assert r.stats["order"] >= 1
    assert sh.irradiance_error(r.coefficients, full.coefficients) <= 0.02
    if r.stats["order"] < 2:
        assert np.all(r.coefficients[4:] == 0)
    lower = sh.truncate_order(full.coefficients, r.stats["order"] - 1)
    assert sh.irradiance_error(lower, full.coefficients) > 0.02


def test_explicit_orders_zero_higher_bands():
    img = np.random.default_rng(3).random((32, 64, 3)).astype(np.float32)
    r0 = compute_sh9(img, order=0)
    r1 = compute_sh9(img, order=1)
    assert np.all(r0.coefficients[1:] == 0) and np.all(r1.coefficients[4:] == 0)
    assert np.any(r1.coefficients[1:4] != 0)


def test_rotate_matrices_matches_rotated_coefficients():
    rng = np.random.default_rng(5)
    L = rng.normal(size=(9, 3))
    R = sh.rotation_from_euler(33, -71, 12)
    M1 = sh.rotate_matrices(sh.irradiance_matrices(L), R)
    M2 = sh.irradiance_matrices(sh.rotate_coefficients(L, R))
    # Equal as functions on the unit sphere (M is unique only up to λ·diag(1, 1, 1, −1)).
    E1 = sh.irradiance_from_matrices(M1, ref.NORMALS)
    E2 = sh.irradiance_from_matrices(M2, ref.NORMALS)
    assert np.abs(E1 - E2).max() < 1e-5 * np.abs(E2).max()


def test_projector_is_reused_for_frames_of_one_size():
    p = SH9Projector(256, 128)
    rng = np.random.default_rng(0)
    a, b = rng.random((2, 128, 256, 3)).astype(np.float32)
    ra, rb, rab = p.project(a), p.project(b), p.project(a + b)
    assert np.allclose(ra.coefficients + rb.coefficients, rab.coefficients, rtol=1e-5, atol=1e-6)
