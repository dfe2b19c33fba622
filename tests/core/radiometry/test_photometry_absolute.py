"""Issue 31: absolute units from a still's own exposure (EXIF), ``calibrate-response --lux``,
``illuminance_lux`` / ``ev100`` / ``coefficient_units`` in the message, and a bracket's span
that no longer moves the scale. Frames come from the simulated filmic camera
(provider/bench/camera_sim.py) written by Pillow with real EXIF, read by the real command."""
from __future__ import annotations

import json
import struct
import subprocess

import numpy as np
import pytest

from provider.bench.camera_sim import CameraSim
from provider.core.radiometry.bracket import merge
from provider.core.radiometry.exif import exposure_from_tiff, read_still_exposure
from provider.core.radiometry.photometry import (LUMINANCE_WEIGHTS, ev100,
                                                 illuminance_up, luminance)
from provider.core.radiometry.response_fit import calibrate_best
from provider.core.sh9.engine import SH9Projector
from provider.live.wire.message import coefficient_message, validate

from conftest import load_hdri

from photometrytools import (CAMERA_K, NOISY, exact_illuminance_up, exact_mean_luminance,
                             message, save_still, scene, shlight, write_bracket)


# -- EXIF --------------------------------------------------------------------------------------

@pytest.mark.parametrize("ext", ["jpg", "tif"])
def test_exif_exposure_of_a_still(tmp_path, ext):
    rgb = np.full((8, 16, 3), 100, np.uint8)
    path = tmp_path / f"still.{ext}"
    save_still(path, rgb, 1 / 250, 5.6, 400)
    e = read_still_exposure(path)
    assert e.complete
    assert e.exposure_s == pytest.approx(1 / 250) and e.f_number == pytest.approx(5.6)
    assert e.iso == 400


PADDING = b"\x00\x17" + b"\xff\x01" + b"\xff\xff"


def padded_jpeg(data: bytes) -> bytes:
    """The same JPEG with what decoders tolerate before every header segment but the first
    (ITU T.81 B.1.1.2; libjpeg skips it with a warning): stray bytes, a TEM marker (no
    length) and fill bytes (0xFF 0xFF 0xFF before the marker). Walked strictly by hand."""
    out, pos = bytearray(data[:2]), 2
    while True:
        pad = PADDING if pos > 2 else b""
        if data[pos + 1] == 0xDA:
            return bytes(out + pad + data[pos:])
        (length,) = struct.unpack(">H", data[pos + 2:pos + 4])
        out += pad + data[pos:pos + 2 + length]
        pos += 2 + length


def test_exif_of_a_jpeg_with_fill_and_stray_bytes(tmp_path):
    """EXIF is found where a decoder finds the frame: one segment walk serves both (the
    frame budget's header_size and the still's exposure)."""
    import cv2
    from provider.core.radiometry.image_size import header_size
    rgb = np.full((8, 16, 3), 100, np.uint8)
    save_still(tmp_path / "still.jpg", rgb, 1 / 250, 5.6, 400)
    data = padded_jpeg((tmp_path / "still.jpg").read_bytes())
    assert PADDING + b"\xff\xe1" in data and data.count(PADDING) >= 3   # before the EXIF too
    (tmp_path / "padded.jpg").write_bytes(data)
    decoded = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    assert decoded.shape[:2] == (8, 16)                     # a real decoder reads it
    assert header_size(data) == (16, 8)
    e = read_still_exposure(tmp_path / "padded.jpg")
    assert e.exposure_s == pytest.approx(1 / 250) and e.f_number == pytest.approx(5.6)
    assert e.iso == 400
    # truncated inside the EXIF segment: no exposure, no error
    cut = data.index(b"Exif\0\0") + 20
    (tmp_path / "cut.jpg").write_bytes(data[:cut])
    assert not read_still_exposure(tmp_path / "cut.jpg").complete
    assert header_size(data[:cut]) is None


def test_exif_big_endian_iso_above_65534_and_malformed():
    # a hand-built big-endian TIFF: IFD0 -> Exif IFD with ExposureTime, FNumber, ISO 65535 and
    # RecommendedExposureIndex 102400 (EXIF 2.3: the ISO is above 65534)
    entries = [(0x829A, 5, 1, 1, 8000), (0x829D, 5, 1, 28, 10), (0x8827, 3, 1, 65535, None),
               (0x8832, 4, 1, 102400, None)]
    exif_at = 8 + 2 + 12 + 4
    data_at = exif_at + 2 + 12 * len(entries) + 4
    ifd0 = struct.pack(">H", 1) + struct.pack(">HHII", 0x8769, 4, 1, exif_at) + b"\0" * 4
    body, extra = struct.pack(">H", len(entries)), b""
    for tag, kind, count, a, b in entries:
        if kind == 5:
            body += struct.pack(">HHII", tag, kind, count, data_at + len(extra))
            extra += struct.pack(">II", a, b)
        elif kind == 3:
            body += struct.pack(">HHIHH", tag, kind, count, a, 0)
        else:
            body += struct.pack(">HHII", tag, kind, count, a)
    data = b"MM\0*" + struct.pack(">I", 8) + ifd0 + body + b"\0" * 4 + extra
    e = exposure_from_tiff(data)
    assert e.exposure_s == pytest.approx(1 / 8000) and e.f_number == pytest.approx(2.8)
    assert e.iso == 102400
    for broken in (b"", b"MM\0*\xff\xff\xff\xff", data[:30], b"II*\0" + data[4:]):
        assert not exposure_from_tiff(broken).complete


