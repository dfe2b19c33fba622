"""A camera's colour from a ColorChecker (docs/photometry.md, "A camera's colour from a
ColorChecker"): ``calibrate-response … --checker PHOTO`` writes the camera's white balance
and 3×3 colour matrix into camera.json, and every command that takes ``--camera`` reads the
room's colour in Rec. 709 through it.

The camera is the simulated filmic 8-bit one (not sRGB) behind its own primaries (a 3×3 mix
of Rec. 709 and a white balance off, as a sensor's raw RGB is); the chart is rendered from
colour-science's ColorChecker reference (the test's truth; the product uses OpenCV's)."""
from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from PIL import Image

from provider.bench.camera_sim import CameraSim
from provider.core.radiometry.colour_temperature import rgb_of_cct
from provider.core.radiometry.photometry import NOMINAL_CD_M2, luminance
from provider.live.wire.message import validate

from conftest import load_hdri
from stilltools import jpeg_still, shlight

#: The sensor's RGB of Rec. 709 light: its primaries mix the channels and its white balance
#: (daylight-ish) leaves red high and blue low.
SENSOR = np.array([[0.80, 0.25, -0.05], [0.10, 0.85, 0.05], [0.02, 0.20, 0.78]]) \
    * np.array([[1.4], [1.0], [0.6]])
CAMERA_K = 1.3 / NOMINAL_CD_M2


def shoot(folder, name, rec709, evs, n=4.0, iso=100, seed=0):
    """Stills of the sensor's view of Rec. 709 radiance, metered at its mean (K = 12.5)."""
    sensor = np.maximum(rec709 @ SENSOR.T, 0.0)
    cam = CameraSim(gain=CAMERA_K * (iso / 100.0) / n ** 2, seed=seed, shot=5e-5, read=2e-4)
    t0 = 12.5 * n ** 2 / (float(luminance(rec709.reshape(-1, 3)).mean()) * iso)
    frames, times = cam.bracket(sensor, t0, evs)
    paths = []
    for ev, f, t in zip(evs, frames, times):
        paths.append(folder / f"{name}_{ev:+g}.jpg")
        jpeg_still(paths[-1], f, t, n, iso, subsampling=0)   # full chroma: colour
    return paths


