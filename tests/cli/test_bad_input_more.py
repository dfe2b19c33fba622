"""More bad input, each one clear line on stderr, exit 2, nothing on stdout and nothing
written half-way (issue 23): images whose header declares an enormous size (OpenCV raises
cv2.error), truncated JPEG/PNG/EXR files, frames with no usable light (all NaN, all
negative: refused and counted, /healthz degraded, not served as darkness), a fisheye circle
so large the frame sees nothing, options that depend on other options, and the options of
validate-shaders and bench checked before any work starts."""
from __future__ import annotations

import os
import struct
import zlib

import cv2
import numpy as np
import pytest

from servertools import ServeProcess, health, poll, refused, run_cli


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad")
    rng = np.random.default_rng(0)
    img = rng.integers(0, 256, (64, 128, 3), dtype=np.uint8)
    assert cv2.imwrite(str(d / "ok.png"), img) and cv2.imwrite(str(d / "ok.jpg"), img)
    png = (d / "ok.png").read_bytes()
    ihdr = bytearray(png[16:29])
    ihdr[0:8] = struct.pack(">II", 100_000, 100_000)               # 10^10 pixels declared
    crc = struct.pack(">I", zlib.crc32(b"IHDR" + bytes(ihdr)) & 0xFFFFFFFF)
    (d / "huge.png").write_bytes(png[:16] + bytes(ihdr) + crc + png[33:])
    jpg = (d / "ok.jpg").read_bytes()
    k = jpg.find(b"\xff\xc0")
    big = bytearray(jpg)
    big[k + 5:k + 9] = struct.pack(">HH", 65000, 65000)
    (d / "huge.jpg").write_bytes(bytes(big))
    (d / "cut.jpg").write_bytes(jpg[:len(jpg) // 2])
    (d / "cut.png").write_bytes(png[:len(png) // 2])
    import OpenEXR
    hdr = rng.random((64, 128, 3)).astype(np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": hdr}) as f:
        f.write(str(d / "ok.exr"))
    exr = (d / "ok.exr").read_bytes()
    (d / "cut.exr").write_bytes(exr[:len(exr) * 2 // 3])
    for name, fill in (("nan.exr", np.nan), ("negative.exr", -1.0)):
        with OpenEXR.File(header, {"RGB": np.full((64, 128, 3), fill, np.float32)}) as f:
            f.write(str(d / name))
    (d / "file").write_text("not a folder")
    return d


@pytest.mark.parametrize("name", ["huge.png", "huge.jpg"])
@pytest.mark.parametrize("command", ["compute", "export", "serve", "validate-shaders",
                                     "calibrate-response"])
def test_an_enormous_header_is_one_line_for_every_command(files, name, command):
    path = str(files / name)
    argv = {"compute": ["compute", path], "export": ["export", path, "--to", "unity"],
            "serve": ["serve", "--port", "0", "--source", path],
            "validate-shaders": ["validate-shaders", "--out", str(files / "v"), path],
            "calibrate-response": ["calibrate-response", f"{path}@1", f"{files / 'ok.png'}@2",
                                   f"{files / 'ok.png'}@4", "-o", str(files / "cam.json")]}
    refused(run_cli(*argv[command]), "too large to decode")
    assert not (files / "cam.json").exists() and not (files / "v").exists()


@pytest.mark.parametrize("name, words", [
    ("cut.jpg", ["JPEG is truncated"]), ("cut.png", ["PNG is truncated"]),
    ("cut.exr", ["OpenEXR file is truncated"])])
def test_a_truncated_file_is_refused_in_shlights_own_words(files, name, words):
    """Not decoded half-way (OpenCV fills the rest with grey) and no libjpeg/libpng/OpenEXR
    words on stdout or stderr."""
    line = refused(run_cli("compute", str(files / name)), *words)
    assert line.startswith("shlight compute: error:")


def test_a_frame_with_no_usable_light_isrefused(files):
    for name in ("nan.exr", "negative.exr"):
        refused(run_cli("compute", str(files / name)), "no usable light")


def test_the_live_server_rejects_and_counts_frames_with_no_usable_light(files):
    with ServeProcess("--source", str(files / "nan.exr"), "--fps", "20") as srv:
        probe = poll(lambda: (lambda p: p if p["frames_rejected"] >= 2 else None)(
            health(srv.http)["probes"]["default"]), timeout=30, what="rejected frames")
        doc = health(srv.http)
        assert doc["status"] == "degraded" and probe["frames"] == 0
        assert "no usable light" in probe["error"]
        assert srv.proc.poll() is None                      # the server never dies


@pytest.mark.parametrize("argv, words", [
    (["compute", "{ok}", "--projection", "fisheye", "--radius", "1e6"], ["too large", "--radius"]),
    (["compute", "{ok}", "--max-lights", "2"], ["--max-lights", "--lights auto"]),
    (["compute", "{ok}", "--max-lights", "2", "--lights", "off"], ["--max-lights", "--lights auto"]),
    (["compute", "{ok}", "--max-lights", "9"], ["--max-lights 9", "out of range"]),
    (["serve", "--port", "0", "--source", "ws://"], ["ws:// source needs a host"]),
    (["serve", "--port", "0", "--source", "ws://:8765/", "--lights", "auto"],
     ["ws:// source needs a host"]),
    (["serve", "--port", "0", "--source", "wss://host:port/"], ["wss:// source"]),
    (["serve", "--port", "0", "--bracket", "a,b"], ["'a' is not one"]),
    (["validate-shaders", "--out", "{file}"], ["--out", "is a file"]),
    (["validate-shaders", "--write-vectors", "{missing}/v.json"], ["--write-vectors", "no folder"]),
    (["validate-shaders", "--vectors", "{ok}"], ["not a contract vectors file"]),
    (["validate-shaders", "--normals", "0"], ["--normals"]),
    (["validate-shaders", "--normals", "100000000000"], ["--normals"]),
    (["validate-shaders", "--tolerance", "nan"], ["--tolerance", "finite"]),
    (["validate-shaders", "--tolerance", "0"], ["--tolerance", "above 0"]),
    (["validate-shaders", "--tolerance", "-1"], ["--tolerance"]),
    (["validate-shaders", "--tolerance", "inf"], ["--tolerance", "finite"]),
    (["bench", "--out", "{file}"], ["--out", "is a file"]),
    (["bench", "--repeat", "0"], ["--repeat", "at least 1"]),
    (["bench", "--repeat", "-5"], ["--repeat"]),
    (["bench", "--sections", ""], ["--sections names no section"]),
    (["bench", "--sections", ",,"], ["--sections names no section"]),
    (["compute", "{ok}", "--camera", "{ok}"], ["camera file", "not a text file"]),
    (["compute", "{ok}", "--projection", "fisheye", "--calibration", "{ok}"],
     ["calibration", "not a JSON text file"]),
    (["calibrate-response", "{ok}@1", "{ok}@1", "{ok}@1", "-o", "{missing}.json"],
     ["at least 1 EV apart"]),
])
def test_options_are_checked_before_any_work(files, argv, words):
    names = {"ok": str(files / "ok.png"), "file": str(files / "file"),
             "missing": str(files / "missing")}
    before = sorted(os.listdir(files))
    refused(run_cli(*[a.format(**names) for a in argv]), *words)
    assert sorted(os.listdir(files)) == before                 # nothing written


def test_a_live_jpeg_frame_cut_short_is_refused_not_decoded_half_way():
    """A camera stream's frame (MJPEG, OSC preview) that ends early: refused, counted by the
    probe like any bad frame, never projected with a grey lower half."""
    from provider import InputError
    from provider.live.sources.base import Frame
    rng = np.random.default_rng(4)
    ok, buf = cv2.imencode(".jpg", rng.integers(0, 256, (240, 320, 3), dtype=np.uint8))
    data = buf.tobytes()
    assert Frame(None, 0.0, jpeg=data).decoded().shape == (240, 320, 3)
    for cut in (len(data) // 8, len(data) // 2, len(data) - 40):
        with pytest.raises(InputError, match="truncated"):
            Frame(None, 0.0, jpeg=data[:cut]).decoded()