def test_a_still_without_exif_says_nothing(tmp_path):
    import cv2
    path = tmp_path / "plain.jpg"
    cv2.imwrite(str(path), np.zeros((4, 8, 3), np.uint8))
    assert read_still_exposure(path).exposure_s is None
    assert read_still_exposure(tmp_path / "missing.jpg").exposure_s is None


# -- the relation and the message --------------------------------------------------------------

def test_ev100_of_a_metered_scene_is_the_cameras_own_setting():
    # a reflected-light meter puts N²/t = L·S/K: f/4, 1/125 s at ISO 100 is EV100 11 and
    # the scene that meters so has L = 2**11 · 12.5 / 100 cd/m²
    assert ev100(2 ** 11 * 12.5 / 100) == pytest.approx(11.0)
    assert ev100(0.0) is None
    assert LUMINANCE_WEIGHTS.sum() == pytest.approx(1.0)


def test_relative_units_without_calibration_and_no_lux():
    hdr = np.ones((32, 64, 3), np.float32)
    result = SH9Projector(64, 32, "equirect").project(hdr)
    msg = coefficient_message(result)
    validate(msg)
    assert msg["coefficient_units"] == "relative"
    assert "illuminance_lux" not in msg and "ev100" not in msg
    # a uniform sky of radiance 1 lights an up-facing surface with π (the furnace test)
    assert illuminance_up(result.matrices) == pytest.approx(np.pi, rel=2e-3)


# -- absolute calibration and held-out brackets --------------------------------------------------

@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """camera.json from a ±4 EV bracket of the apartment at f/2, ISO 100 and a lux meter."""
    folder = tmp_path_factory.mktemp("abs")
    hdr = scene("apartment")
    paths = write_bracket(folder, "cal", hdr, (-4, -2, 0, 2, 4), n=2.0, iso=100)
    lux = exact_illuminance_up(hdr)
    p = shlight("calibrate-response", *paths, "--lux", lux, "-o", folder / "camera.json")
    assert p.returncode == 0, p.stderr
    return folder, p


def test_calibrate_response_stores_the_absolute_scale(calibrated):
    folder, p = calibrated
    a = json.loads((folder / "camera.json").read_text())["params"]["absolute"]
    assert a["f_number"] == 2.0 and a["iso"] == 100
    assert "absolute scale" in p.stdout
    # the simulated camera is 1.3× more sensitive than ISO 12232's nominal one
    assert a["vs_iso12232"] == pytest.approx(1 / 1.3, rel=0.08)


@pytest.mark.parametrize("name,n,iso", [("forest", 5.6, 400), ("city", 2.8, 800)])
def test_held_out_bracket_gives_lux_from_exif_alone(calibrated, tmp_path, name, n, iso):
    folder, _ = calibrated
    hdr = scene(name)
    paths = write_bracket(tmp_path, name, hdr, (-6, -4, -2, 0, 2, 4), n=n, iso=iso, seed=3)
    msg = message(shlight("compute", *paths, "--camera", folder / "camera.json"))
    assert msg["coefficient_units"] == "cd/m²" and msg["f_number"] == pytest.approx(n)
    truth = exact_illuminance_up(hdr)
    assert msg["illuminance_lux"] == pytest.approx(truth, rel=0.05), (msg["illuminance_lux"],
                                                                       truth)
    # EV100 of the scene's mean luminance over the sphere (reflected-light meter, K = 12.5)
    assert msg["ev100"] == pytest.approx(np.log2(exact_mean_luminance(hdr) * 100 / 12.5),
                                         abs=0.1)


def test_one_still_with_exif_is_absolute_too(calibrated, tmp_path):
    folder, _ = calibrated
    hdr = scene("forest")
    (path,) = write_bracket(tmp_path, "one", hdr, (0,), n=4.0, iso=200, ext="jpg")
    msg = message(shlight("compute", path, "--camera", folder / "camera.json"))
    assert msg["coefficient_units"] == "cd/m²" and msg["iso"] == 200
    assert msg["exposure_s"] > 0 and msg["illuminance_lux"] > 0
    plain = message(shlight("compute", path))
    assert plain["coefficient_units"] == "relative" and "illuminance_lux" not in plain


