"""Registration (docs/contract.md §13): a printed marker's pose in a panorama, measured on
markers composited into the shared panoramas at known poses (tests/marker_scene.py, the tests'
own ray-traced renderer), for every projection the engine reads."""
from __future__ import annotations

import json
import math
import struct
import subprocess
import sys

import cv2
import zlib

import numpy as np
import pytest

from marker_scene import (composite, marker_grid, qr_grid, random_pose, rotation_error_deg,
                          scene, to_srgb8)
from provider.core.errors import InputError
from provider.core.geometry.projections import make_projection
from provider.core.registration.pose import MarkerNotFound, find_marker, levelling_rotation

MARKER = "aruco:DICT_4X4_50:7"
SIZE = 0.2


def camera_still(base, projection, grid, R, t, rng, *, jpeg=True):
    """What a camera records: the composite, lens blur, sensor noise, 8-bit sRGB, JPEG."""
    img = composite(base, projection, grid, R, t, SIZE, quiet=1 if grid.shape[0] < 10 else 4)
    white = 0.8 * float(base.reshape(-1, 3).mean(0) @ [0.2126, 0.7152, 0.0722])
    img = cv2.GaussianBlur(img, (0, 0), 0.7)
    img = img + rng.normal(0, 0.02 * white, img.shape).astype(np.float32)
    img = to_srgb8(img, white)
    if jpeg:
        ok, buf = cv2.imencode(".jpg", img[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 90])
        img = cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1]
    return np.ascontiguousarray(img)


def measure(width, scenes, poses, seed, *, distance=(0.8, 2.0)):
    proj = make_projection("equirect", width, width // 2)
    rng = np.random.default_rng(seed)
    rot, pos = [], []
    for name in scenes:
        base = scene(name, proj)
        for _ in range(poses):
            R, t = random_pose(rng, distance)
            pose = find_marker(camera_still(base, proj, marker_grid(), R, t, rng), MARKER, SIZE)
            rot.append(rotation_error_deg(pose.rotation, R))
            pos.append(float(np.linalg.norm(pose.position - t)))
    return np.array(rot), np.array(pos)


def test_4k_still_meets_the_rotation_and_position_targets():
    """3840×1920 JPEG stills, 20 cm markers at 0.8-2 m tilted up to 60°: rotation ≤ 1°
    median, ≤ 3° worst (no planar-ambiguity flip), position ≤ 2 cm."""
    rot, pos = measure(3840, ["city", "forest"], 4, seed=11)
    assert np.median(rot) <= 1.0 and rot.max() <= 3.0, rot
    assert pos.max() <= 0.02, pos


def test_1920_live_frame_meets_its_target():
    rot, pos = measure(1920, ["lab", "sky"], 4, seed=12)
    assert np.median(rot) <= 2.5, rot
    assert np.median(pos) <= 0.02, pos


@pytest.mark.parametrize("name,width,height,around", [
    ("fisheye", 1280, 1280, (0, 1, 0)),        # default mount looks up: a marker above
    ("dual-fisheye", 1920, 1080, None),
    ("cubemap", 3840, 640, None),
])
def test_every_projection_gives_the_pose(name, width, height, around):
    proj = make_projection(name, width, height)
    base = scene("apartment", proj)
    rng = np.random.default_rng(zlib.crc32(name.encode()))   # the same poses every run
    for _ in range(2):
        R, t = random_pose(rng, around=None if around is None else np.array(around, float),
                           max_off_deg=70)
        img = composite(base, proj, marker_grid(), R, t, SIZE)
        pose = find_marker(img, MARKER, SIZE, name)
        assert rotation_error_deg(pose.rotation, R) < 1.0
        assert np.linalg.norm(pose.position - t) < 0.02


def test_marker_across_the_equirect_seam_and_at_the_zenith():
    """Behind the camera (+Z, where u wraps from 1 to 0) and overhead (+Y, the top row)."""
    proj = make_projection("equirect", 1920, 960)
    base = scene("venice", proj)
    for axis in ([0, 0, 1.0], [0, 1.0, 0]):
        t = np.array(axis) * 1.2
        z = -np.array(axis)
        x = np.cross([1.0, 0.3, 0.2], z)
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(z, x), z], axis=1)
        pose = find_marker(composite(base, proj, marker_grid(), R, t, SIZE), MARKER, SIZE)
        assert rotation_error_deg(pose.rotation, R) < 1.0
        assert np.linalg.norm(pose.position - t) < 0.01


