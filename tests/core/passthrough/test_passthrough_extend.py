"""The headset's views extend the sphere (issue 42, item 5): where the 360° camera sees
nothing (its tripod, a masked mount) the views, brought to the sphere's units by the fit,
fill it; without a 360° camera ``shlight compute VIEWS/transforms.json`` fuses the views
alone and says what they saw (``coverage_sr``) and what they could not measure
(``clipped_light_fraction``, a lower bound). A simulated headset
(provider/bench/headset_sim.py) looks around a room none of the shared nine is."""
from __future__ import annotations

import json
import math
from dataclasses import replace

import cv2
import numpy as np
import pytest

from provider.bench.headset_sim import HeadsetSim, perturb_panorama
from provider.core.errors import InputError
from provider.core.geometry.sh import irradiance_error, sphere_irradiance
from provider.core.passthrough import PassthroughFit, read_transforms
from provider.core.passthrough.extend import (CLIP_CODE, equirect_directions, fill_sphere,
                                              pixel_solid_angles, sphere_holes, splat_fit,
                                              splat_views, view_pixels)
from provider.core.passthrough.overlaps import relative_exposures
from provider.core.passthrough.views import PassthroughView, read_view_image
from provider.core.radiometry.images import read_image
from provider.core.sh9.engine import compute_sh9
from provider.live.probe.camerafile import save_camera
from provider.live.wire.message import validate

from conftest import load_hdri
from servertools import refused, run_cli

ROOM, ROOM_SEED = "lab", 13
#: The tripod's cap (deg from straight down) the tests' 360° camera does not see.
CAP_DEG = 40.0


@pytest.fixture(scope="module")
def room():
    """A room none of the shared nine is as it stands: the lab, perturbed."""
    return perturb_panorama(load_hdri(ROOM), seed=ROOM_SEED)


def _render(room, folder, **options):
    truth = HeadsetSim(n_views=40, seed=3, width=160, height=120).render(room, str(folder),
                                                                          **options)
    views = read_transforms(folder / "transforms.json")
    return truth, views, [read_view_image(v) for v in views]


@pytest.fixture(scope="module")
def headset(room, tmp_path_factory):
    """40 views of the room, no exposure metadata: (folder, truth, views, images)."""
    folder = tmp_path_factory.mktemp("headset")
    return (folder, *_render(room, folder))


@pytest.fixture(scope="module")
def fitted(room, headset):
    fit = PassthroughFit(room)
    for view, image in zip(headset[2], headset[3]):
        fit.add_view(view, image)
    return fit.solve()


def _write_exr(path, image):
    import OpenEXR
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(image, np.float32)}) as f:
        f.write(str(path))


def _cap(height, deg):
    """(H, 2H) bool: the equirect pixels within ``deg`` of straight down."""
    theta = (np.arange(height) + 0.5) / height * 180.0
    return np.repeat((theta >= 180.0 - deg)[:, None], 2 * height, 1)


def _truth_coverage(truth, height):
    """What the headset saw, from the simulation's own records (true poses, recorded
    codes): (seen, clipped in every view that saw it), (H, 2H) bool each."""
    dirs = equirect_directions(height).reshape(-1, 3)
    seen = np.zeros(len(dirs), bool)
    unclipped = np.zeros(len(dirs), bool)
    for view, rotation, codes in zip(truth.views, truth.rotations, truth.codes):
        px, py, inside = view_pixels(replace(view, rotation=rotation), dirs)
        idx = np.flatnonzero(inside)
        x = np.clip(px[idx].astype(int), 0, view.w - 1)
        y = np.clip(py[idx].astype(int), 0, view.h - 1)
        seen[idx] = True
        unclipped[idx[(codes[y, x] < CLIP_CODE).all(-1)]] = True
    shape = (height, 2 * height)
    return seen.reshape(shape), (seen & ~unclipped).reshape(shape)


# -- where a view's pixel lands --------------------------------------------------------------

