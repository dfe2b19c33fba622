"""``shlight passthrough`` and the joint fit (issue 42, items 1-2): a simulated headset
(provider/bench/headset_sim.py: a filmic curve that is not sRGB, a lagging auto exposure, a
drifting white balance, vignetting, JPEG, 1° pose error) looks around a room none of the
tests has seen (a shared panorama turned, mirrored, re-tinted and re-lit region by region),
and the fit must make a hologram sit where its real replica does, by the issue's score."""
from __future__ import annotations

import json

import numpy as np
import pytest

from provider.bench.headset_sim import (HeadsetSim, fitted_model, look_rotation,
                                        naive_model, perturb_panorama, score)
from provider.core.errors import InputError
from provider.core.passthrough import PassthroughFit, read_transforms
from provider.core.passthrough.fit import PassthroughResult, sample_equirect
from provider.core.passthrough.views import read_view_image
from provider.core.radiometry.response import CameraResponse
from provider.live.probe.camerafile import load_camera

from conftest import load_hdri
from servertools import run_cli

#: The issue's done-when (stops): median view bias, 90th-percentile view bias, pixels' p90.
DONE_WHEN = {"median_view_bias": 0.10, "p90_view_bias": 0.20, "pixel_p90": 0.45}
ROOM, ROOM_SEED = "lab", 7


@pytest.fixture(scope="module")
def room():
    """A room none of the shared nine is as it stands: the lab, perturbed."""
    return perturb_panorama(load_hdri(ROOM), seed=ROOM_SEED)


@pytest.fixture(scope="module")
def headset(room, tmp_path_factory):
    """40 views of the room, no exposure metadata: (folder, truth)."""
    folder = tmp_path_factory.mktemp("headset")
    return folder, HeadsetSim(n_views=40, seed=3).render(room, str(folder))


@pytest.fixture(scope="module")
def fitted(room, headset) -> PassthroughResult:
    """The fit of the headset's views (fitted once for the module's tests)."""
    return fit_folder(room, headset[0])


def fit_folder(room, folder) -> PassthroughResult:
    fit = PassthroughFit(room)
    for view in read_transforms(folder / "transforms.json"):
        fit.add_view(view, read_view_image(view))
    return fit.solve()


def result_from_json(out: dict) -> PassthroughResult:
    """The CLI's JSON as the model a consumer renders through."""
    camera = CameraResponse.from_dict(out["camera"])
    vig = camera.params["vignetting"]
    views = out["views"]
    return PassthroughResult(
        response=camera, exposure=np.array([v["exposure"] for v in views]),
        wb_gains=np.array([v["wb_gains"] for v in views]),
        residual_stops=np.array([v["residual_stops"] or np.nan for v in views]),
        samples=np.array([v["samples"] for v in views]), vignetting=(vig["v1"], vig["v2"]))


def test_the_fit_puts_a_hologram_where_its_replica_is_and_the_naive_way_does_not(
        room, headset, fitted):
    truth = headset[1]
    got = score(truth, fitted_model(fitted))
    naive = score(truth, naive_model(truth, room))
    for key, limit in DONE_WHEN.items():
        assert got[key] <= limit, (key, got, naive)
    # the baseline the issue measured (sRGB, mean-matched exposure, no white balance) is
    # several times worse on every count: the score can tell them apart
    for key in DONE_WHEN:
        assert naive[key] >= 2 * got[key], (key, got, naive)
    assert naive["median_view_bias"] > DONE_WHEN["median_view_bias"]


def test_exposures_follow_the_auto_exposure_and_white_balance_its_drift(headset, fitted):
    truth, res = headset[1], fitted
    # the fit's exposure is the camera's up to the anchor of its curve (g(118) = 0.18, the
    # simulated camera's too): view to view, it follows the auto exposure's lag
    ratio = np.log2(res.exposure / truth.exposure)
    assert np.ptp(truth.exposure) > 0.5 * truth.exposure.mean()   # the AE did move
    assert np.std(ratio) < 0.1, ratio
    wb_err = np.abs(np.log2(res.wb_gains / truth.wb_gains))
    assert np.median(wb_err) < 0.1, wb_err
    assert np.all(res.residual_stops < 0.5)


