"""Issue 33's tracebacks, each now one clear line on stderr and exit 2 with nothing on
stdout (or, for a frame of all zeros, a warning and the message): exposures whose lighting
overflows, a full disk under stdout (a closed pipe stays quiet), frames too small to
calibrate, an absurd Debevec lambda, a marker size no marker has, QR text past a QR code's
capacity, a bench folder under a file, libpng's and OpenCV's own lines for a giant PNG
header or a corrupt .hdr, and ``export --cube-size 0``. The same refusals in the library."""
from __future__ import annotations

import os
import struct
import subprocess
import zlib

import cv2
import numpy as np
import pytest

from servertools import ROOT, SHLIGHT, refused, run_cli


def _png_with_size(src: bytes, width: int, height: int) -> bytes:
    ihdr = bytearray(src[16:29])
    ihdr[0:8] = struct.pack(">II", width, height)
    crc = struct.pack(">I", zlib.crc32(b"IHDR" + bytes(ihdr)) & 0xFFFFFFFF)
    return src[:16] + bytes(ihdr) + crc + src[33:]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    import OpenEXR
    d = tmp_path_factory.mktemp("bad33")
    rng = np.random.default_rng(33)
    assert cv2.imwrite(str(d / "pano.jpg"), rng.integers(0, 256, (64, 128, 3), dtype=np.uint8))
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for name, pixels in (("bright.exr", 1.0 + rng.random((32, 64, 3), dtype=np.float32)),
                         ("zero.exr", np.zeros((32, 64, 3), np.float32))):
        with OpenEXR.File(header, {"RGB": pixels}) as f:
            f.write(str(d / name))
    assert cv2.imwrite(str(d / "black.png"), np.zeros((32, 64, 3), np.uint8))
    for name, (h, w) in (("one", (1, 1)), ("small", (4, 8))):      # brackets too small
        base = rng.random((h, w, 3))
        for i, k in enumerate((0.25, 1.0, 4.0)):
            assert cv2.imwrite(str(d / f"{name}{i}.png"),
                               np.clip(base * 255 * k, 0, 255).astype(np.uint8))
    png = (d / "black.png").read_bytes()
    (d / "giant.png").write_bytes(_png_with_size(png, 2 ** 31, 2 ** 30))
    (d / "giant2.png").write_bytes(_png_with_size(png, 2 ** 31 - 1, 2 ** 30))
    (d / "empty.png").write_bytes(_png_with_size(png, 0, 4))
    (d / "bad.hdr").write_bytes(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 64 +X 128\n"
                                + bytes(range(256)) * 8)
    (d / "file").write_text("not a folder")
    return d


def _bracket(files, name):
    return [f"{files / f'{name}{i}.png'}@{t}" for i, t in enumerate(("1/16", "1/4", "1"))]


# -- exposure: the lighting overflows ---------------------------------------------------------

@pytest.mark.parametrize("argv, words", [
    (["compute", "{d}/pano.jpg", "--exposure", "1e39"], ["exposure 1e+39 overflows", "to 3.4e+38"]),
    (["export", "{d}/pano.jpg", "--to", "unity", "--exposure", "1e39"], ["exposure 1e+39"]),
    (["compute", "{d}/bright.exr", "--exposure", "1e308"], ["exposure 1e+308"]),
    (["compute", "{d}/pano.jpg", "--exposure", "1e-40"], ["exposure 1e-40 underflows",
                                                          "from 1.18e-38"]),
    (["compute", "{d}/pano.jpg", "--exposure", "3e38"],
     ["the lighting overflows at exposure 3e+38", "float32"]),
    (["compute", "{d}/bright.exr", "--exposure", "1e38"],
     ["the lighting overflows at exposure 1e+38", "float32"]),
    (["environment", "{d}/bright.exr", "--exposure", "3e38", "-o", "{d}/over.ktx2"],
     ["the lighting overflows at exposure 3e+38", "float32"]),
])
def test_an_exposure_whose_lighting_overflows_isrefused(files, argv, words):
    res = run_cli(*[a.format(d=files) for a in argv])
    assert "RuntimeWarning" not in res.stderr
    refused(res, *words)


