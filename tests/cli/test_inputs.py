"""Every bad input a user can give: one clear line, no traceback, nothing accepted that cannot
be right. Geometry is checked against the frame (a fisheye centre outside it, a lens circle
of a few pixels, a frame too small for its projection), non-finite numbers are refused
where they enter, and ``shlight serve`` refuses at start what no frame can fix, and says
once what a frame size cannot be projected with, instead of rebuilding per frame."""
from __future__ import annotations

import json
import math
import os
from pathlib import Path
import shutil

import cv2
import numpy as np
import pytest

from provider import InputError, SH9Projector, compute_sh9
from provider.core.options import check_options, precompute_note
from provider.core.geometry.sh import rotation_from_euler

from servertools import ServeProcess, health, poll, run_cli

HDRI = os.path.join(str(Path(__file__).resolve().parents[1]), "data", "hdri")


@pytest.fixture(scope="module")
def frames(tmp_path_factory):
    d = tmp_path_factory.mktemp("frames")
    cv2.imwrite(str(d / "pano.png"), np.full((128, 256, 3), 128, np.uint8))     # 2:1
    cv2.imwrite(str(d / "square.png"), np.full((240, 240, 3), 128, np.uint8))
    cv2.imwrite(str(d / "one.png"), np.full((1, 1, 3), 128, np.uint8))
    cv2.imwrite(str(d / "tiny.png"), np.full((1, 6, 3), 128, np.uint8))
    return d


def _refused(res, *words):
    assert res.returncode == 2, (res.stdout, res.stderr)
    assert "Traceback" not in res.stderr and res.stdout == ""
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr                 # one line, not a usage block
    for w in words:
        assert w in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("args, words", [
    (["--rotate", "nan,0,0"], ["--rotate", "finite"]),
    (["--rotate", "inf,0,0"], ["--rotate", "finite"]),
    (["--rotate", "0,-inf,0"], ["--rotate", "finite"]),
    (["--exposure", "nan"], ["--exposure", "finite"]),
    (["--projection", "fisheye", "--fov", "0"], ["--fov 0", "(0, 360]"]),
    (["--projection", "fisheye", "--fov", "nan"], ["--fov", "finite"]),
    (["--projection", "fisheye", "--fov", "400"], ["--fov 400"]),
    (["--projection", "fisheye", "--radius", "nan"], ["--radius", "finite"]),
    (["--projection", "fisheye", "--radius", "-5"], ["--radius -5"]),
    (["--projection", "fisheye", "--center", "99999,0"], ["centre (99999, 0)", "outside"]),
    (["--projection", "fisheye", "--center", "nan,3"], ["--center", "finite"]),
    (["--projection", "fisheye", "--center", "120,120", "--radius", "2"],
     ["image circle is 2.0 px", "too small"]),
    (["--projection", "fisheye", "--downsample", "40"], ["--downsample 40", "too small"]),
    (["--projection", "fisheye", "--albedo", "2"], ["--albedo 2"]),
    (["--order-budget", "inf"], ["--order-budget", "finite"]),
    (["--downsample", "0"], ["downsample"]),
])
def test_compute_refuses_impossible_options_in_one_line(frames, args, words):
    _refused(run_cli("compute", str(frames / "square.png"), *args), *words)


@pytest.mark.parametrize("image, projection, words", [
    ("one.png", "dual-fisheye", ["image circle", "too small"]),   # was: 24.4 sr > 4π
    ("one.png", "fisheye", ["image circle", "too small"]),
    ("tiny.png", "cubemap", ["too small"]),
])
def test_frames_too_small_for_their_projection_are_refused(frames, image, projection, words):
    _refused(run_cli("compute", str(frames / image), "--projection", projection), *words)


def test_a_panorama_read_as_a_fisheye_is_computed_with_a_warning(frames):
    res = run_cli("compute", str(frames / "pano.png"), "--projection", "fisheye")
    assert res.returncode == 0 and res.stdout.startswith("{")
    warnings = [l for l in res.stderr.splitlines() if "warning" in l]
    assert len(warnings) == 1 and "equirect" in warnings[0] and "2:1" in warnings[0]
    plain = run_cli("compute", str(frames / "square.png"), "--projection", "fisheye")
    assert plain.returncode == 0 and plain.stderr == ""