def test_exposure_metadata_fixes_the_views_exposures(room, tmp_path):
    truth = HeadsetSim(n_views=24, seed=5).render(room, str(tmp_path), metadata=True)
    res = fit_folder(room, tmp_path)
    assert res.response.params["metadata_exposures"] is True
    ratio = res.exposure / truth.exposure
    # metadata leaves one constant to fit: every view's exposure is the truth × that constant
    # (a few float64 products per view, no sums over pixels: 1e-9 holds on any CPU)
    assert np.ptp(np.log2(ratio)) < 1e-9


def test_cli_prints_the_model_and_writes_camera_json(room, headset, tmp_path):
    folder, truth = headset
    sphere = tmp_path / "room.exr"
    _write_exr(sphere, room)
    camera = tmp_path / "headset.json"
    proc = run_cli("passthrough", str(folder / "transforms.json"), "--sphere", str(sphere),
                   "--camera-out", str(camera), timeout=120)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out["camera"]["format"] == "shlight-camera-response"
    assert [v["file_path"] for v in out["views"]] == [v.file_path for v in truth.views]
    for v in out["views"]:
        assert set(v) >= {"file_path", "exposure", "wb_gains", "ev100", "residual_stops"}
        assert v["wb_gains"][1] == 1.0
        assert v["ev100"] == pytest.approx(np.log2(0.18 / v["exposure"] * 100 / 12.5))
    # the camera.json is the one printed, and loads as any calibrated camera does
    assert load_camera(camera).to_dict() == out["camera"]
    # through the CLI, the done-when holds too
    fitted = score(truth, fitted_model(result_from_json(out)))
    for key, limit in DONE_WHEN.items():
        assert fitted[key] <= limit, (key, fitted)


def _write_exr(path, image):
    import OpenEXR
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(image, np.float32)}) as f:
        f.write(str(path))


# -- the views' records ---------------------------------------------------------------------

def test_a_view_looks_where_its_transform_says(tmp_path, room):
    """OpenGL camera axes, the world of docs/contract.md §1: the centre pixel of a view that
    looks 90° right (yaw toward +X) sees the panorama at u = 0.75."""
    rot = look_rotation(90.0, 0.0)
    # float64 sines and cosines of 90° and a few products (no sums): exact to ~1e-16 anywhere
    assert np.allclose(rot[:, 2], (-1, 0, 0), atol=1e-12)     # camera +Z is backward
    doc = {"camera_model": "PINHOLE", "fl_x": 100, "fl_y": 100, "cx": 80, "cy": 60,
           "w": 160, "h": 120,
           "frames": [{"file_path": "a.jpg", "transform_matrix": _m(rot)}]}
    (tmp_path / "a.jpg").write_bytes(b"")
    (tmp_path / "transforms.json").write_text(json.dumps(doc))
    view = read_transforms(tmp_path / "transforms.json")[0]
    centre = view.directions(np.array(80.0), np.array(60.0))
    assert np.allclose(centre, (1, 0, 0), atol=1e-12)
    right = view.directions(np.array(160.0), np.array(60.0))   # image right: toward +Z
    assert right[2] > 0.5 and abs(right[1]) < 1e-12
    up = view.directions(np.array(80.0), np.array(0.0))        # image top: up
    assert up[1] > 0.4
    pano = np.zeros((64, 128, 3))
    pano[:, 96] = 1.0                                         # u = 0.75 (column centre 96.5)
    assert sample_equirect(pano, centre)[0] > 0.4


def _m(rot, t=(0.0, 1.6, 0.0)):
    m = np.eye(4)
    m[:3, :3] = rot
    m[:3, 3] = t
    return m.tolist()


def _bad_records():
    good = {"file_path": "a.jpg", "transform_matrix": _m(np.eye(3))}
    scaled = _m(2 * np.eye(3))
    return [
        ("not a rotation", {**good, "transform_matrix": scaled}, {}, "not a rotation"),
        ("mirror", {**good, "transform_matrix": _m(np.diag([1.0, 1.0, -1.0]))}, {},
         "not a rotation"),
        ("principal point", {**good, "cx": 500}, {}, "outside the 160×120 frame"),
        ("missing file", {**good, "file_path": "nope.jpg"}, {}, "no such file"),
        ("camera model", good, {"camera_model": "FISHEYE"}, "camera_model 'FISHEYE'"),
        ("no matrix", {"file_path": "a.jpg"}, {}, "transform_matrix is missing"),
        ("short matrix", {**good, "transform_matrix": [[1, 0, 0]]}, {}, "4×4"),
        ("focal", {**good, "fl_x": -3}, {}, "fl_x must be positive"),
    ]


