"""Bad lens files, chessboard photos, theta:// URLs and Theta options (issue 41): each one
clear line and exit 2 before any work, nothing written, no traceback; a FIFO image for
register is waited on with a note, as compute does. Real files, the real CLI, the fake OSC
camera on loopback."""
from __future__ import annotations

import json
import math
import os
import struct
import subprocess
import sys
import zlib

import cv2
import numpy as np
import pytest

from fakecams.osc_camera import FakeOscCamera
from conftest import load_hdri
from servertools import ROOT, SHLIGHT, ServerThread, poll, run_cli
from servertools import refused as _refused
from lensboardtools import BOARD, poses, render_board, true_lens

from provider.core.errors import InputError
from provider.core.geometry.checks import ProjectionError
from provider.core.geometry.lens_calibration import (MAX_CURVE_TERMS, board_points,
                                                     calibrate_lens, lens_from_dict)

#: A lens file as calibrate-lens writes it: an equidistant-like lens, 90° ring at 180 px.
LENS = {"shlight_lens": 1, "model": "kannala-brandt", "curve": [1.0, -0.01, 0.0, 0.0, 0.0],
        "focal": 180.0, "aspect": 1.0, "center": [640.0, 360.0], "image_size": [1280, 720],
        "fov_deg": 200.0, "profile": "theta-s"}


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    d = tmp_path_factory.mktemp("lensin")
    assert cv2.imwrite(str(d / "dual.png"), np.full((720, 1280, 3), 100, np.uint8))
    return d


def _lens(d, name, text=None, **fields):
    path = d / name
    path.write_text(text if text is not None else json.dumps(dict(LENS, **fields)))
    return str(path)


def _lens_cases(d):
    return [
        # Python's json writes and reads Infinity; no other JSON reader does
        (_lens(d, "inf.json", json.dumps(dict(LENS, image_size=[math.inf, 720]))),
         ["Infinity is not a JSON number"]),
        (_lens(d, "big.json", json.dumps(LENS).replace("1280", "1e400")),
         ["1e400 is beyond the range of a JSON number"]),
        (_lens(d, "float.json", image_size=[1280.5, 720]),
         ["image_size must be two whole numbers"]),
        (_lens(d, "plist.json", profile=["theta-s"]), ["profile must be one of", "['theta-s']"]),
        (_lens(d, "brackets.json", "[" * 50_000), ["JSON nested too deeply (at most 2 levels)"]),
        (_lens(d, "huge.json", "[" * 100_000), ["100,000 bytes, too large", "at most 64 KiB"]),
        (_lens(d, "terms.json", curve=[1.0] + [0.0] * MAX_CURVE_TERMS),
         ["curve has 17 terms, at most 16 (a calibration writes 5"]),
        (_lens(d, "many.json", curve=[1.0] + [0.0] * 100_000), ["at most 64 KiB"]),
        (_lens(d, "nested.json", curve=[[1.0, -0.01], [0.0, 0.0]]),
         ["JSON nested too deeply (at most 2 levels)"]),
        (_lens(d, "text.json", focal="180"), ["focal must be a number, got '180'"]),
        (_lens(d, "fov.json", fov_deg=0), ["fov_deg 0 is not a field of view"]),
    ]


@pytest.mark.parametrize("command", ["compute", "export", "register", "serve"])
def test_a_bad_lens_file_is_one_line_in_every_command(frames, command):
    """Each bad lens file, whichever command reads it, and for a fisheye and a dual-fisheye
    frame alike: one line naming the file and what is wrong."""
    img = str(frames / "dual.png")
    argv = {"compute": ["compute", img], "export": ["export", img, "--to", "unity"],
            "register": ["register", img, "--marker", "qr", "--marker-size", "0.1"],
            "serve": ["serve", "--port", "0", "--source", img]}[command]
    cases = _lens_cases(frames)
    projections = ["dual-fisheye"] if command == "serve" else ["dual-fisheye", "fisheye"]
    for projection in projections:
        for path, words in cases:
            res = run_cli(*argv, "--projection", projection, "--lens", path)
            line = _refused(res, *words)
            assert os.path.basename(path) in line


