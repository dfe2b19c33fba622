"""A new user's bad command lines (issue 41, item 5): each is one line on stderr and exit 2,
before any work and with nothing written; the legal values beside them still run.

Numbers beyond what a camera or a lux meter can read (``calibrate-response --f-number
1e308``, ``--lux 1e308``, ``compute --lux 1e39``, an exposure of 0.1 µs), empty values a
script's unset variable gives (``--lux-facing ''``, ``--mqtt ''``), an MQTT port 0, an
option with nothing to do (``export --to webxr --no-cube``), ``bench --repeat`` in the
billions, argparse's own errors that must name the command, ``%%`` in a help text, the AR
example's sizes, and validate-shaders' summary, which must judge each case at its own
tolerance."""
from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from provider.cli import COMMANDS
from provider.core.errors import InputError
from provider.core.radiometry import photometry
from servertools import ROOT, run_cli
from servertools import refused as _refused


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    rng = np.random.default_rng(0)
    assert cv2.imwrite(str(d / "pano.png"), rng.integers(0, 256, (32, 64, 3), dtype=np.uint8))
    return d


# -- what a camera and a lux meter can read ---------------------------------------------------

BRACKET = ["a.png@1", "b.png@2", "c.png@4"]     # never read: the options are refused first


@pytest.mark.parametrize("extra, words", [
    (["--lux", "188", "--f-number", "1e308"], ["--f-number", "128", "1e+308"]),  # a traceback
    (["--lux", "1e308", "--f-number", "2"], ["--lux", "200000 lux", "1e+308"]),  # 1e305 × C
    (["--lux", "188", "--f-number", "0.2"], ["--f-number", "0.5"]),
    (["--lux", "188", "--iso", "1e12"], ["--iso", "1e+07"]),
    (["--lux", "inf"], ["--lux"]),
    (["--lux", "-3"], ["--lux must be a positive number"]),
])
def test_calibrate_response_refuses_what_no_camera_or_meter_reads(tmp_path, extra, words):
    out = tmp_path / "camera.json"
    _refused(run_cli("calibrate-response", *BRACKET, *extra, "-o", str(out)), *words)
    assert not out.exists() and not (tmp_path / "camera.png").exists()


def test_the_bounds_hold_every_real_reading():
    """The bounds refuse slips, never a real scene: noon sun (1.2e5 lux), f/0.95 and f/64,
    ISO 25 and 409,600, 1/32,000 s and a 30-minute night exposure all pass."""
    for value, bounds in ((1.2e5, photometry.LUX_RANGE), (0.01, photometry.LUX_RANGE),
                          (0.95, photometry.F_NUMBER_RANGE), (64, photometry.F_NUMBER_RANGE),
                          (25, photometry.ISO_RANGE), (409600, photometry.ISO_RANGE),
                          (1 / 32000, photometry.EXPOSURE_S_RANGE),
                          (1800, photometry.EXPOSURE_S_RANGE)):
        assert photometry.check_physical("x", value, bounds) == value
    for value in (0.0, -1.0, 3e5, float("nan"), None):
        with pytest.raises(InputError, match="--lux"):
            photometry.check_physical("--lux", value, photometry.LUX_RANGE, " lux")


def test_a_lux_reading_beyond_daylight_is_refused_not_dropped(files):
    """``compute --lux 1e39`` closed 1e39 in its note and dropped the closed region (103.8
    lux, below the unmetered 136.5): refused before the frame is read."""
    _refused(run_cli("compute", str(files / "pano.png"), "--lux", "1e39"),
             "shlight compute: error: --lux", "200000 lux")
    _refused(run_cli("serve", "--port", "0", "--camera", str(files / "camera.json"),
                     "--lux", "1e39"), "shlight serve: error: --lux", "200000 lux")


def test_an_exposure_time_no_shutter_gives_is_refused(files):
    _refused(run_cli("compute", f"{files / 'pano.png'}@0.0000001"),
             "exposure time '0.0000001'", "1e-06")
    _refused(run_cli("compute", f"{files / 'pano.png'}@100000"), "exposure time '100000'")
    assert run_cli("compute", f"{files / 'pano.png'}@1/8000").returncode == 0