def chart_scene() -> np.ndarray:
    """(600, 800, 3) Rec. 709 radiance (cd/m²) of a ColorChecker on a grey wall in D65
    light: colour-science's reference reflectances (2014), 60 px patches."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour
        cc = colour.CCS_COLOURCHECKERS["ColorChecker24 - After November 2014"]
        xyz = colour.xyY_to_XYZ(np.array(list(cc.data.values())))
        patches = np.clip(colour.XYZ_to_RGB(xyz, colour.RGB_COLOURSPACES["ITU-R BT.709"],
                                            cc.illuminant,
                                            chromatic_adaptation_transform="Bradford"),
                          0.0, None)
    size, gap = 60, 14
    h, w = 4 * size + 5 * gap, 6 * size + 7 * gap
    chart = np.full((h, w, 3), 0.03)
    for i, rgb in enumerate(patches):
        r, c = divmod(i, 6)
        y, x = gap + r * (size + gap), gap + c * (size + gap)
        chart[y:y + size, x:x + size] = rgb
    scene = np.full((600, 800, 3), 0.2)
    scene[150:150 + h, 200:200 + w] = chart
    return scene * 300.0


def tinted_room(t_k: float) -> np.ndarray:
    """A room none of the shared panoramas is (the forest re-lit and turned), tinted to a
    blackbody-like white of ``t_k`` (its mean radiance's colour), at 60 cd/m²."""
    from provider.bench.headset_sim import perturb_panorama
    room = perturb_panorama(load_hdri("forest"), seed=5).astype(np.float64)
    h = room.shape[0]
    edges = np.linspace(0, np.pi, h + 1)
    row = np.cos(edges[:-1]) - np.cos(edges[1:])
    mean = (room.mean(axis=1) * row[:, None]).sum(axis=0) / row.sum()
    room = room / mean * rgb_of_cct(t_k)
    return room * (60.0 / float(luminance(room.reshape(-1, 3)).mean()))


@pytest.fixture(scope="module")
def cameras(tmp_path_factory):
    """(camera.json with the chart's colour, camera.json without), one bracket of a room."""
    folder = tmp_path_factory.mktemp("checker")
    from provider.bench.headset_sim import perturb_panorama
    room = perturb_panorama(load_hdri("apartment"), seed=3).astype(np.float64)
    room *= 60.0 / float(luminance(room.reshape(-1, 3)).mean())
    bracket = shoot(folder, "cal", room, (-4, -2, 0, 2, 4))
    (chart,) = shoot(folder, "chart", chart_scene(), (0,))
    out = []
    for name, extra in (("colour.json", ["--checker", chart]), ("plain.json", [])):
        p = shlight("calibrate-response", *bracket, *extra, "-o", folder / name)
        assert p.returncode == 0, p.stderr
        out.append((folder / name, p.stdout))
    return out


def test_the_checker_fixes_the_cameras_colour(cameras):
    (coloured, said), _ = cameras
    params = json.loads(coloured.read_text())["params"]
    matrix = np.array(params["colour_matrix"])
    # the matrix undoes the sensor's mix up to the curve's own scale: near a multiple of I
    undone = matrix @ SENSOR
    undone /= np.trace(undone) / 3
    np.testing.assert_allclose(undone, np.eye(3), atol=0.06)
    assert params["white_balance"][0] < 1 < params["white_balance"][2]
    assert "white balance" in said and params["checker"]["patches"] >= 20


@pytest.mark.parametrize("t_k", [4500.0, 6000.0])
def test_every_command_with_the_camera_reads_rec709_colour(cameras, tmp_path, t_k):
    """A tinted room through the same camera, a 3-shot bracket of full-chroma (4:4:4) JPEGs:
    without the chart the sensor's RGB reads 4,500 K as 3,440 K and 6,000 K as 4,040 K (20-30 %
    low); with its matrix 4,580 K and 6,150 K (+2 %, +2.5 %; 5 % leaves room for another
    CPU's rounding of the merge and the fit). 4:2:0 JPEGs (Pillow's default) cost up to 8 %
    more: their chroma is averaged after the tone curve (docs/photometry.md)."""
    (coloured, _), (plain, _) = cameras
    frames = shoot(tmp_path, "room", tinted_room(t_k), (-4, 0, 4), seed=2)
    read = {}
    for name, camera in (("colour", coloured), ("plain", plain)):
        p = shlight("compute", *frames, "--camera", camera)
        assert p.returncode == 0, p.stderr
        msg = json.loads(p.stdout)
        validate(msg)
        read[name] = msg["cct_k"]
    print(f"{t_k:.0f} K room: {read['colour']:.0f} K with the chart's matrix, "
          f"{read['plain']:.0f} K without")
    assert read["colour"] == pytest.approx(t_k, rel=0.05), read
    assert read["plain"] < 0.85 * t_k, read


def test_a_photo_without_a_chart_is_one_line(tmp_path, cameras):
    (coloured, _), _ = cameras
    bracket = sorted(coloured.parent.glob("cal_*.jpg"))
    blank = tmp_path / "blank.jpg"
    Image.fromarray(np.full((300, 400, 3), 128, np.uint8)).save(blank)
    p = shlight("calibrate-response", *bracket, "--checker", blank, "-o", tmp_path / "c.json")
    assert p.returncode == 2 and "no ColorChecker" in p.stderr
    assert "Traceback" not in p.stderr and not (tmp_path / "c.json").exists()


def test_the_reflection_cube_takes_the_matrix_too(cameras, tmp_path):
    """``shlight environment --camera``: the cube's texels through the same matrix as the
    SH9 (its mean colour is the coefficients' L00 colour, both corrected)."""
    (coloured, _), (plain, _) = cameras
    (frame,) = shoot(tmp_path, "room", tinted_room(6000.0), (0,), seed=2)
    from provider.core.reflections.environment import EnvironmentProjector
    from provider.live.probe.camerafile import load_camera
    from provider.core.radiometry.images import read_image
    rgb = read_image(str(frame))
    h, w = rgb.shape[:2]
    means = {}
    for name, camera in (("colour", coloured), ("plain", plain)):
        response = load_camera(camera)
        cube = EnvironmentProjector(w, h, size=16, response=response).project(rgb)
        means[name] = cube.mips[0].reshape(-1, 3).astype(np.float64).mean(axis=0)
    matrix = np.array(json.loads(coloured.read_text())["params"]["colour_matrix"])
    # the same frame, the same curve up to the matrix: the corrected mean is the matrix's
    expected = matrix @ means["plain"]
    np.testing.assert_allclose(means["colour"], expected, rtol=0.02)


def test_a_meter_closes_in_the_cameras_colour(tmp_path):
    """The meter's luminance and a chroma meter's colour are Rec. 709's, the frame's RGB the
    camera's: with a colour matrix the closed light, once through the matrix, has the
    meter's lux and colour."""
    from provider.core.geometry.projections import Equirect
    from provider.core.radiometry.colour_temperature import cct_duv
    from provider.core.sh9.meter import close_clipped, up_weights
    matrix = np.linalg.inv(SENSOR)                      # this camera's own correction
    matrix /= float(luminance(matrix @ np.ones(3)))
    h, w = 32, 64
    weights = up_weights(Equirect(w, h))
    rad = np.full((h, w, 3), 1.0, np.float32)
    clipped = np.zeros((h, w), bool)
    clipped[6:8, 20:22] = True
    out, c = close_clipped(rad, clipped, weights, lux=40.0, colour=(3000.0, 0.0),
                           colour_matrix=matrix)
    seen = matrix @ np.tensordot(weights[0], out.astype(np.float64), axes=([0, 1], [0, 1]))
    assert float(luminance(seen)) == pytest.approx(40.0, rel=1e-4)
    assert cct_duv(seen)[0] == pytest.approx(3000.0, rel=5e-3)