def test_lens_from_dict_bounds_the_curve_and_refuses_lists_for_words():
    """The same rules for a lens given as a dict (the library's entry): 100,001 terms are
    refused at once (evaluating them for every pixel would take minutes), a nested curve is
    not flattened, a profile must be a word."""
    for bad, words in [(dict(LENS, curve=[1.0] + [0.0] * 100_000),
                        "curve has 100,001 terms, at most 16"),
                       (dict(LENS, curve=[[1.0, -0.01]]), "curve[0] must be a number"),
                       (dict(LENS, curve=[]), "curve must be a list of 1-16 numbers, got 0"),
                       (dict(LENS, image_size=[math.inf, 720]), "image_size[0] must be a finite"),
                       (dict(LENS, center=[640, 10 ** 400]), "center[1] must be a finite"),
                       (dict(LENS, profile={"a": 1}), "profile must be one of"),
                       (dict(LENS, focal=True), "focal must be a number, got True")]:
        with pytest.raises(ProjectionError, match=words.replace("[", r"\[")):
            lens_from_dict(bad, "L")
    assert lens_from_dict(LENS)["image_size"] == (1280, 720)      # the good one still reads


def test_a_lens_file_that_is_a_fifo_is_refused_not_waited_on(frames):
    fifo = frames / "fifo.json"
    os.mkfifo(fifo)
    for argv in (["compute", str(frames / "dual.png"), "--projection", "fisheye"],
                 ["register", str(frames / "dual.png"), "--marker", "qr", "--marker-size", "0.1",
                  "--projection", "dual-fisheye"]):
        _refused(run_cli(*argv, "--lens", str(fifo)), "not a regular file")


@pytest.mark.parametrize("text, words", [
    ("[" * 50_000, ["JSON nested too deeply (at most 3 levels)"]),
    ('{"K": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "D": [NaN, 0, 0, 0]}', ["NaN is not a JSON number"]),
    ("[1, 2]", ['not {"K": 3x3, "D": 4}']),
    (None, ["not a regular file"])])
def test_a_bad_opencv_calibration_file_is_one_line(frames, tmp_path, text, words):
    """--calibration (an OpenCV fisheye K, D) is read by the lens file's rules."""
    path = tmp_path / "kd.json"
    if text is None:
        os.mkfifo(path)
    else:
        path.write_text(text)
    _refused(run_cli("compute", str(frames / "dual.png"), "--projection", "fisheye", "--fov",
                     "170", "--calibration", str(path)), f"cannot use calibration {path}", *words)


def test_a_narrow_lens_file_is_read_without_naming_a_downsample_nobody_gave(frames):
    """A 10° lens: its circle (15.7 px) is whole in the frame but not in the error
    estimate's coarse copy, which then uses a finer one: lighting, not an error naming
    --downsample 15."""
    path = _lens(frames, "fov10.json", fov_deg=10)
    for projection in ("fisheye", "dual-fisheye"):
        res = run_cli("compute", str(frames / "dual.png"), "--projection", projection,
                      "--lens", path)
        assert res.returncode == 0, res.stderr
        assert "--downsample" not in res.stderr
        msg = json.loads(res.stdout)
        assert np.all(np.isfinite(msg["coefficients"]))
        assert math.isfinite(msg["error_estimate"])
    # the user's own --downsample is still named when it is the one that shrinks the circle
    res = run_cli("compute", str(frames / "dual.png"), "--projection", "fisheye", "--lens", path,
                  "--downsample", "4")
    _refused(res, "after --downsample 4")