@pytest.mark.parametrize("distortion", [(0.0, 0.0, 0.0, 0.0), (-0.12, 0.03, 0.002, -0.001)])
def test_view_pixels_is_the_inverse_of_a_views_directions(distortion):
    from provider.bench.headset_sim import look_rotation
    view = PassthroughView(file_path="a.jpg", path="", rotation=look_rotation(30, -20, 5),
                           position=np.zeros(3), fl_x=150, fl_y=148, cx=81, cy=59, w=160,
                           h=120, camera_model="OPENCV", distortion=distortion)
    ys, xs = np.mgrid[0:120:7, 0:160:7]
    px, py, inside = view_pixels(view, view.directions(xs.ravel() + 0.3, ys.ravel() + 0.6))
    assert inside.all()
    # undistortPoints iterates to ~1e-6 px; pinhole arithmetic is exact to ~1e-12
    np.testing.assert_allclose(px, xs.ravel() + 0.3, atol=1e-3)
    np.testing.assert_allclose(py, ys.ravel() + 0.6, atol=1e-3)
    # behind the camera, and beside the frame, is not inside
    behind = view_pixels(view, -view.directions(np.array([80.0]), np.array([60.0])))[2]
    beside = view_pixels(view, view.directions(np.array([-30.0]), np.array([60.0])))[2]
    assert not behind.any() and not beside.any()


# -- the views in the sphere's units ---------------------------------------------------------

def test_the_views_light_lands_where_the_sphere_has_it(room, headset, fitted):
    truth, views, images = headset[1:]
    coverage = splat_fit(fitted, views, images, room.shape[0])
    m = coverage.measured
    err = np.log2(np.maximum(coverage.radiance[m], 1e-12) / np.maximum(room[m], 1e-12))
    # the fit's exposures put each view's light in the sphere's units: no bias per channel
    # (medians over ~100k pixels; the fit's view bias is ~0.01 stop)
    assert np.abs(np.median(err, axis=0)).max() < 0.05, np.median(err, axis=0)
    # and half the pixels within 0.25 stop (edges are 1° of pose error and JPEG apart)
    assert np.median(np.abs(err).max(-1)) < 0.25
    # coverage: what the simulated look-around saw, within 2 % (the recorded poses are 1°
    # off the true ones, which only moves the edge of what was seen)
    seen, _ = _truth_coverage(truth, room.shape[0])
    true_sr = coverage.solid_angle(seen)
    assert coverage.coverage_sr == pytest.approx(true_sr, rel=0.02)
    assert 0.6 * 4 * math.pi < coverage.coverage_sr < 0.95 * 4 * math.pi


def test_filling_the_tripods_hole_brings_sh9_closer_to_the_truth(room, headset, fitted):
    truth, views, images = headset[1:]
    holes = sphere_holes(room, nadir_cap_deg=CAP_DEG)
    assert (holes == _cap(room.shape[0], CAP_DEG)).all()
    holed = np.where(holes[..., None], 0.0, room)
    filled = fill_sphere(holed, holes, splat_fit(fitted, views, images, room.shape[0]))
    # the cap is 2π(1 − cos 40°) sr; the look-around (pitch ±35°, 67° tall views) reaches
    # ~69° below the horizon: what of the cap the views saw is filled (within the 1° the
    # recorded poses are off), the rest not
    assert filled.holes_sr == pytest.approx(2 * math.pi * (1 - math.cos(math.radians(40))),
                                            rel=0.01)
    seen, _ = _truth_coverage(truth, room.shape[0])
    band = float(pixel_solid_angles(room.shape[0]) @ (seen & holes).sum(1))
    assert band > 0.5
    assert filled.gained_sr == pytest.approx(band, rel=0.05)
    # what the 360° camera saw is kept as it was, bit for bit
    assert np.array_equal(filled.sphere[~holes], room[~holes].astype(np.float32))
    truth = compute_sh9(room).coefficients
    err_holed = irradiance_error(compute_sh9(holed.astype(np.float32)).coefficients, truth)
    err_filled = irradiance_error(compute_sh9(filled.sphere).coefficients, truth)
    assert err_filled < 0.8 * err_holed, (err_filled, err_holed)


# -- the views alone -------------------------------------------------------------------------

def test_overlaps_alone_find_the_auto_exposure_and_the_white_balances_drift(headset):
    truth, views, images = headset[1:]
    got = relative_exposures(views, images, truth.camera.true_response().table,
                             (math.log(1 - 0.35 * 0.5) / 0.5, 0.0))
    assert got.connected.all() and got.pairs > 100
    assert not got.metadata
    # up to the one level the views cannot know, every view's exposure is the simulated
    # auto exposure's (which moved by more than a stop)
    ratio = np.log2(got.exposure / truth.exposure)
    assert np.ptp(np.log2(truth.exposure)) > 1.0
    assert np.std(ratio) < 0.08, ratio
    # and the white balance up to its mean over the views
    wb = np.log2(got.wb_gains / truth.wb_gains)
    assert np.abs(wb - wb.mean(axis=0)).max() < 0.1