def test_bad_lux_is_one_line(tmp_path):
    p = shlight("calibrate-response", "a.png@1", "b.png@2", "c.png@4", "--lux", "-3",
                "-o", tmp_path / "c.json")
    assert p.returncode == 2 and "--lux must be a positive" in p.stderr
    assert "Traceback" not in p.stderr


# -- a bracket's span ------------------------------------------------------------------------------

def test_a_wider_bracket_does_not_move_the_scale():
    """Calibrated on ±4 EV; the ±6 EV bracket's extra frames put samples in the toe the
    calibration never explained (trusted codes from ~45): they must not move the level.
    Before the trusted-range weights the green L00 moved by 2.3 % here."""
    cam = CameraSim(clip_stops=(2.5, 2.45, 2.55), shot=2e-4, read=2e-3)
    hdr = np.maximum(load_hdri("apartment"), 0)
    t0 = 0.18 / float(np.median(hdr.mean(axis=-1)))
    frames, times = cam.bracket(hdr, t0, (-4, -2, 0, 2, 4))
    response = calibrate_best(frames, times)
    assert response.params["trusted_codes"][0] > 16
    projector = SH9Projector(hdr.shape[1], hdr.shape[0], "equirect")
    levels = []
    for evs in ((-4, -2, 0, 2, 4), (-6, -4, -2, 0, 2, 4, 6)):
        f2, t2 = cam.bracket(hdr, t0, evs, seed=1)
        levels.append(projector.project(merge(f2, t2, response).radiance).coefficients[0])
    assert np.max(np.abs(levels[1] / levels[0] - 1)) < 0.01, levels


