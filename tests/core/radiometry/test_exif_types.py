"""A still's exposure from EXIF numbers of every numeric TIFF type (docs/photometry.md):
cameras write RATIONAL, but Pillow writes a float as DOUBLE and other tools FLOAT, SHORT or
LONG; a number no camera records is not used, and the command says why in one line. The
TIFF structures are built byte by byte (tests/exiftools.py)."""
from __future__ import annotations

import json
import struct
import subprocess
import sys

import pytest

from provider.core.radiometry.exif import (EXPOSURE_BIAS, EXPOSURE_TIME, F_NUMBER, ISO,
                                           exposure_from_tiff, read_still_exposure)

from exiftools import jpeg_with_exif, tiff

def shlight(*args):
    return subprocess.run([sys.executable, "-m", "provider.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=300)


@pytest.mark.parametrize("order", ["II", "MM"])
@pytest.mark.parametrize("kind", ["RATIONAL", "SRATIONAL", "FLOAT", "DOUBLE"])
def test_fractional_numbers_of_every_type(kind, order):
    bias = 0.7 if kind == "RATIONAL" else -0.7           # RATIONAL is unsigned
    e = exposure_from_tiff(tiff([(EXPOSURE_TIME, kind, 0.004), (F_NUMBER, kind, 5.6),
                                 (ISO, kind, 400), (EXPOSURE_BIAS, kind, bias)], order))
    assert e.exposure_s == pytest.approx(0.004, rel=1e-6)     # FLOAT holds 7 digits
    assert e.f_number == pytest.approx(5.6, rel=1e-6) and e.iso == pytest.approx(400)
    assert e.exposure_bias_ev == pytest.approx(bias, rel=1e-6)
    assert e.complete and e.refused == ()


@pytest.mark.parametrize("order", ["II", "MM"])
@pytest.mark.parametrize("kind", ["BYTE", "SHORT", "LONG", "SSHORT", "SLONG"])
def test_whole_numbers_of_every_type(kind, order):
    """Integer types hold whole seconds, f-numbers and ISOs (a long exposure, f/8, ISO
    200); in IFD0 itself, where some writers put the tags."""
    e = exposure_from_tiff(tiff([(EXPOSURE_TIME, kind, 2), (F_NUMBER, kind, 8),
                                 (ISO, kind, 200 if kind != "BYTE" else 100)], order,
                                exif_ifd=False))
    assert (e.exposure_s, e.f_number) == (2.0, 8.0)
    assert e.iso == (200 if kind != "BYTE" else 100)


@pytest.mark.parametrize("tag,kind,value,words", [
    (EXPOSURE_TIME, "SRATIONAL", -0.01, "ExposureTime -0.01 s"),
    (EXPOSURE_TIME, "DOUBLE", 1e9, "ExposureTime 1e+09 s"),
    (EXPOSURE_TIME, "FLOAT", float("inf"), "ExposureTime inf s"),
    (F_NUMBER, "DOUBLE", 0.1, "FNumber 0.1"),
    (F_NUMBER, "SSHORT", -4, "FNumber -4"),
    (ISO, "LONG", 0, "ISO 0"),
    (EXPOSURE_BIAS, "SRATIONAL", -40, "ExposureBiasValue -40 EV"),
])
def test_a_number_no_camera_records_is_not_used(tag, kind, value, words):
    good = {EXPOSURE_TIME: 0.01, F_NUMBER: 4.0, ISO: 100, EXPOSURE_BIAS: 0.0}
    entries = [(t, "RATIONAL" if t != ISO else "SHORT", v) for t, v in good.items() if t != tag]
    e = exposure_from_tiff(tiff(entries + [(tag, kind, value)]))
    name = {EXPOSURE_TIME: "exposure_s", F_NUMBER: "f_number", ISO: "iso",
            EXPOSURE_BIAS: "exposure_bias_ev"}[tag]
    assert getattr(e, name) is None
    assert len(e.refused) == 1 and e.refused[0].startswith(f"EXIF {words} is not one a camera")
    assert "not used" in e.refused[0]
    others = [n for n in ("exposure_s", "f_number", "iso") if n != name]
    assert all(getattr(e, n) is not None for n in others)     # the rest still read


def test_a_rational_zero_over_zero_is_unknown_not_refused():
    e = exposure_from_tiff(tiff([(EXPOSURE_TIME, "RATIONAL", 0.01), (F_NUMBER, "RATIONAL", 2)])
                           .replace(struct.pack("<II", 2, 1), b"\0" * 8))
    assert e.exposure_s == pytest.approx(0.01) and e.f_number is None and e.refused == ()


def test_compute_merges_a_bracket_whose_exif_is_double(tmp_path):
    """Floats as Pillow writes them (DOUBLE) give a bracket its times from EXIF alone;
    before, only RATIONAL was read and the bracket was refused for want of exposures."""
    paths = []
    for i, (t, level) in enumerate(((0.005, 60), (0.01, 110), (0.02, 170))):
        paths.append(tmp_path / f"f{i}.jpg")
        jpeg_with_exif(paths[-1], tiff([(EXPOSURE_TIME, "DOUBLE", t), (F_NUMBER, "FLOAT", 2.8),
                                         (ISO, "LONG", 200)]), level)
    assert read_still_exposure(paths[0]).exposure_s == pytest.approx(0.005)
    p = shlight("compute", *paths)
    assert p.returncode == 0, p.stderr
    msg = json.loads(p.stdout)
    assert msg["exposures_s"] == pytest.approx([0.005, 0.01, 0.02])
    assert msg["radiometry"] == "merged"


def test_compute_says_in_one_line_why_an_exif_time_is_not_used(tmp_path):
    bad, good = tmp_path / "bad.jpg", tmp_path / "good.jpg"
    jpeg_with_exif(bad, tiff([(EXPOSURE_TIME, "SRATIONAL", -0.004), (F_NUMBER, "RATIONAL", 4)]))
    jpeg_with_exif(good, tiff([(EXPOSURE_TIME, "RATIONAL", 0.004)]), 200)
    p = shlight("compute", bad, good)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    (line,) = p.stderr.splitlines()
    assert line.startswith("shlight compute: error: every frame needs its exposure time")
    assert line.endswith(f"missing for: {bad} (EXIF ExposureTime -0.004 s is not one a "
                         "camera records (1e-06 to 86400 s): not used)")
    # @SECONDS wins: the bad EXIF time is not needed, so not said
    p = shlight("compute", f"{bad}@1/250", good)
    assert p.returncode == 0, p.stderr
    assert "ExposureTime" not in p.stderr


def test_an_absurd_f_number_is_warned_and_the_frame_still_computes(tmp_path):
    path = tmp_path / "still.jpg"
    jpeg_with_exif(path, tiff([(EXPOSURE_TIME, "RATIONAL", 0.01), (F_NUMBER, "DOUBLE", 0.1),
                               (ISO, "SHORT", 100)]))
    p = shlight("compute", path)
    assert p.returncode == 0, p.stderr
    assert f"shlight compute: warning: {path}: EXIF FNumber 0.1 is not one a camera records " \
           "(0.5 to 128): not used" in p.stderr.splitlines()
    msg = json.loads(p.stdout)
    assert msg["exposure_s"] == pytest.approx(0.01) and "f_number" not in msg