def test_rotation_columns_are_the_markers_axes_in_the_camera_frame():
    """A marker 1 m in front (−Z, the panorama's centre), printed upright and facing the
    camera: its x is +X (right), y is +Y (up), z is +Z (toward the camera)."""
    proj = make_projection("equirect", 1920, 960)
    img = composite(scene("dawn", proj), proj, marker_grid(), np.eye(3), [0, 0, -1.0], SIZE)
    pose = find_marker(img, MARKER, SIZE)
    assert np.allclose(pose.rotation, np.eye(3), atol=0.01)
    assert np.allclose(pose.position, [0, 0, -1], atol=0.005)
    assert pose.marker_id == 7 and pose.error_deg < 0.05
    assert 50 < pose.apparent_size_px < 70      # 0.2 rad × 305 px/rad


def test_qr_code_by_its_text():
    proj = make_projection("equirect", 3840, 1920)
    base = scene("bridge", proj)
    rng = np.random.default_rng(5)
    R, t = random_pose(rng, (1.0, 1.2), max_tilt_deg=40)
    img = composite(base, proj, qr_grid("room-1"), R, t, SIZE, quiet=4)
    pose = find_marker(img, "qr:room-1", SIZE)
    assert pose.marker_id == "room-1"
    assert rotation_error_deg(pose.rotation, R) < 1.0
    with pytest.raises(MarkerNotFound):
        find_marker(img, "qr:room-2", SIZE)


def test_no_marker_is_an_error_never_a_pose():
    proj = make_projection("equirect", 1920, 960)
    base = scene("night", proj)
    with pytest.raises(MarkerNotFound, match="no aruco:DICT_4X4_50:7 marker"):
        find_marker(base, MARKER, SIZE)
    other = composite(base, proj, marker_grid(marker_id=8), np.eye(3), [0, 0, -1.0], SIZE)
    with pytest.raises(MarkerNotFound):
        find_marker(other, MARKER, SIZE)
    assert find_marker(other, "aruco:DICT_4X4_50", SIZE).marker_id == 8   # any id


@pytest.mark.parametrize("spec,size", [("aruco:DICT_9X9_1:1", 0.2), ("aruco:DICT_4X4_50:50", 0.2),
                                       ("qrx", 0.2), (MARKER, 0), (MARKER, float("nan"))])
def test_bad_marker_specs_are_refused_in_one_line(spec, size):
    with pytest.raises(InputError):
        find_marker(np.zeros((64, 128, 3), np.uint8), spec, size)


def test_a_flat_marker_faces_up_once_a_tilted_still_is_levelled():
    """A marker lying on the floor, filmed by a camera pitched 10° and rolled −6°: the still's
    XMP says so, and the levelled pose has the marker's z along +Y (up)."""
    level = levelling_rotation(10.0, -6.0)           # R_level<-camera
    # The true pose in the level world: on the floor, 1 m ahead and 0.9 m down.
    R_world = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])   # z up, y toward -Z
    t_world = np.array([0.1, -0.9, -1.0])
    R_cam, t_cam = level.T @ R_world, level.T @ t_world
    proj = make_projection("equirect", 1920, 960)
    img = composite(scene("lab", proj), proj, marker_grid(), R_cam, t_cam, SIZE)
    pose = find_marker(img, MARKER, SIZE)
    assert pose.rotation[:, 2] @ [0, 1, 0] < math.cos(math.radians(5))   # tilted as filmed
    from provider.core.registration.pose import levelled
    up = levelled(pose, level)
    assert rotation_error_deg(up.rotation, R_world) < 0.5 and up.levelled