def test_views_alone_see_what_they_saw_and_bound_what_they_clipped(room, tmp_path):
    """With exposure metadata (so the level is known) and the headset's curve and
    vignetting: the light the views measured is the room's; what clipped in every view is
    counted at the clip level, never above the truth."""
    truth, views, images = _render(room, tmp_path, metadata=True)
    vignetting = (math.log(1 - 0.35 * 0.5) / 0.5, 0.0)   # 1 − 0.35ρ², close enough
    table = truth.camera.true_response().table
    got = relative_exposures(views, images, table, vignetting)
    assert got.metadata
    coverage = splat_views(views, images, table, got.exposure, got.wb_gains, vignetting,
                           height=room.shape[0])
    # metadata says exposure_s = 0.01 × the simulation's exposure (one constant it keeps)
    light = coverage.lower_bound() / 100.0
    m = coverage.measured
    green = np.median(light[m, 1] / np.maximum(room[m, 1], 1e-12))
    assert green == pytest.approx(1.0, abs=0.03)
    seen, clipped = _truth_coverage(truth, room.shape[0])
    omega = pixel_solid_angles(room.shape[0])[:, None]
    # the clipped share (green: the other channels' level is the views' mean white balance,
    # not the simulation's) is below the true share of the light the simulated headset
    # clipped in every view that saw it
    true_light = room[..., 1] * omega
    true_share = float(true_light[clipped].sum() / true_light[seen].sum())
    share = coverage.clipped_light_fraction((1,))
    assert 0.3 < share <= true_share, (share, true_share)
    # the lab's lamps clip in every view: most of what the simulation says clipped is
    # flagged so (1° of pose error moves their edges, which some view then measures)
    flagged = coverage.solid_angle(clipped & coverage.clipped) / coverage.solid_angle(clipped)
    assert flagged > 0.5, flagged
    # the mean light (L00, green, whose level metadata fixes) is a lower bound of the
    # room's: what no view saw is black, what clipped is at its clip level (an SH9's
    # irradiance is not, normal by normal: truncation moves light between directions)
    ours = compute_sh9(light.astype(np.float32)).coefficients
    ref = compute_sh9(room).coefficients
    assert 0.3 * ref[0, 1] < ours[0, 1] < ref[0, 1]
    # and with the directions they could only bound given their true light, the views' SH9
    # is near the SH9 of what they saw: 0.29 measured here, the rest of the error is the
    # lamps' edges, which a view whose pose is a degree off measures as the wall beside
    # them (and the level of the shoulder codes next to clipping)
    patched = np.where(coverage.bounded[..., None], room, light)
    seen_truth = compute_sh9((room * seen[..., None]).astype(np.float32)).coefficients
    patched_irr = sphere_irradiance(compute_sh9(patched.astype(np.float32)).coefficients)
    err = float(np.sqrt(np.mean((patched_irr[:, 1] - sphere_irradiance(seen_truth)[:, 1]) ** 2))
                / np.sqrt(np.mean(sphere_irradiance(seen_truth)[:, 1] ** 2)))
    print(f"views alone, green irradiance vs the truth over what they saw: {err:.3f}")
    assert err < 0.35, err


def test_compute_fuses_a_transforms_json_alone(room, headset, fitted, tmp_path):
    folder, truth = headset[:2]
    camera = tmp_path / "headset.json"
    save_camera(fitted.response, camera)      # what shlight passthrough --camera-out writes
    proc = run_cli("compute", str(folder / "transforms.json"), "--camera", str(camera),
                   timeout=180)
    assert proc.returncode == 0, proc.stderr
    msg = json.loads(proc.stdout)
    validate(msg)
    seen, _ = _truth_coverage(truth, room.shape[0])
    true_sr = float(pixel_solid_angles(room.shape[0]) @ seen.sum(1))
    assert msg["coverage_sr"] == pytest.approx(true_sr, rel=0.02)
    assert 0.1 < msg["clipped_light_fraction"] < 1
    assert msg["views"] == 40 and msg["views_used"] == 40
    assert msg["radiometry"] == "calibrated"
    assert "cannot measure a light it clips in every view" in msg["warnings"]
    assert "cannot measure a light it clips in every view" in proc.stderr
    # the folder works as the file does
    again = run_cli("compute", str(folder), "--camera", str(camera), timeout=180)
    assert json.loads(again.stdout)["coefficients"] == msg["coefficients"]
    # without a camera: sRGB, said
    srgb = run_cli("compute", str(folder / "transforms.json"), timeout=180)
    assert srgb.returncode == 0, srgb.stderr
    assert "decoded as sRGB" in srgb.stderr
    assert json.loads(srgb.stdout)["radiometry"] == "srgb-assumed"