def test_register_waits_on_a_fifo_image_with_a_note(frames, tmp_path):
    """As compute does: a FIFO image is a note ("waiting for a writer"), said before the
    wait, then read once something writes it."""
    fifo = tmp_path / "still.png"
    os.mkfifo(fifo)
    proc = subprocess.Popen([*SHLIGHT, "register", str(fifo), "--marker", "qr",
                             "--marker-size", "0.1"], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        first = proc.stderr.readline()        # said before it waits: the read returns
        assert "note: waiting for a writer on FIFO" in first and str(fifo) in first
        ok, png = cv2.imencode(".png", np.full((64, 128, 3), 90, np.uint8))
        with open(fifo, "wb") as f:
            f.write(png.tobytes())
        out, err = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 2 and out == "" and "Traceback" not in err
    assert "no qr marker found" in err


@pytest.mark.parametrize("url, words", [
    ("theta://[::1", ["theta:// URL: Invalid IPv6 URL"]),
    ("theta://host:99999", ["theta:// URL: Port out of range"]),
    ("theta://", ["theta source needs a host"])])
def test_a_bad_theta_url_is_one_line_for_register_and_serve(frames, url, words):
    """Checked before any still is taken or any image read (the good image comes first)."""
    line = _refused(run_cli("register", str(frames / "dual.png"), url, "--marker", "qr",
                            "--marker-size", "0.1"), *words)
    assert "note" not in line
    _refused(run_cli("serve", "--port", "0", "--source", url), *words)


def test_a_bad_stream_url_is_one_line_not_echoed():
    line = _refused(run_cli("serve", "--port", "0", "--source", "http://u:secret@[::1"),
                    "http:// source: Invalid IPv6 URL")
    assert "secret" not in line


@pytest.mark.parametrize("value, words", [
    ("{bad json", ["iso={bad json: not JSON"]),
    ("NaN", ["iso=NaN: not a number a camera reads"]),
    ("Infinity", ["iso=Infinity: not a number a camera reads"]),
    ("-inf", ["iso=-inf: not a number a camera reads"]),
    ("1e400", ["1e400 is beyond the range of a JSON number"]),
    ('{"a": [[[[1]]]]}', ["JSON nested too deeply (at most 4 levels)"]),
    ("[" * 100_000, ["JSON nested too deeply (at most 4 levels)"])])
def test_a_bad_theta_option_value_is_one_line(value, words):
    res = run_cli("serve", "--port", "0", "--source", "theta://127.0.0.1:9",
                  "--theta-option", f"iso={value}")
    _refused(res, "--theta-option", *words)


def test_theta_option_values_parse_as_json_or_a_word():
    from provider.cli.serve import _theta_option
    assert _theta_option("whiteBalance=daylight") == ("whiteBalance", "daylight")
    assert _theta_option("iso=200") == ("iso", 200)
    assert _theta_option("_hdr=true") == ("_hdr", True)
    assert _theta_option('previewFormat={"width":1024,"height":512,"framerate":8}') == \
        ("previewFormat", {"width": 1024, "height": 512, "framerate": 8})


def test_theta_check_is_bounded_and_says_its_bound():
    _refused(run_cli("serve", "--port", "0", "--source", "theta://127.0.0.1:9",
                     "--theta-check", "1e308"), "--theta-check 1e+308: out of range (0, 3600]")


def test_a_theta_option_in_probe_args_reaches_that_probes_camera():
    """`--probe-args 'b=--theta-option iso=200'` (a traceback before): probe b's camera is
    set to it."""
    theta = FakeOscCamera(load_hdri("apartment"))
    try:
        with ServerThread("--probe", "a=demo", "--probe", f"b={theta.spec}",
                          "--probe-args", "b=--theta-option iso=200"):
            poll(lambda: theta.options.get("iso") == 200, 20, what="iso set on b's camera")
    finally:
        theta.close()


# ---- calibrate-lens -----------------------------------------------------------------------------

@pytest.fixture(scope="module")
def boards(tmp_path_factory):
    """Rendered chessboard photos through a known lens (test_lens_calibration's renderer):
    three good views, and three at one tilt, moved across the circle."""
    d = tmp_path_factory.mktemp("boards")
    lens = true_lens()
    for i, (R, t) in enumerate(poses(3)):
        assert cv2.imwrite(str(d / f"good{i}.png"), render_board(lens, R, t, ss=1))
    R = np.diag([1.0, -1.0, -1.0])           # facing the lens, square on to its axis
    for i, dx in enumerate((-0.25, -0.05, 0.15)):
        assert cv2.imwrite(str(d / f"flat{i}.png"),
                           render_board(lens, R, np.array([dx, -0.1, 0.3]), ss=1))
    png = (d / "good0.png").read_bytes()
    ihdr = bytearray(png[16:29])
    ihdr[0:8] = struct.pack(">II", 100_000, 100_000)               # 10^10 pixels declared
    crc = struct.pack(">I", zlib.crc32(b"IHDR" + bytes(ihdr)) & 0xFFFFFFFF)
    (d / "huge.png").write_bytes(png[:16] + bytes(ihdr) + crc + png[33:])
    return d


@pytest.mark.parametrize("photos, extra, words", [
    (["huge.png", "good0.png", "good1.png"], [], ["huge.png", "100000×100000", "too large"]),
    (["good0.png", "good0.png", "good0.png"], [], ["in only 1 distinct place"]),
    (["good0.png", "good1.png", "good2.png"], ["--fov", "1e-9"],
     ["outside a field of view of 1e-09°", "at least"]),
])
def test_calibrate_lens_refuses_what_cannot_give_a_lens(boards, photos, extra, words):
    out = boards / "lens.json"
    res = run_cli("calibrate-lens", *(str(boards / p) for p in photos), "--board",
                  f"{BOARD[0]}x{BOARD[1]}", *extra, "-o", str(out), timeout=300)
    _refused(res, *words)
    assert not out.exists()


def test_calibrate_lens_refuses_boards_at_one_tilt(boards):
    """Boards square on to the lens, moved across the circle: Zhang's degenerate case. OpenCV
    fits them badly (37.7 px RMS measured) or, for boards moved in the image only, exactly
    (0.002 px RMS) with a meaningless lens (1.9° between their tilts): refused either way."""
    out = boards / "lens.json"
    res = run_cli("calibrate-lens", *(str(boards / f"flat{i}.png") for i in range(3)),
                  "--board", f"{BOARD[0]}x{BOARD[1]}", "-o", str(out), timeout=300)
    line = _refused(res)
    assert "did not fit the photos" in line or "face the lens at one tilt" in line, line
    assert not out.exists()
    grid = board_points(BOARD, 10.0)[:, :2]
    with pytest.raises(ProjectionError, match="face the lens at one tilt"):
        calibrate_lens([grid + (100 + 50 * i, 200) for i in range(3)], BOARD, (480, 480))


def test_calibrate_lens_refuses_opencvs_starting_guess():
    """Corners no fisheye made: OpenCV hands back its starting guess (D = 0) at 100-230 px
    RMS without an error; refused, not written."""
    rng = np.random.default_rng(0)
    corners = [rng.uniform(0, 480, (BOARD[0] * BOARD[1], 2)) for _ in range(3)]
    with pytest.raises(ProjectionError, match="did not fit the photos"):
        calibrate_lens(corners, BOARD, (480, 480))


def test_strict_json_reader_is_one_input_error():
    from provider.core.json_text import depth, parse_json
    assert depth([1, {"a": [2]}]) == 3 and depth(5) == 0
    with pytest.raises(InputError, match="^x: JSON nested too deeply"):
        parse_json("[" * 100_000, "x", 8)
    assert parse_json('{"a": [1.5]}', "x", 2) == {"a": [1.5]}
