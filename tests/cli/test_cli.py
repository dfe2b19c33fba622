"""`shlight compute` prints the wire message; user errors are one line, never a traceback."""
import json
import subprocess
import sys

import numpy as np
import pytest
import cv2

from provider.live.wire.message import coefficient_message, validate, load_schema
from provider import compute_sh9
from conftest import HDRI_DIR


def shlight(*args, timeout=120):
    return subprocess.run([sys.executable, "-m", "provider.cli", *args], capture_output=True,
                          text=True, timeout=timeout)


def test_compute_prints_a_valid_wire_message_equal_to_the_library():
    path = HDRI_DIR / "bridge.exr"
    p = shlight("compute", str(path))
    assert p.returncode == 0, p.stderr
    msg = json.loads(p.stdout)
    validate(msg)
    assert msg["type"] == "sh9" and msg["frame"] == "rh-y-up" and msg["stale"] is False
    assert len(msg["coefficients"]) == 27 and len(msg["matrices"]) == 48
    r = compute_sh9(str(path))
    assert np.allclose(msg["coefficients"], r.coefficients.reshape(-1), rtol=1e-12)
    assert np.allclose(msg["matrices"], r.matrices.reshape(-1), rtol=1e-12)
    # coefficient order on the wire: L00.r, L00.g, L00.b, L1-1.r, ...
    assert msg["coefficients"][3] == pytest.approx(r.coefficients[1, 0])
    assert 0 < msg["error_estimate"] < 0.3


def test_compute_on_an_8bit_png_and_a_radiance_hdr(tmp_path):
    img = (np.random.default_rng(0).random((64, 128, 3)) * 255).astype(np.uint8)
    img[:4] = 255
    png = tmp_path / "pano.png"
    cv2.imwrite(str(png), img[..., ::-1])
    msg = json.loads(shlight("compute", str(png)).stdout)
    validate(msg)
    assert msg["clipped_fraction"] > 0
    hdr = tmp_path / "pano.hdr"
    cv2.imwrite(str(hdr), np.full((32, 64, 3), 2.0, np.float32))
    msg = json.loads(shlight("compute", str(hdr)).stdout)
    assert msg["coefficients"][0] == pytest.approx(2.0 * 0.282095 * 4 * np.pi, rel=1e-3)


def test_compute_options_reach_the_engine(tmp_path):
    path = str(HDRI_DIR / "lab.exr")
    plain = json.loads(shlight("compute", path).stdout)
    dering = json.loads(shlight("compute", path, "--dering", "auto", "--order", "auto").stdout)
    assert plain["ringing"] and min(plain["min_irradiance"]) < 0
    assert min(dering["min_irradiance"]) >= 0 and dering["window_cutoff"] > 0
    rot = json.loads(shlight("compute", path, "--rotate", "90,0,0").stdout)
    assert rot["coefficients"] != plain["coefficients"]


@pytest.mark.parametrize("args,needle", [
    (["compute", "/nonexistent/pano.exr"], "no such file"),
    (["compute", "{tmp}/garbage.png"], "cannot read"),
    (["compute", "{tmp}/wide.png"], "2:1"),
    (["compute", "{tmp}/wide.png", "--projection", "cubemap"], "6:1"),
    (["compute", "{tmp}/ok.png", "--exposure", "-1"], "exposure"),
    (["compute", "{tmp}/ok.png", "--rotate", "1,2"], "--rotate"),
    (["compute", "{tmp}/ok.png", "--projection", "fisheye", "--calibration", "{tmp}/nope.json"],
     "calibration"),
])
def test_user_errors_are_one_clear_line(tmp_path, args, needle):
    (tmp_path / "garbage.png").write_bytes(b"not a png at all")
    cv2.imwrite(str(tmp_path / "wide.png"), np.zeros((10, 50, 3), np.uint8))
    cv2.imwrite(str(tmp_path / "ok.png"), np.zeros((10, 20, 3), np.uint8))
    p = shlight(*[a.format(tmp=tmp_path) for a in args])
    assert p.returncode == 2
    assert needle in p.stderr
    assert "Traceback" not in p.stderr and p.stdout == ""


def test_schema_rejects_what_jsonutility_cannot_parse():
    import jsonschema
    msg = coefficient_message(compute_sh9(np.ones((16, 32, 3), np.float32)))
    validate(msg)
    for bad in ({"coefficients": msg["coefficients"][:26]}, {"matrices": [[0.0] * 16] * 3},
                {"stale": None}, {"frame": "lh-y-up"}, {"nested": {"a": 1}}):
        with pytest.raises(jsonschema.ValidationError):
            validate({**msg, **bad})
    assert load_schema()["$defs"]["sh9"]["properties"]["version"]["const"] == 1


def test_message_refuses_non_finite_numbers():
    from provider.live.wire.message import dumps
    r = compute_sh9(np.ones((16, 32, 3), np.float32))
    r.coefficients[0, 0] = np.nan
    with pytest.raises(ValueError):
        coefficient_message(r)
    with pytest.raises(ValueError):
        dumps({"x": float("inf")})


@pytest.mark.bench
def test_bench_quick_writes_a_table_and_a_plot(tmp_path):
    p = shlight("bench", "--quick", "--out", str(tmp_path), "--sections", "speed,edge",
                timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    table = (tmp_path / "speed_vs_error.md").read_text()
    assert "paper (sRGB 64×48)" in table and "× floor" in table and "1920×960" in table
    assert (tmp_path / "speed_vs_error.png").stat().st_size > 10_000
    edge = (tmp_path / "fisheye_edge.md").read_text()
    # --quick is quick: callgrind (most of a run's time) only with --instructions
    assert "640×480" in edge and "M |" not in edge
    assert "not counted" in edge or "valgrind not installed" in edge
    # what it costs is said first, then each section's start and end
    plan = p.stderr.splitlines()[0]
    assert plan.startswith("shlight bench: speed (~") and "edge (~" in plan, plan
    assert "[1/2] speed" in p.stderr and "[2/2] edge done in" in p.stderr


@pytest.mark.bench
def test_bench_scenes_reports_ringing_and_the_cost_of_deringing(tmp_path):
    hdri = tmp_path / "hdri"
    hdri.mkdir()
    for name in ("lab", "city"):
        (hdri / f"{name}.exr").write_bytes((HDRI_DIR / f"{name}.exr").read_bytes())
    p = shlight("bench", "--out", str(tmp_path), "--sections", "scenes", "--hdri", str(hdri),
                timeout=600)
    assert p.returncode == 0, p.stderr[-2000:]
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[2:-1]]
            for line in (tmp_path / "scenes.md").read_text().splitlines()
            if line.startswith("| lab") or line.startswith("| city")}
    # lab rings (negative minimum) and gets a window; city does not ring and is left alone
    assert rows["lab"][2].startswith("-") and rows["lab"][3] != "–"
    assert rows["city"][2].startswith("+") and rows["city"][3] == "–"
    assert 0 < float(rows["lab"][4].rstrip(" %")) < 5