def test_exact_up_illuminance_of_the_engine():
    """The engine's up-facing illuminance sums the pixels (SH9 would truncate it): a sky of
    1 cd/m² over a black ground gives π lux; the camera mounted upside down sees it below."""
    h, w = 64, 128
    sky = np.zeros((h, w, 3), np.float32)
    sky[: h // 2] = 1.0
    assert SH9Projector(w, h, "equirect").up_illuminance(sky) == pytest.approx(np.pi, rel=1e-4)
    flip = np.diag([1.0, -1.0, -1.0])                  # 180° about X: the sky goes below
    assert SH9Projector(w, h, "equirect", rotation=flip).up_illuminance(sky) < 0.01
    # a fisheye looking up sees the upper hemisphere: π within its pixel quadrature
    fish = np.ones((128, 128, 3), np.float32)
    lux = SH9Projector(128, 128, "fisheye").up_illuminance(fish)
    assert lux == pytest.approx(np.pi, rel=0.02)


def test_calibrate_lux_needs_aperture_and_iso_in_one_line(tmp_path):
    """Frames without EXIF (PNG@SECONDS) say nothing of their aperture and ISO: --lux asks
    for them, in one line, and writes nothing; --f-number alone is refused."""
    import cv2
    hdr = scene("apartment")
    args = []
    cam = CameraSim(gain=CAMERA_K / 4, **NOISY)
    frames, times = cam.bracket(hdr, 0.01, (-2, 0, 2))
    for i, (f, t) in enumerate(zip(frames, times)):
        path = tmp_path / f"f{i}.png"
        cv2.imwrite(str(path), np.ascontiguousarray(f[..., ::-1]))
        args.append(f"{path}@{t!r}")
    out = tmp_path / "c.json"
    p = shlight("calibrate-response", *args, "--lux", 300, "-o", out)
    assert p.returncode == 2 and "--f-number N and --iso S" in p.stderr
    assert "Traceback" not in p.stderr and not out.exists()
    p = shlight("calibrate-response", *args, "--f-number", 2, "-o", out)
    assert p.returncode == 2 and "--f-number is for --lux" in p.stderr
    p = shlight("calibrate-response", *args, "--lux", 300, "--f-number", 2, "--iso", 100,
                "-o", out)
    assert p.returncode == 0, p.stderr
    assert json.loads(out.read_text())["params"]["absolute"]["f_number"] == 2


def test_threejs_exposure_follows_the_rooms_ev100(calibrated, tmp_path):
    """client-three.js physicalExposure (renderer.toneMappingExposure) from a real message:
    the room's mean luminance renders at 12.5 / 120 of white whatever its level (the
    saturation-based exposure 1 / (1.2 · 2^EV100) of the reflected-light meter's EV100)."""
    import shutil
    from pathlib import Path
    node = shutil.which("node")
    if node is None:
        pytest.skip("node is not installed")
    folder, _ = calibrated
    hdr = scene("forest")
    (path,) = write_bracket(tmp_path, "one", hdr, (0,), n=4.0, iso=200, ext="jpg")
    msg = message(shlight("compute", path, "--camera", folder / "camera.json"))
    client = Path(__file__).resolve().parents[3] / "provider/live/server/static/client-three.js"
    script = tmp_path / "exposure.mjs"
    script.write_text(f'import {{ physicalExposure }} from "{client.as_uri()}";\n'
                      f'const m = {json.dumps(msg)};\n'
                      'console.log(JSON.stringify([physicalExposure({message: m}), '
                      'physicalExposure({message: {...m, ev100: undefined}})]));\n')
    out = subprocess.run([node, str(script)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    exposure, relative = json.loads(out.stdout)
    mean = float(luminance(np.array(msg["coefficients"][:3]))) * 0.282095
    assert mean * exposure == pytest.approx(12.5 / 120, rel=1e-6)
    assert relative is None


def test_gltf_directional_lights_carry_lux(calibrated, tmp_path):
    """In absolute units the glTF export's KHR_lights_punctual directional lights are in lux
    (the spec's unit): Y(color) · intensity is the light's light_illuminance_lux."""
    folder, _ = calibrated
    hdr = scene("lab")
    paths = write_bracket(tmp_path, "lab", hdr, (-6, -4, -2, 0, 2, 4), n=4.0, iso=400)
    common = [*paths, "--camera", folder / "camera.json", "--lights", "auto"]
    msg = message(shlight("compute", *common))
    p = shlight("export", *common, "--to", "gltf")
    assert p.returncode == 0, p.stderr
    lights = json.loads(p.stdout)["KHR_lights_punctual"]
    assert msg["lights"] == len(lights) >= 1
    lux = [float(luminance(np.array(light["color"]))) * light["intensity"] for light in lights]
    assert lux == pytest.approx(msg["light_illuminance_lux"], rel=1e-6)


def test_unity_core_reads_photometry(calibrated, tmp_path):
    """The Unity package's C# core (compiled with Mono's mcs, no UnityEngine) reads
    coefficient_units, illuminance_lux, ev100, cct_k and each light's lux from a real absolute
    message, and gives the physical exposure 1/(1.2·2^EV100); a relative message gives NaN."""
    import shutil
    from pathlib import Path
    mcs, mono = shutil.which("mcs"), shutil.which("mono")
    if not (mcs and mono):
        pytest.skip("Mono is not installed")
    root = Path(__file__).resolve().parents[3]
    core = sorted((root / "unity_package" / "Runtime" / "Core").glob("*.cs"))
    exe = tmp_path / "PhotometryTest.exe"
    r = subprocess.run([mcs, "-nologo", "-warnaserror+", "-nowarn:618", "-target:exe",
                        f"-out:{exe}", *map(str, core),
                        str(root / "tests" / "csharp" / "PhotometryTest.cs")],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    folder, _ = calibrated
    paths = write_bracket(tmp_path, "lab", scene("lab"), (-6, -4, -2, 0, 2, 4), n=4.0, iso=400)
    msg = message(shlight("compute", *paths, "--camera", folder / "camera.json",
                          "--lights", "auto"))
    relative = message(shlight("compute", paths[3]))
    got = []
    for m in (msg, relative):
        out = subprocess.run([mono, str(exe)], input=json.dumps(m), capture_output=True,
                             text=True, timeout=60)
        assert out.returncode == 0, out.stderr
        got.append(json.loads(out.stdout))
    a, rel = got
    assert a["absolute"] and a["units"] == "cd/m2"
    assert a["lux"] == pytest.approx(msg["illuminance_lux"]) and a["ev100"] == pytest.approx(msg["ev100"])
    assert a["exposure"] == pytest.approx(1 / (1.2 * 2 ** msg["ev100"]))
    assert a["cct"] == pytest.approx(msg["cct_k"]) and a["lights"] == msg["lights"] >= 1
    assert a["light_lux"] == pytest.approx(msg["light_illuminance_lux"])
    assert not rel["absolute"] and rel["units"] == "relative" and rel["exposure"] is None
    assert rel["light_lux"] == []


def test_a_fifo_is_not_read_for_exif(tmp_path):
    """compute reads FIFOs (a writer per image): looking for EXIF must not eat their bytes."""
    import os
    import threading
    if not hasattr(os, "mkfifo"):
        pytest.skip("POSIX FIFOs")
    fifo = tmp_path / "frame.jpg"
    os.mkfifo(fifo)
    assert read_still_exposure(fifo).exposure_s is None       # returns at once, reads nothing
    still = tmp_path / "still.jpg"
    save_still(still, np.full((16, 32, 3), 120, np.uint8), 1 / 100, 2.0, 100)
    data = still.read_bytes()
    writer = threading.Thread(target=lambda: fifo.write_bytes(data))
    writer.start()
    msg = message(shlight("compute", fifo))
    writer.join(timeout=30)
    assert msg["coefficients"][0] > 0 and "exposure_s" not in msg