def test_a_cube_brighter_than_half_float_says_how_many_texels_are_held(files):
    """The KTX2 cube is half float: texels beyond 65504 are stored as 65504, and the command
    says how many (no silent clamping)."""
    res = run_cli("environment", f"{files}/bright.exr", "--exposure", "1e5", "-o",
                  f"{files}/held.ktx2")
    assert res.returncode == 0, res.stderr
    assert "RuntimeWarning" not in res.stderr
    warning = [line for line in res.stderr.splitlines() if "65504" in line]
    assert len(warning) == 1 and "8,184 of 8,184 texels are brighter than half float" in warning[0]
    quiet = run_cli("environment", f"{files}/bright.exr", "-o", f"{files}/fine.ktx2")
    assert quiet.returncode == 0 and "65504" not in quiet.stderr


def test_the_library_refuses_lighting_that_overflows():
    from provider.core.errors import InputError
    from provider.core.options import LIGHTING_MAX, check_lighting, check_options
    from provider.core.sh9.engine import SH9Projector
    with pytest.raises(InputError, match="overflows"):
        check_options(exposure=1e39)
    frame = np.full((16, 32, 3), 2.0, np.float32)
    with pytest.raises(InputError, match="the lighting overflows at exposure 1e\\+38"):
        SH9Projector(32, 16, exposure=1e38).project(frame)
    with pytest.raises(InputError, match="and a 1e-30 s frame"):
        SH9Projector(32, 16).project(frame * 1e10, exposure_s=1e-30)
    big = SH9Projector(32, 16, exposure=1e30).project(frame).coefficients
    assert np.all(np.isfinite(big)) and np.abs(big).max() < LIGHTING_MAX
    with pytest.raises(InputError, match="not finite"):
        check_lighting(np.full((9, 3), np.nan))


# -- stdout: a full disk is one line, a closed pipe is quiet ----------------------------------

@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full here")
@pytest.mark.parametrize("argv", [["compute", "{d}/bright.exr"],
                                  ["export", "{d}/bright.exr", "--to", "gltf"],
                                  ["compute", "{d}/bright.exr", "--pretty"]])