# -- the command line ------------------------------------------------------------------------

def test_passthrough_writes_the_extended_sphere(room, headset, tmp_path):
    folder = headset[0]
    sphere = tmp_path / "room.exr"
    holed = np.where(_cap(room.shape[0], CAP_DEG)[..., None], 0.0, room)
    _write_exr(sphere, holed)        # a stitcher's black tripod cap
    out = tmp_path / "extended.exr"
    proc = run_cli("passthrough", str(folder / "transforms.json"), "--sphere", str(sphere),
                   "--extended-out", str(out), timeout=180)
    assert proc.returncode == 0, proc.stderr
    ext = json.loads(proc.stdout)["extended"]
    cap_sr = 2 * math.pi * (1 - math.cos(math.radians(CAP_DEG)))
    assert ext["holes_sr"] == pytest.approx(cap_sr, rel=0.01)
    assert 0.5 < ext["gained_sr"] < cap_sr
    assert ext["coverage_sr"] == pytest.approx(4 * math.pi - ext["holes_sr"] + ext["gained_sr"])
    filled = read_image(out)
    truth = compute_sh9(room).coefficients
    assert irradiance_error(compute_sh9(filled).coefficients, truth) < 0.8 * irradiance_error(
        compute_sh9(holed.astype(np.float32)).coefficients, truth)
    # the same hole from --nadir-cap-deg, or from a mask, on the whole sphere
    _write_exr(tmp_path / "whole.exr", room)
    mask = tmp_path / "mask.png"
    cv2.imwrite(str(mask), _cap(room.shape[0], CAP_DEG).astype(np.uint8) * 255)
    for extra in (("--nadir-cap-deg", str(CAP_DEG)), ("--sphere-mask", str(mask))):
        proc = run_cli("passthrough", str(folder / "transforms.json"), "--sphere",
                       str(tmp_path / "whole.exr"), "--extended-out",
                       str(tmp_path / "e2.exr"), *extra, timeout=180)
        assert proc.returncode == 0, proc.stderr
        got = json.loads(proc.stdout)["extended"]
        assert got["holes_sr"] == pytest.approx(ext["holes_sr"])
        assert got["gained_sr"] == pytest.approx(ext["gained_sr"], rel=0.02)


def test_a_fisheyes_unseen_half_is_filled_by_the_views(room, headset, tmp_path):
    """A 180° fisheye looking up sees nothing below the horizon; the views looking down
    (which the fit cannot fit: nothing to compare) are brought to its units by their
    overlaps with those it fitted, and fill what they saw with the room's light."""
    from provider.core.geometry.projections import make_projection
    from provider.core.passthrough.fit import sample_equirect
    folder, truth = headset[:2]
    size = 512
    projection = make_projection("fisheye", size, size)
    ys, xs = np.mgrid[0:size, 0:size]
    dirs, seen = projection.pixel_to_direction(xs + 0.5, ys + 0.5)
    image = np.where(np.asarray(seen)[..., None], sample_equirect(room, dirs), 0.0)
    sphere = tmp_path / "fisheye.exr"
    _write_exr(sphere, image.astype(np.float32))
    out = tmp_path / "extended.exr"
    proc = run_cli("passthrough", str(folder), "--sphere", str(sphere), "--sphere-projection",
                   "fisheye", "--extended-out", str(out), timeout=240)
    assert proc.returncode == 0, proc.stderr
    ext = json.loads(proc.stdout)["extended"]
    assert ext["holes_sr"] == pytest.approx(2 * math.pi, rel=0.03)
    assert ext["views_from_overlaps"] > 0
    filled = read_image(out)
    height = filled.shape[0]
    lower = np.repeat(((np.arange(height) + 0.5) / height > 0.5)[:, None], 2 * height, 1)
    seen_truth, _ = _truth_coverage(truth, height)
    band = float(pixel_solid_angles(height) @ (seen_truth & lower).sum(1))
    assert ext["gained_sr"] == pytest.approx(band, rel=0.05)
    # the light filled in is the room's, in the sphere's units (no bias; edges apart)
    truth_pano = sample_equirect(room, equirect_directions(height))
    filled_here = lower & seen_truth & (filled > 0).all(-1)
    err = np.log2(filled[filled_here] / np.maximum(truth_pano[filled_here], 1e-12))
    assert np.abs(np.median(err, axis=0)).max() < 0.1, np.median(err, axis=0)