@pytest.mark.parametrize("command", ["compute", "serve"])
def test_an_empty_lux_facing_is_not_up(files, command):
    argv = (["compute", str(files / "pano.png")] if command == "compute"
            else ["serve", "--port", "0", "--camera", str(files / "camera.json")])
    _refused(run_cli(*argv, "--lux", "400", "--lux-facing", ""),
             f"shlight {command}: error: --lux-facing is empty", "up, sun or AZ,EL")


# -- export --no-cube -------------------------------------------------------------------------

@pytest.mark.parametrize("to", ["webxr", "threejs", "unity", "openxr-android"])
def test_no_cube_is_refused_where_the_format_has_no_cube(files, to):
    _refused(run_cli("export", str(files / "pano.png"), "--to", to, "--no-cube"),
             f"--no-cube has no effect with --to {to}", "gltf and arcore")


def test_no_cube_still_leaves_arcores_cube_out(files):
    import json
    res = run_cli("export", str(files / "pano.png"), "--to", "arcore", "--no-cube")
    assert res.returncode == 0, res.stderr
    with_cube = json.loads(run_cli("export", str(files / "pano.png"), "--to", "arcore").stdout)
    without = json.loads(res.stdout)
    assert len(json.dumps(without)) < len(json.dumps(with_cube))   # the 16² cube is left out


# -- MQTT URLs --------------------------------------------------------------------------------

@pytest.mark.parametrize("url, words", [
    ("mqtt://127.0.0.1:0/t", ["--mqtt mqtt://127.0.0.1:0/t", "port 0"]),   # was 1883
    ("", ["--mqtt is empty"]),                                               # was no MQTT
    ("  ", ["--mqtt is empty"]),
    ("mqtt://127.0.0.1:65536/t", ["--mqtt", "out of range"]),
])
def test_serve_refuses_an_mqtt_url_with_no_broker(url, words):
    _refused(run_cli("serve", "--port", "0", "--mqtt", url), "shlight serve: error:", *words)


def test_a_meter_on_port_0_is_refused_too(files):
    _refused(run_cli("serve", "--port", "0", "--camera", str(files / "camera.json"),
                     "--lux", "mqtt://127.0.0.1:0/lux"), "--lux", "port 0")


def test_mqtt_ports_given_and_left_out():
    from provider.live.wire.mqtt_link import parse_mqtt_url
    assert parse_mqtt_url("mqtt://h/t").port == 1883
    assert parse_mqtt_url("mqtts://h/t").port == 8883
    assert parse_mqtt_url("mqtt://h:1884/t").port == 1884
    assert parse_mqtt_url("mqtt://h:65535/t").port == 65535


# -- bench --repeat ---------------------------------------------------------------------------

def test_bench_repeat_is_bounded(tmp_path):
    out = tmp_path / "b"
    _refused(run_cli("bench", "--repeat", "1000000000", "--out", str(out)),
             "shlight bench: error: --repeat must be at least 1 and at most 1000")
    assert not out.exists()
    from provider.cli.bench import HDRI_DIR, MAX_REPEAT, check_arguments
    check_arguments(argparse.Namespace(repeat=MAX_REPEAT, sections="speed", out=str(out),
                                       hdri=str(HDRI_DIR)))          # the bound itself runs


# -- argparse's own errors name the command ---------------------------------------------------

@pytest.mark.parametrize("command", [name for name, _, _ in COMMANDS])
def test_an_unknown_option_names_the_command(command):
    """``shlight serve --bogus`` said ``shlight: error:`` (the top parser's words); every
    command's usage error names it, and says where its help is."""
    line = _refused(run_cli(command, "--no-such-option"))
    assert line.startswith(f"shlight {command}: error: "), line
    assert f"shlight {command} --help" in line


def test_an_unknown_option_after_the_positionals_names_the_command(files):
    line = _refused(run_cli("compute", str(files / "pano.png"), "--bogus"))
    assert line == ("shlight compute: error: unrecognized arguments: --bogus (see: shlight "
                    "compute --help)")


@pytest.mark.parametrize("command", [None] + [name for name, _, _ in COMMANDS])
def test_help_shows_no_doubled_percent(command):
    res = run_cli(*([command] if command else []), "--help")
    assert res.returncode == 0, res.stderr
    assert "%%" not in res.stdout, [l for l in res.stdout.splitlines() if "%%" in l]
    if command == "marker":
        assert "Print at 100 % (no 'fit to page')" in " ".join(res.stdout.split())