def _jpeg_with_xmp(rgb, xmp: str) -> bytes:
    ok, buf = cv2.imencode(".jpg", rgb[..., ::-1], [cv2.IMWRITE_JPEG_QUALITY, 95])
    payload = b"http://ns.adobe.com/xap/1.0/\x00" + xmp.encode()
    app1 = b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload
    data = buf.tobytes()
    return data[:2] + app1 + data[2:]


def _run(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "provider.cli", *args], capture_output=True,
                          text=True, cwd=cwd, timeout=300)


def test_register_command_prints_the_levelled_pose_and_says_no_marker_in_one_line(tmp_path):
    level = levelling_rotation(8.0, 5.0)
    R_world = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])
    t_world = np.array([-0.2, -0.8, -0.9])
    proj = make_projection("equirect", 1920, 960)
    base = scene("apartment", proj)
    img = composite(base, proj, marker_grid(), level.T @ R_world, level.T @ t_world, SIZE)
    white = 0.8 * float(base.reshape(-1, 3).mean(0) @ [0.2126, 0.7152, 0.0722])
    still = tmp_path / "still.jpg"
    still.write_bytes(_jpeg_with_xmp(to_srgb8(img, white), (
        '<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/'
        '22-rdf-syntax-ns#"><rdf:Description xmlns:GPano="http://ns.google.com/photos/1.0/'
        'panorama/" GPano:PosePitchDegrees="8.0" GPano:PoseRollDegrees="5.0"/></rdf:RDF>'
        '</x:xmpmeta>')))
    out = _run("register", str(still), "--marker", MARKER, "--marker-size", "0.2")
    assert out.returncode == 0, out.stderr
    got = json.loads(out.stdout)
    assert got["levelled"] is True and got["marker_id"] == 7
    R = np.array(got["rotation"]).reshape(3, 3)
    assert rotation_error_deg(R, R_world) < 1.0
    assert np.allclose(got["position"], t_world, atol=0.02)
    assert got["error_px"] < 0.5 and got["apparent_size_px"] > 20
    off = _run("register", str(still), "--marker", MARKER, "--marker-size", "0.2", "--level", "off")
    assert json.loads(off.stdout)["levelled"] is False
    blank = tmp_path / "blank.jpg"
    cv2.imwrite(str(blank), to_srgb8(base, white)[..., ::-1])
    miss = _run("register", str(blank), "--marker", MARKER, "--marker-size", "0.2")
    assert miss.returncode == 2 and miss.stdout == ""
    assert miss.stderr.count("\n") == 1 and "no aruco:DICT_4X4_50:7 marker found" in miss.stderr


def test_marker_command_writes_a_png_that_prints_to_size_and_is_detected(tmp_path):
    out = tmp_path / "marker.png"
    run = _run("marker", MARKER, "--size", "0.2", "--dpi", "150", "-o", str(out))
    assert run.returncode == 0, run.stderr
    data = out.read_bytes()
    at = data.index(b"pHYs")
    ppm_x, ppm_y, unit = struct.unpack(">IIB", data[at + 4:at + 13])
    assert unit == 1 and abs(ppm_x / 39.37 - 150) < 0.5 and ppm_x == ppm_y
    page = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    corners, ids, _ = cv2.aruco.ArucoDetector(dictionary).detectMarkers(page)
    assert ids is not None and ids.ravel().tolist() == [7]
    side_px = np.linalg.norm(corners[0][0][1] - corners[0][0][0])
    assert abs(side_px / 150 * 25.4 - 200) < 200 / 6 / 150 * 25.4 * 6   # whole dots per cell
    assert "--marker-size 0.2" in run.stderr
    qr = _run("marker", "qr:room-1", "--size", "0.1", "-o", str(tmp_path / "qr.png"))
    assert qr.returncode == 0
    text, _, _ = cv2.QRCodeDetector().detectAndDecode(cv2.imread(str(tmp_path / "qr.png"), 0))
    assert text == "room-1"
    bad = _run("marker", "aruco:DICT_4X4_50", "-o", str(tmp_path / "x.png"))
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