def test_the_engine_refuses_what_the_command_line_refuses():
    """Library users get the same checks, as InputError (never ValueError, ZeroDivisionError
    or 'math domain error' from deep inside)."""
    img = np.ones((240, 240, 3), np.float32)
    bad = [dict(fov_deg=0), dict(fov_deg=float("nan")), dict(radius=float("inf")),
           dict(radius=0), dict(center=(99999, 0)), dict(center=(float("nan"), 1)),
           dict(K=np.full((3, 3), np.nan), fov_deg=170)]
    for options in bad:
        with pytest.raises(InputError):
            SH9Projector(240, 240, "fisheye", **options)
    R = rotation_from_euler(30, 0, 0)
    for rotation in (np.full((3, 3), np.nan), 2 * R, np.diag([1.0, 1.0, -1.0]), np.eye(2)):
        with pytest.raises(InputError, match="rotation"):
            compute_sh9(img[:120], rotation=rotation)
    for options in (dict(exposure=float("inf")), dict(downsample="two"), dict(downsample=1.5),
                    dict(rotation="not a matrix"), dict(order_budget=float("nan"))):
        with pytest.raises(InputError):
            check_options(**options)
    with pytest.raises(InputError):
        SH9Projector(1, 1, "dual-fisheye")
    p = SH9Projector(240, 240, "fisheye", rotation=R)        # a real rotation is fine
    assert p.project(img).stats["coverage_sr"] == pytest.approx(2 * math.pi, rel=1e-3)
    assert SH9Projector(512, 256, "fisheye").warnings            # allowed, but said
    assert not SH9Projector(480, 480, "fisheye").warnings


def test_huge_non_equirect_frames_say_what_they_cost_before_building():
    note = precompute_note(8192, 4096, "fisheye")
    assert "--downsample 8 (1024×512)" in note and "4.4 GB" in note
    assert precompute_note(8192, 4096, "fisheye", downsample=8) is None
    assert precompute_note(8192, 4096, "equirect") is None     # separable: always quick
    assert precompute_note(640, 480, "fisheye") is None


def test_an_exr_with_another_extension_is_read_as_exr(tmp_path):
    renamed = tmp_path / "lab.jpg"
    shutil.copy(os.path.join(HDRI, "lab.exr"), renamed)
    res = run_cli("compute", str(renamed))
    assert res.returncode == 0, res.stderr
    want = compute_sh9(os.path.join(HDRI, "lab.exr")).coefficients
    np.testing.assert_array_equal(json.loads(res.stdout)["coefficients"], want.reshape(-1))
    np.testing.assert_array_equal(compute_sh9(str(renamed)).coefficients, want)


# ---- shlight serve ------------------------------------------------------------------------------

@pytest.mark.parametrize("args, words", [
    (["--rotate", "nan,0,0"], ["--rotate", "finite"]),
    (["--projection", "fisheye", "--fov", "0"], ["--fov 0"]),
    (["--projection", "fisheye", "--radius", "inf"], ["--radius", "finite"]),
    (["--probe", "a=demo", "--probe-args", "a=--projection fisheye --fov 0"], ["--fov 0"]),
    (["--max-hz", "nan"], ["--max-hz >= 0", "finite"]),
    (["--send-timeout", "inf"], ["--send-timeout > 0", "finite"]),
    (["--capture-size", "0x0"], ["--capture-size", "WIDTHxHEIGHT"]),
    (["--fps", "nan"], ["--fps nan", "out of range"]),
])
def test_serve_refuses_at_start_what_no_frame_can_fix(args, words):
    res = run_cli("serve", "--port", "0", *args)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("shlight serve: error:") and all(w in last for w in words), last


def test_serve_says_once_that_frames_cannot_be_projected_and_does_not_rebuild():
    """A centre outside the demo's 256×128 frames: one error line, the projector is not
    rebuilt per frame (it was: 27 log lines a second, forever), and /healthz says why."""
    with ServeProcess("--projection", "fisheye", "--center", "99999,0") as srv:
        probe = lambda: health(srv.http)["probes"]["default"]
        poll(lambda: probe()["frames_rejected"] >= 20, timeout=30, what="rejected frames")
        assert "outside the frame" in probe()["error"]
        out = srv.output
    assert out.count("building the fisheye projector") == 1, out
    errors = [l for l in out.splitlines() if "ERROR" in l]
    assert len(errors) == 1 and "centre (99999, 0)" in errors[0], out
    assert "frame rejected" not in out and "Traceback" not in out


def test_serve_warns_once_about_a_panorama_read_as_a_fisheye():
    with ServeProcess("--projection", "fisheye") as srv:
        poll(lambda: health(srv.http)["probes"]["default"]["frames"] >= 20, timeout=30,
             what="projected frames")
        out = srv.output
    warnings = [l for l in out.splitlines() if "shaped like an equirect panorama" in l]
    assert len(warnings) == 1, out