def test_views_at_the_edge_of_what_the_sphere_sees_are_fitted_without_its_black(
        room, headset):
    """A fisheye's sphere is black below its horizon; a view that looks across the horizon
    is fitted on what lies above it, not on a blur that mixes in the black (which made such
    a view's exposure most of a stop high)."""
    from provider.core.geometry.projections import make_projection
    from provider.core.passthrough.fit import MIN_SAMPLES, sample_equirect
    from provider.core.passthrough.sphere import to_equirect
    truth, views, images = headset[1:]
    projection = make_projection("fisheye", 512, 512)
    ys, xs = np.mgrid[0:512, 0:512]
    dirs, seen = projection.pixel_to_direction(xs + 0.5, ys + 0.5)
    image = np.where(np.asarray(seen)[..., None], sample_equirect(room, dirs), 0.0)
    fit = PassthroughFit(to_equirect(image.astype(np.float32), projection))
    for view, img in zip(views, images):
        fit.add_view(view, img)
    result = fit.solve()
    ok = result.samples >= MIN_SAMPLES
    edge = ok & (result.samples < 0.3 * np.median(result.samples[ok]))
    assert edge.sum() >= 3            # views across the horizon, with few samples
    stops = np.log2(result.exposure / truth.exposure)
    stops -= np.median(stops[ok])     # the level of the curve's anchor
    assert np.abs(stops[edge]).max() < 0.3, stops[edge]


def test_bad_input_is_refused_in_one_line(room, headset, tmp_path):
    folder = headset[0]
    views = str(folder / "transforms.json")
    sphere = tmp_path / "room.exr"
    _write_exr(sphere, room)
    cv2.imwrite(str(tmp_path / "small_mask.png"), np.zeros((10, 20), np.uint8))
    (tmp_path / "a_folder.exr").mkdir()
    for argv, says in [
            (("--nadir-cap-deg", "200"), "--nadir-cap-deg"),
            (("--sphere-mask", str(tmp_path / "small_mask.png")), "is 20×10; the sphere"),
            (("--sphere-mask", str(tmp_path / "none.png")), "no such file"),
            (("--extended-out", str(tmp_path / "a_folder.exr")), "is a folder"),
            (("--extended-out", str(sphere)), "the --sphere panorama"),
            (("--nadir-cap-deg", "180"), "sees nothing")]:
        refused(run_cli("passthrough", views, "--sphere", str(sphere), *argv, timeout=120),
                "shlight passthrough: error:", says)
    black = tmp_path / "black"
    black.mkdir()
    cv2.imwrite(str(black / "a.jpg"), np.zeros((120, 160, 3), np.uint8))
    doc = {"camera_model": "PINHOLE", "fl_x": 100, "fl_y": 100, "cx": 80, "cy": 60,
           "w": 160, "h": 120,
           "frames": [{"file_path": "a.jpg", "transform_matrix": np.eye(4).tolist()}]}
    (black / "transforms.json").write_text(json.dumps(doc))
    m = np.eye(4)
    m[:3, :3] *= 2
    scaled = dict(doc, frames=[{"file_path": "a.jpg", "transform_matrix": m.tolist()}])
    (black / "scaled.json").write_text(json.dumps(scaled))
    for argv, says in [
            ((views, str(sphere)), "computed alone"),
            ((views, "--projection", "fisheye"), "leave --projection out"),
            ((views, "--lux", "500"), "leave --lux out"),
            ((str(black / "scaled.json"),), "not a rotation"),
            ((str(black / "missing.json"),), "no such file"),
            ((str(black / "transforms.json"),), "measured nothing")]:
        refused(run_cli("compute", *argv, timeout=120), "shlight compute: error:", says)


def test_a_mask_of_the_wrong_size_is_refused_by_the_maths_too(room):
    with pytest.raises(InputError, match="mask"):
        sphere_holes(room, np.zeros((4, 8), bool))