# -- the AR example ---------------------------------------------------------------------------

@pytest.mark.parametrize("extra, words", [
    (["--marker-length", "-1"], ["--marker-length", "above 0"]),
    (["--marker-length", "0"], ["--marker-length"]),
    (["--scale", "nan"], ["--scale", "nan"]),
    (["--scale", "inf"], ["--scale"]),
    (["--hfov", "180"], ["--hfov", "below 180"]),
    (["--lighting-timeout", "-5"], ["--lighting-timeout"]),
    (["--max-frames", "-1"], ["--max-frames"]),
])
def test_the_ar_example_refuses_sizes_that_draw_nothing(files, extra, words):
    out = files / "ar.png"
    res = subprocess.run([sys.executable, str(ROOT / "examples" / "ar_composite.py"),
                          "--input", str(files / "pano.png"), "--lighting",
                          str(ROOT / "provider" / "data" / "hdri" / "bridge.exr"),
                          "--output", str(out), *extra],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    line = _refused(res, *words)
    assert line.startswith("ar_composite: error: ")
    assert not out.exists()


# -- validate-shaders' summary ----------------------------------------------------------------

def _comparison(case, max_rel, tolerance):
    from provider.verify.harness import Comparison
    return Comparison(case=case, path="glsl", normals=10, max_rel=max_rel, rms_rel=max_rel / 2,
                      clamp_max_rel=max_rel, negative_outputs=0, ringing_normals=0,
                      independent_max_rel=None, independent_tolerance=None,
                      tolerance=tolerance, passed=max_rel <= tolerance)


def test_the_summary_judges_each_case_at_its_own_tolerance():
    """A passing run printed the shadow cases' worst (1.45e-04, within their 2.44e-04)
    beside the SH9 tolerance 1.91e-06: a pass that read as a failure."""
    from provider.verify.harness import FLOAT32_TOLERANCE, summary_lines
    from provider.verify.lights import OCCLUDED_TOLERANCE
    lines = summary_lines([_comparison("furnace", 1e-7, FLOAT32_TOLERANCE),
                           _comparison("random", 2e-7, FLOAT32_TOLERANCE),
                           _comparison("shadow:one:half", 1.45e-4, OCCLUDED_TOLERANCE)],
                          ["glsl", "hlsl"])
    assert lines == [
        f"glsl: 2 comparisons at tolerance {FLOAT32_TOLERANCE:.2e}, worst max relative error "
        "2.00e-07 (random), worst relative RMS 1.00e-07",
        f"glsl: 1 comparisons at tolerance {OCCLUDED_TOLERANCE:.2e}, worst max relative error "
        "1.45e-04 (shadow:one:half), worst relative RMS 7.25e-05"]


def test_a_passing_validation_prints_no_error_above_its_tolerance(ctx, tmp_path):
    res = subprocess.run([sys.executable, "-m", "provider.cli", "validate-shaders",
                          str(ROOT / "provider" / "data" / "hdri" / "sky.exr"), "--no-hlsl",
                          "--no-pictures", "--normals", "1024", "--out", str(tmp_path)],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stdout + res.stderr
    found = re.findall(r"^glsl: \d+ comparisons at tolerance (\S+), worst max relative error "
                       r"(\S+) ", res.stdout, re.M)
    assert len(found) >= 2, res.stdout        # the SH9 cases' and the shadow cases' own
    for tolerance, worst in found:
        assert float(worst) <= float(tolerance), (worst, tolerance)
    for line in res.stdout.splitlines():      # every case line beside its own tolerance
        m = re.match(r"PASS  glsl  \S+ +max (\S+) \(tolerance (\S+)\)", line)
        if m:
            assert float(m[1]) <= float(m[2]), line


# -- the docs write the command one way -------------------------------------------------------

def test_the_docs_write_the_command_one_way():
    """docs/index.md says once that ``shlight`` is the installed ``.venv/bin/shlight``; no
    page then mixes the two spellings."""
    docs = ROOT / "docs"
    mixed = [p.name for p in docs.glob("*.md") if ".venv/bin/shlight" in p.read_text()
             and p.name != "index.md"]
    assert mixed == []
    index = (docs / "index.md").read_text()
    assert index.count(".venv/bin/shlight") == 1 and "`shlight`" in index