@pytest.mark.parametrize("case,frame,top,message", _bad_records(),
                         ids=[c[0] for c in _bad_records()])
def test_bad_records_are_refused_in_one_line(tmp_path, case, frame, top, message):
    import cv2
    cv2.imwrite(str(tmp_path / "a.jpg"), np.zeros((120, 160, 3), np.uint8))
    doc = {"camera_model": "PINHOLE", "fl_x": 100, "fl_y": 100, "cx": 80, "cy": 60,
           "w": 160, "h": 120, **top, "frames": [frame]}
    (tmp_path / "transforms.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="frame 0"):
        read_transforms(tmp_path / "transforms.json")
    with pytest.raises(InputError) as info:
        read_transforms(tmp_path / "transforms.json")
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_cli_refuses_bad_input_in_one_line(tmp_path):
    import cv2
    cv2.imwrite(str(tmp_path / "a.jpg"), np.zeros((120, 160, 3), np.uint8))
    doc = {"camera_model": "PINHOLE", "fl_x": 100, "fl_y": 100, "cx": 80, "cy": 60,
           "w": 160, "h": 120,
           "frames": [{"file_path": "a.jpg", "transform_matrix": _m(2 * np.eye(3))}]}
    (tmp_path / "transforms.json").write_text(json.dumps(doc))
    sphere = tmp_path / "sphere.exr"
    _write_exr(sphere, np.ones((32, 64, 3), np.float32))
    square = tmp_path / "square.exr"
    _write_exr(square, np.ones((32, 32, 3), np.float32))
    (tmp_path / "notjson.json").write_text("{frames")
    good = dict(doc, frames=[{"file_path": "a.jpg", "transform_matrix": _m(np.eye(3))}])
    (tmp_path / "good.json").write_text(json.dumps(good))
    cv2.imwrite(str(tmp_path / "small.jpg"), np.zeros((100, 100, 3), np.uint8))
    (tmp_path / "reg_none.json").write_text(json.dumps({"rotation": [1, 0, 0, 0, 1, 0, 0, 0, 1]}))
    (tmp_path / "reg_scaled.json").write_text(json.dumps({"world_to_sphere": [2, 0, 0, 0, 2, 0,
                                                                              0, 0, 2]}))
    small = dict(doc, frames=[{"file_path": "small.jpg", "transform_matrix": _m(np.eye(3))}])
    (tmp_path / "small.json").write_text(json.dumps(small))
    for argv, says in [
            ((str(tmp_path / "transforms.json"), "--sphere", str(sphere)), "not a rotation"),
            ((str(tmp_path / "notjson.json"), "--sphere", str(sphere)), "is not JSON"),
            ((str(tmp_path / "missing.json"), "--sphere", str(sphere)), "no such file"),
            ((str(tmp_path / "good.json"), "--sphere", str(square)), "2:1 equirect"),
            ((str(tmp_path / "good.json"), "--sphere", str(tmp_path / "no.exr")),
             "no such file"),
            ((str(tmp_path / "small.json"), "--sphere", str(sphere)),
             "is 100×100 but its record says w 160, h 120"),
            ((str(tmp_path / "good.json"), "--sphere", str(sphere), "--registration",
              str(tmp_path / "reg_none.json")), "needs world_to_sphere"),
            ((str(tmp_path / "good.json"), "--sphere", str(sphere), "--registration",
              str(tmp_path / "reg_scaled.json")), "world_to_sphere's 3×3 part is not a rotation"),
            # a black view: nothing to fit, said in one line rather than a made-up curve
            ((str(tmp_path / "good.json"), "--sphere", str(sphere)), "usable pixels"),
            ((str(tmp_path / "good.json"), "--sphere", str(sphere), "--sigma-deg", "nan"),
             "--sigma-deg")]:
        proc = run_cli("passthrough", *argv)
        assert proc.returncode == 2, (argv, proc.stderr)
        lines = proc.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("shlight passthrough: error: "), \
            proc.stderr
        assert says in lines[0]


def test_near_objects_the_sphere_sees_elsewhere_do_not_move_the_fit(room, tmp_path):
    """Parallax: half the views have a near object (an ellipse over ~10 % of the frame)
    whose light the sphere has 15-30° away; the medians and the edge filter keep the fit."""
    truth = HeadsetSim(n_views=40, seed=3, parallax=0.5).render(room, str(tmp_path))
    fitted = score(truth, fitted_model(fit_folder(room, tmp_path)))
    for key, limit in DONE_WHEN.items():
        assert fitted[key] <= limit, (key, fitted)


def test_a_black_view_is_flagged_and_the_others_still_fit(room, headset, tmp_path):
    import shutil
    import cv2
    folder, truth = headset
    copy = tmp_path / "views"
    shutil.copytree(folder, copy)
    cv2.imwrite(str(copy / truth.views[5].file_path), np.zeros((240, 320, 3), np.uint8))
    sphere = tmp_path / "room.exr"
    _write_exr(sphere, room)
    proc = run_cli("passthrough", str(copy), "--sphere", str(sphere), timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "1 view(s) had too few usable pixels" in proc.stderr
    assert truth.views[5].file_path in proc.stderr
    views = json.loads(proc.stdout)["views"]
    assert views[5]["fitted"] is False and views[5]["samples"] < 30
    assert all("fitted" not in v for i, v in enumerate(views) if i != 5)
    ratio = np.array([v["exposure"] for v in views]) / truth.exposure
    others = np.delete(np.log2(ratio), 5)
    assert np.std(others) < 0.1


def test_opencv_distortion_is_undone_as_opencv_projects_it(tmp_path):
    """An OPENCV record's pixel looks along the ray that cv2.projectPoints (OpenCV's own
    forward model, camera axes x right, y down, z forward) sends back to that pixel."""
    import cv2
    cv2.imwrite(str(tmp_path / "a.jpg"), np.zeros((240, 320, 3), np.uint8))
    rot = look_rotation(30.0, 10.0, 5.0)
    dist = dict(k1=-0.12, k2=0.03, p1=0.001, p2=-0.0015)
    doc = {"camera_model": "OPENCV", **dist, "frames": [
        {"file_path": "a.jpg", "transform_matrix": _m(rot), "fl_x": 170.0, "fl_y": 168.0,
         "cx": 161.0, "cy": 118.0, "w": 320, "h": 240}]}
    (tmp_path / "transforms.json").write_text(json.dumps(doc))
    view = read_transforms(tmp_path)[0]
    px, py = np.meshgrid(np.linspace(5, 315, 7), np.linspace(5, 235, 5))
    d = view.directions(px, py).reshape(-1, 3)
    cam = d @ rot                       # world -> OpenGL camera axes
    cv_cam = cam * (1, -1, -1)          # OpenGL -> OpenCV camera axes
    K = np.array([[170.0, 0, 161.0], [0, 168.0, 118.0], [0, 0, 1]])
    back, _ = cv2.projectPoints(cv_cam, np.zeros(3), np.zeros(3), K,
                                np.array(list(dist.values())))
    # undistortPoints iterates (5 rounds by default): a few hundredths of a pixel off
    assert np.abs(back.reshape(-1, 2) - np.stack([px.ravel(), py.ravel()], -1)).max() < 0.05


def test_the_fit_keeps_the_newest_views_it_is_given(room, headset):
    folder, _ = headset
    views = read_transforms(folder)
    fit = PassthroughFit(room, max_views=10)
    for v in views[:15]:
        fit.add_view(v, read_view_image(v))
    assert [v.file_path for v in fit.views] == [v.file_path for v in views[5:15]]
    assert len(fit.solve().exposure) == 10


def test_the_views_exposures_are_in_the_spheres_units(room, tmp_path):
    """An 8-bit sphere with its exposure time (PANO@SECONDS) is radiance per second of
    exposure, as compute reads it: ten times the radiance, a tenth of the exposure; the
    curve and the white balance do not change."""
    import cv2
    from provider.core.radiometry.response import srgb_decode
    HeadsetSim(n_views=16, seed=4).render(room, str(tmp_path / "views"))
    codes = np.clip(np.rint(255 * np.interp(np.clip(room / 8.0, 0, 1),
                                            srgb_decode(np.linspace(0, 1, 4096)),
                                            np.linspace(0, 1, 4096))), 0, 255)
    pano = tmp_path / "pano.png"
    cv2.imwrite(str(pano), codes.astype(np.uint8)[..., ::-1])
    outs = []
    for sphere in (str(pano), f"{pano}@0.1"):
        proc = run_cli("passthrough", str(tmp_path / "views"), "--sphere", sphere)
        assert proc.returncode == 0, proc.stderr
        assert "decoded as sRGB" in proc.stderr          # no --sphere-camera: said
        outs.append(json.loads(proc.stdout))
    plain, timed = outs
    assert CameraResponse.from_dict(timed["camera"]).table == pytest.approx(
        CameraResponse.from_dict(plain["camera"]).table, rel=1e-4)
    # The fit is scale-equivariant; what differs is the float32 decode of the two spheres
    # (radiance rounded after the division by 0.1), which can move a median by a neighbour.
    for a, b in zip(plain["views"], timed["views"]):
        assert b["exposure"] == pytest.approx(0.1 * a["exposure"], rel=1e-4)
        assert b["wb_gains"] == pytest.approx(a["wb_gains"], rel=1e-4)
        assert b["ev100"] == pytest.approx(a["ev100"] + np.log2(10), abs=1e-4)


def test_poses_three_degrees_off_are_found_again(tmp_path):
    """Tracking 3° off (RMS) in a room with thin bright structures (the bridge's cables
    against the sky): each view's pose is searched (within 3°) for the turn under which its
    codes correlate best with the sphere, and the fit holds; trusting the poses, it does
    not."""
    room = perturb_panorama(load_hdri("bridge"), seed=ROOM_SEED)
    truth = HeadsetSim(n_views=40, seed=3, pose_noise_deg=3.0).render(room, str(tmp_path))
    views = read_transforms(tmp_path)
    images = [read_view_image(v) for v in views]
    results = {}
    for refine in (3.0, 0.0):
        fit = PassthroughFit(room, refine_deg=refine)
        for view, image in zip(views, images):
            fit.add_view(view, image)
        results[refine] = fit.solve()
    found = score(truth, fitted_model(results[3.0]))
    trusted = score(truth, fitted_model(results[0.0]))
    for key, limit in DONE_WHEN.items():
        assert found[key] <= limit, (key, found, trusted)
    assert trusted["pixel_p90"] > DONE_WHEN["pixel_p90"], trusted
    # the turns found are the size of the tracking error on the optical axis
    axis_error = [np.degrees(np.arccos(np.clip(v.rotation[:, 2] @ r[:, 2], -1, 1)))
                  for v, r in zip(truth.views, truth.rotations)]
    assert abs(np.median(results[3.0].pose_correction_deg) - np.median(axis_error)) < 0.75


def test_a_registration_takes_the_headsets_world_into_the_spheres(room, tmp_path):
    """The headset's world turned 40° (and tilted) from the sphere's: with the registration,
    in either form (world_to_sphere, or shlight register's rotation with the marker's
    rotation in the headset's world), the fit is the one of views already in the sphere's
    frame; without it, the views explain nothing."""
    folder = tmp_path / "views"
    HeadsetSim(n_views=16, seed=6).render(room, str(folder))
    doc = json.loads((folder / "transforms.json").read_text())
    r_ws = look_rotation(40.0, 8.0, 3.0)                # world <- sphere
    for f in doc["frames"]:
        m = np.array(f["transform_matrix"])
        m[:3, :3] = r_ws @ m[:3, :3]
        m[:3, 3] = r_ws @ m[:3, 3]
        f["transform_matrix"] = m.tolist()
    (folder / "world.json").write_text(json.dumps(doc))
    r_cm = look_rotation(-120.0, 20.0, 10.0)            # camera <- marker (shlight register)
    (tmp_path / "reg_a.json").write_text(json.dumps({"world_to_sphere": r_ws.T.ravel().tolist()}))
    (tmp_path / "reg_b.json").write_text(json.dumps({
        "marker": "aruco:DICT_4X4_50:7", "rotation": np.round(r_cm, 7).ravel().tolist(),
        "position": [0.1, 0.2, -1.5], "marker_in_world": (r_ws @ r_cm).ravel().tolist()}))
    sphere = tmp_path / "room.exr"
    _write_exr(sphere, room)
    runs = {}
    for name, argv in [("sphere", (str(folder / "transforms.json"),)),
                       ("a", (str(folder / "world.json"), "--registration",
                              str(tmp_path / "reg_a.json"))),
                       ("b", (str(folder / "world.json"), "--registration",
                              str(tmp_path / "reg_b.json"))),
                       ("none", (str(folder / "world.json"),))]:
        proc = run_cli("passthrough", *argv, "--sphere", str(sphere), timeout=120)
        assert proc.returncode == 0, proc.stderr
        runs[name] = json.loads(proc.stdout)["views"]
    base = np.array([v["exposure"] for v in runs["sphere"]])
    for name in ("a", "b"):
        # rounding of register's 7 digits moves the poses by ~1e-5°: the same fit
        assert np.array([v["exposure"] for v in runs[name]]) == pytest.approx(base, rel=1e-3)
    resid = lambda k: np.median([v["residual_stops"] or 9 for v in runs[k]])
    assert resid("none") > 3 * resid("sphere"), (resid("none"), resid("sphere"))


def test_a_fisheye_sphere_fits_the_views_it_sees(room, headset, fitted, tmp_path):
    """A 180° fisheye looking up (docs/contract.md §1) as the sphere: the views that see
    its hemisphere render as their real surfaces do; what it does not see is not compared
    (a view with nothing to compare says fitted: false)."""
    from provider.core.geometry.projections import make_projection
    folder, truth = headset
    size = 512
    projection = make_projection("fisheye", size, size)
    ys, xs = np.mgrid[0:size, 0:size]
    dirs, seen = projection.pixel_to_direction(xs + 0.5, ys + 0.5)
    image = np.where(np.asarray(seen)[..., None], sample_equirect(room, dirs), 0.0)
    sphere = tmp_path / "fisheye.exr"
    _write_exr(sphere, image.astype(np.float32))
    proc = run_cli("passthrough", str(folder), "--sphere", str(sphere),
                   "--sphere-projection", "fisheye", timeout=120)
    assert proc.returncode == 0, proc.stderr
    views = json.loads(proc.stdout)["views"]
    up = np.array([v.rotation[1, 2] < -0.35 for v in truth.views])   # looking 20°+ up
    ok = np.array([v.get("fitted", True) for v in views])
    assert up.sum() >= 5 and ok[up].all()
    # the views it sees render as their real surfaces do, by the score
    import dataclasses
    idx = np.flatnonzero(up)
    seen_truth = dataclasses.replace(
        truth, views=[truth.views[i] for i in idx], rotations=[truth.rotations[i] for i in idx],
        exposure=truth.exposure[idx], wb_gains=truth.wb_gains[idx],
        radiance=[truth.radiance[i] for i in idx], codes=[truth.codes[i] for i in idx])
    model = result_from_json(json.loads(proc.stdout))
    got = score(seen_truth, lambda i, L, rho2: model.predict_codes(L, idx[i], rho2))
    for key, limit in DONE_WHEN.items():
        assert got[key] <= limit, (key, got)
    # views toward the floor compare only the part above the fisheye's horizon
    down = np.array([v.rotation[1, 2] > 0.4 for v in truth.views])     # 24°+ down
    samples = np.array([v["samples"] for v in views])
    assert down.sum() >= 3 and np.all(samples[down] < 0.5 * fitted.samples[down])


def test_a_warm_solve_after_new_views_needs_few_rounds(room, headset, fitted):
    """The seam for a live fit: views added to a solved fit, re-solved from the last curve
    in two rounds, score as the full twelve-round fit of all of them does."""
    folder, truth = headset
    views = read_transforms(folder)
    fit = PassthroughFit(room)
    for v in views[:30]:
        fit.add_view(v, read_view_image(v))
    fit.solve()
    for v in views[30:]:
        fit.add_view(v, read_view_image(v))
    warm = score(truth, fitted_model(fit.solve(iterations=2, warm=True)))
    cold = score(truth, fitted_model(fitted))
    for key in DONE_WHEN:
        # two fits of the same samples from nearby starts: within a fiftieth of a stop
        assert warm[key] == pytest.approx(cold[key], abs=0.02), (key, warm, cold)