def test_a_full_disk_under_stdout_is_one_line(files, argv):
    with open("/dev/full", "w") as full:
        res = subprocess.run([*SHLIGHT, *[a.format(d=files) for a in argv]], cwd=ROOT,
                             stdout=full, stderr=subprocess.PIPE, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert "Traceback" not in res.stderr and "Exception ignored" not in res.stderr
    assert res.stderr.strip().splitlines() == [
        f"shlight {argv[0]}: error: cannot write the output: No space left on device"]


def test_a_reader_that_left_is_quiet(files):
    proc = subprocess.Popen([*SHLIGHT, "compute", str(files / "bright.exr")], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()                       # `| head -c0`: gone before the first byte
    err = proc.stderr.read()
    assert proc.wait(timeout=60) in (0, 141)
    assert err == ""


# -- calibrate-response ------------------------------------------------------------------------

@pytest.mark.parametrize("name, method, size", [("one", "auto", "1×1"), ("one", "debevec", "1×1"),
                                                ("small", "auto", "8×4"),
                                                ("small", "debevec", "8×4")])
def test_frames_too_small_to_calibrate_are_one_line(files, name, method, size):
    out = files / "cam.json"
    line = refused(run_cli("calibrate-response", "--method", method, "-o", str(out),
                            *_bracket(files, name)),
                    "the frames are too small to calibrate", size, "at least 12×12")
    assert "cv2" not in line and not out.exists()


def test_an_absurd_lambda_is_refused_before_solving(files):
    """No LAPACK lines on stdout, and not blamed on the frames."""
    out = files / "cam.json"
    refused(run_cli("calibrate-response", "--method", "debevec", "--lambda", "1e300",
                     "-o", str(out), *_bracket(files, "small")),
             "--lambda must be a finite number above 0 and at most 1e+06", "1e+300")
    assert not out.exists()


def test_the_library_refuses_them_too(files):
    from provider.core.radiometry.response import ResponseError, calibrate
    frames = [cv2.imread(str(files / f"small{i}.png")) for i in range(3)]
    with pytest.raises(ResponseError, match="too small to calibrate: 8×4 pixels"):
        calibrate(frames, [1 / 16, 1 / 4, 1])
    big = [cv2.resize(f, (64, 32)) for f in frames]
    with pytest.raises(ResponseError, match="lambda must be a finite number above 0"):
        calibrate(big, [1 / 16, 1 / 4, 1], lambda_=1e300)


# -- markers -----------------------------------------------------------------------------------

@pytest.mark.parametrize("size", ["1e300", "1e6", "0.001", "0"])
def test_register_refuses_a_marker_size_no_marker_has(files, size):
    refused(run_cli("register", str(files / "pano.jpg"), "--marker", "aruco:DICT_4X4_50:7",
                     "--marker-size", size), "--marker-size", "0.005-5 m")


def test_a_qr_text_past_a_qr_codes_capacity_is_one_line(files):
    out = files / "m.png"
    line = refused(run_cli("marker", "qr:" + "x" * 5000, "-o", str(out)),
                    "too long for a QR code", "5000 characters", "2953 bytes")
    assert len(line) < 300 and not out.exists()


def test_the_library_refuses_marker_sizes_and_long_qr_text():
    from provider.core.errors import InputError
    from provider.core.registration.marker_detect import parse_marker
    from provider.core.registration.marker_print import printable_marker
    from provider.core.registration.pose import find_marker
    with pytest.raises(InputError, match="0.005-5 m"):
        find_marker(np.zeros((64, 128, 3), np.uint8), "aruco:DICT_4X4_50:7", 1e300)
    with pytest.raises(InputError, match="capacity|too long"):
        printable_marker(parse_marker("qr:" + "1" * 7090), 0.2)
    assert printable_marker(parse_marker("qr:" + "1" * 7089), 0.2).ndim == 2


# -- bench --out -------------------------------------------------------------------------------

def test_bench_out_under_a_file_is_one_line(files):
    """(A read-only folder, the issue's case, is the same check; root writes anywhere, so it
    is tested below only for other users.)"""
    refused(run_cli("bench", "--out", str(files / "file" / "b"), "--quick"),
             "--out", "cannot write under", str(files / "file"))


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
def test_bench_out_in_a_read_only_folder_is_one_line(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        refused(run_cli("bench", "--out", str(ro / "b"), "--quick"), "cannot write under")
    finally:
        ro.chmod(0o755)


# -- noise before the line ---------------------------------------------------------------------

@pytest.mark.parametrize("name, words", [
    ("giant.png", ["2147483648×1073741824", "too large to decode"]),
    ("giant2.png", ["2147483647×1073741824", "too large to decode"]),
    ("empty.png", ["0×4", "corrupt"]),
    ("bad.hdr", ["not a Radiance .hdr file"]),
])
def test_no_libpng_or_opencv_lines_before_the_one_line(files, name, words):
    line = refused(run_cli("compute", str(files / name)), *words)
    assert "libpng" not in line and "[ERROR" not in line


# -- export --cube-size ------------------------------------------------------------------------

@pytest.mark.parametrize("extra, words", [
    (["--cube-size", "0"], ["--cube-size 0", "a power of two from 8 to 256"]),
    (["--cube-size", "12"], ["--cube-size 12", "a power of two"]),
    (["--cube-size", "64", "--no-cube"], ["--cube-size", "--no-cube"]),
])
def test_export_refuses_a_cube_size_it_cannot_make(files, extra, words):
    refused(run_cli("export", str(files / "pano.jpg"), "--to", "gltf", *extra), *words)


# -- a frame of all zeros: said, and still answered --------------------------------------------

@pytest.mark.parametrize("argv", [["compute", "{d}/zero.exr"], ["compute", "{d}/black.png"],
                                  ["export", "{d}/zero.exr", "--to", "unity"]])
def test_a_frame_of_all_zeros_is_a_warning_not_silence(files, argv):
    import json
    res = run_cli(*[a.format(d=files) for a in argv])
    assert res.returncode == 0, res.stderr
    assert res.stderr.strip().splitlines() == [
        f"shlight {argv[0]}: warning: the frame is all zeros where the projection looks: no "
        "light, the lighting is black (a lens cap, a black render, the wrong file?)"]
    assert json.loads(res.stdout)["type"] in ("sh9", "export")


def test_a_lit_frame_has_no_such_warning(files):
    res = run_cli("compute", str(files / "bright.exr"))
    assert res.returncode == 0 and res.stderr == ""
