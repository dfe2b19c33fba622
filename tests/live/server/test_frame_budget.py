"""Big frames must not take ``shlight serve`` down (issue 29): the pixel budget
``--max-frame-pixels`` checked on the header before decoding, one log line, counted and
remembered; a valid .hdr read without OpenCV's temporary files; a file source that picks its
picture up again after a read that failed for a reason other than its content; libpng's
words replaced by ours; a camera's error page made fit for one log line.

The 20000×10000 frames are real, decodable files made without holding their pixels: a
baseline JPEG whose every block is mid-grey (6 bits a block) and a one-value PNG whose
deflate stream repeats one flushed piece. Real servers, real sockets; waits are on
conditions, never on durations.
"""
from __future__ import annotations

import json
import logging
import os
from pathlib import Path
import re
import resource
import struct
import threading
import zlib
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

import cv2
import numpy as np
import pytest

from provider.core.errors import InputError
from provider.core.radiometry.image_size import (DEFAULT_MAX_PIXELS, FrameTooLarge,
                                                 header_size)
from provider.core.radiometry.images import TransientReadError, read_image
from provider.live.sources import SourceError, SourceOptions
from provider.live.sources.base import Frame, printable
from servertools import (MjpegCamera, ServeProcess, ServerThread, health, http_get,
                         jpeg_panorama, metric, poll, run_cli)

BRIDGE = os.path.join(str(Path(__file__).resolve().parents[2]), "data", "hdri", "bridge.exr")
BIG = (20000, 10000)
GIB = 1 << 30


# ---- huge, valid images made cheaply ---------------------------------------------------------

def _segment(marker: int, payload: bytes) -> bytes:
    return bytes([0xFF, marker]) + struct.pack(">H", len(payload) + 2) + payload


_DC_BITS = bytes([0, 1, 5, 1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0])     # JPEG Annex K.3
_AC_BITS = bytes([0, 2, 1, 3, 3, 2, 4, 3, 5, 5, 4, 4, 0, 0, 1, 0x7D])
_AC_VALUES = bytes.fromhex(
    "01020300041105122131410613516107227114328191a1082342b1c11552d1f02433627282090a161718191a"
    "25262728292a3435363738393a434445464748494a535455565758595a636465666768696a737475767778797a"
    "838485868788898a92939495969798999aa2a3a4a5a6a7a8a9aab2b3b4b5b6b7b8b9bac2c3c4c5c6c7c8c9ca"
    "d2d3d4d5d6d7d8d9dae1e2e3e4e5e6e7e8e9eaf1f2f3f4f5f6f7f8f9fa")


def grey_jpeg(width: int, height: int) -> bytes:
    """A baseline greyscale JPEG (standard Huffman tables) of mid-grey: every 8×8 block is
    DC difference 0 ("00") and end-of-block ("1010"), so 4 blocks are 3 bytes."""
    assert width % 8 == 0 and height % 8 == 0
    blocks = (width // 8) * (height // 8)
    data = b"\x28\xa2\x8a" * (blocks // 4)
    if blocks % 4:
        bits = "001010" * (blocks % 4)
        bits += "1" * (-len(bits) % 8)
        data += int(bits, 2).to_bytes(len(bits) // 8, "big")
    return (b"\xff\xd8" + _segment(0xDB, b"\x00" + b"\x01" * 64)
            + _segment(0xC0, struct.pack(">BHHB", 8, height, width, 1) + b"\x01\x11\x00")
            + _segment(0xC4, b"\x00" + _DC_BITS + bytes(range(12)))
            + _segment(0xC4, b"\x10" + _AC_BITS + _AC_VALUES)
            + _segment(0xDA, b"\x01\x01\x00\x00\x3f\x00") + data + b"\xff\xd9")


def _chunk(kind: bytes, payload: bytes) -> bytes:
    return (struct.pack(">I", len(payload)) + kind + payload
            + struct.pack(">I", zlib.crc32(kind + payload)))


def grey_png(width: int, height: int, value: int = 0) -> bytes:
    """An 8-bit greyscale PNG of one value: a few rows deflated and flushed once, the piece
    repeated (each decodes alone), the Adler-32 of all rows."""
    row = b"\x00" + bytes([value]) * width
    rows = max(d for d in range(1, 101) if height % d == 0)
    deflate = zlib.compressobj(9, zlib.DEFLATED, -15)
    piece = deflate.compress(row * rows) + deflate.flush(zlib.Z_FULL_FLUSH)
    adler = 1
    for _ in range(height):
        adler = zlib.adler32(row, adler)
    stream = (b"\x78\xda" + piece * (height // rows) + deflate.flush(zlib.Z_FINISH)
              + struct.pack(">I", adler))
    return (b"\x89PNG\r\n\x1a\n"
            + _chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + _chunk(b"IDAT", stream) + _chunk(b"IEND", b""))


def _write_png(path, value, size=(64, 32)):
    img = np.zeros((size[1], size[0], 3), np.uint8)
    img[:] = value
    img[: size[1] // 4] = 255
    assert cv2.imwrite(str(path), img)


def peak_rss(pid: int) -> int:
    """The process's peak resident set (VmHWM), bytes."""
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) * 1024
    raise AssertionError("no VmHWM")


needs_proc = pytest.mark.skipif(not os.path.exists("/proc/self/status"),
                                reason="reads the server's peak memory from /proc")


# ---- headers ---------------------------------------------------------------------------------

def test_the_crafted_images_are_real_and_their_headers_say_their_size():
    for data in (grey_jpeg(64, 32), grey_png(64, 32, 77)):
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
        assert img.shape == (32, 64) and img.min() == img.max()
    assert header_size(grey_jpeg(*BIG)) == BIG
    assert header_size(grey_png(*BIG)) == BIG
    assert len(grey_jpeg(*BIG)) < 3 << 20 and len(grey_png(*BIG)) < 1 << 20


@pytest.mark.parametrize("ext,params", [
    (".png", []), (".jpg", []), (".jpg", [cv2.IMWRITE_JPEG_PROGRESSIVE, 1]), (".tif", []),
    (".bmp", []), (".webp", []), (".webp", [cv2.IMWRITE_WEBP_QUALITY, 101]), (".ppm", []),
    (".pgm", []), (".pfm", []), (".hdr", [])])
def test_header_size_matches_what_opencv_decodes(ext, params):
    img = (np.random.default_rng(1).random((37, 91, 3)) * 255).astype(np.uint8)
    if ext in (".pfm", ".hdr"):
        img = img.astype(np.float32) / 255
    if ext == ".pgm":
        img = img[..., 0]
    ok, data = cv2.imencode(ext, img, params)
    assert ok
    decoded = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    assert header_size(data.tobytes()) == (decoded.shape[1], decoded.shape[0]) == (91, 37)


def test_header_size_reads_openexr_and_says_none_for_what_it_cannot_read():
    with open(BRIDGE, "rb") as f:
        assert header_size(f.read()) == (512, 256)
    assert header_size(b"\xff\xd8\xff\xe0\x00\x10JFIF") is None      # no frame header yet
    assert header_size(os.urandom(64).replace(b"\xff", b"\0")) is None
    assert header_size(b"") is None


# ---- the budget where images are read --------------------------------------------------------

def test_read_image_refuses_past_the_budget_from_the_header(tmp_path):
    path = tmp_path / "big.png"
    path.write_bytes(grey_png(*BIG))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
    with pytest.raises(FrameTooLarge) as err:
        read_image(path, DEFAULT_MAX_PIXELS)
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - before
    assert (err.value.width, err.value.height) == BIG and not err.value.decoded
    assert str(err.value) == (f"{path}: image 20000×10000 (200 Mpx) is too large to "
                              "decode: over --max-frame-pixels 33.6 Mpx")
    assert grown < 100 << 20                       # decoded, it would be 600 MB and more
    small = tmp_path / "small.png"
    _write_png(small, (10, 20, 30))
    assert read_image(small, 64 * 32).shape == (32, 64, 3)   # at the budget: read
    with pytest.raises(FrameTooLarge):
        read_image(small, 64 * 32 - 1)


def test_compute_refuses_an_image_over_its_budget_in_one_line(tmp_path):
    path = tmp_path / "big.jpg"
    path.write_bytes(grey_jpeg(*BIG))
    r = run_cli("compute", str(path), "--max-frame-pixels", "8192x4096")
    assert r.returncode == 2 and r.stdout == ""
    assert r.stderr.splitlines() == [
        f"shlight compute: error: {path}: image 20000×10000 (200 Mpx) is too large to "
        "decode: over --max-frame-pixels 33.6 Mpx"]


def test_frames_are_refused_from_the_header_or_once_decoded():
    with pytest.raises(FrameTooLarge) as err:
        Frame(None, 0.0, jpeg=grey_jpeg(*BIG)).decoded(DEFAULT_MAX_PIXELS)
    assert not err.value.decoded and "20000×10000" in str(err.value)
    small = jpeg_panorama(64)
    assert Frame(None, 0.0, jpeg=small).decoded(64 * 32).shape == (32, 64, 3)
    with pytest.raises(FrameTooLarge):
        Frame(None, 0.0, jpeg=small).decoded(1000)
    # decoded by its source (a camera): refused before the projection
    with pytest.raises(FrameTooLarge) as err:
        Frame(np.zeros((40, 80, 3), np.uint8), 0.0).decoded(1000)
    assert err.value.decoded and "too large to use" in str(err.value)


def test_the_serve_option_takes_pixels_or_a_size():
    from provider.cli import build_parser
    parse = build_parser().parse_args
    assert parse(["serve"]).max_frame_pixels == 8192 * 4096
    assert parse(["serve", "--max-frame-pixels", "0"]).max_frame_pixels == 0
    assert parse(["serve", "--max-frame-pixels", "4096x2048"]).max_frame_pixels == 4096 * 2048
    r = run_cli("serve", "--max-frame-pixels", "lots")
    assert r.returncode == 2 and "WIDTHxHEIGHT" in r.stderr


# ---- shlight serve: files and an HTTP camera sending 20000×10000 frames --------------------

def _lines(output: str, text: str) -> list[str]:
    return [line for line in output.splitlines() if text in line]


@needs_proc
def test_a_huge_file_in_a_sequence_is_refused_once_without_decoding(tmp_path):
    _write_png(tmp_path / "a.png", (60, 60, 60))
    (tmp_path / "b.png").write_bytes(grey_png(*BIG))
    with ServeProcess("--source", str(tmp_path), "--fps", "20") as proc:
        poll(lambda: health(proc.http)["probes"]["default"]["frames"] >= 8, timeout=30,
             what="several loops over the files")
        h = health(proc.http)["probes"]["default"]
        assert h["frames_too_large"] == 1 and h["frames_rejected"] == 1   # remembered
        assert h["max_frame_pixels"] == DEFAULT_MAX_PIXELS
        assert "20000×10000" in h["bad_files"][str(tmp_path / "b.png")]
        assert metric(proc.http, "shlight_probe_frames_too_large_total", probe="default") == 1
        said = _lines(proc.output, "20000×10000")
        assert len(said) == 1, proc.output
        assert re.search(r"WARNING +probe default: frame 20000×10000 \(200 Mpx\) is over "
                         r"--max-frame-pixels 33\.6 Mpx: not decoded \(.*b\.png\)", said[0])
        assert peak_rss(proc.proc.pid) < GIB


@needs_proc
def test_an_http_camera_sending_huge_frames_is_refused_without_decoding():
    small, big = jpeg_panorama(64), grey_jpeg(*BIG)
    with MjpegCamera(small, fps=20) as cam:
        with ServeProcess("--source", cam.url) as proc:
            def probe():
                return health(proc.http)["probes"]["default"]
            poll(lambda: probe()["frames"] >= 1, timeout=30, what="lighting")
            cam.frame = big                  # nothing but 20000×10000 frames for a while
            poll(lambda: probe()["frames_too_large"] >= 5, timeout=30, what="refusals")
            cam.frame = small
            frames = probe()["frames"]
            poll(lambda: probe()["frames"] > frames + 3, timeout=30, what="normal frames")
            h = probe()
            assert h["state"] == "live" and h["frames_rejected"] == h["frames_too_large"]
            assert metric(proc.http, "shlight_probe_frames_too_large_total",
                          probe="default") == h["frames_too_large"]
            said = _lines(proc.output, "20000×10000")
            assert len(said) == 1, proc.output       # a run of them: one line
            assert said[0].rstrip().endswith("is over --max-frame-pixels 33.6 Mpx: not decoded")
            assert peak_rss(proc.proc.pid) < GIB


def test_a_huge_replacement_of_an_image_keeps_the_last_one_and_says_so_once(tmp_path, caplog):
    caplog.set_level(logging.INFO)
    path = tmp_path / "room.png"
    _write_png(path, (90, 90, 90))
    with ServerThread("--source", str(path), "--fps", "30") as srv:
        probe = srv.server.probes["default"]
        poll(lambda: srv.call(lambda: probe.frames_processed) >= 2, what="frames")
        (tmp_path / "new.png").write_bytes(grey_png(*BIG))
        os.replace(tmp_path / "new.png", path)
        poll(lambda: health(srv.http)["probes"]["default"]["frames_too_large"], what="refused")
        frames = srv.call(lambda: probe.frames_processed)
        poll(lambda: srv.call(lambda: probe.frames_processed) >= frames + 20, what="frames")
        h = health(srv.http)["probes"]["default"]
        assert h["frames_too_large"] == 1 and h["state"] == "live"
        assert "20000×10000" in h["bad_files"][str(path)]
        said = [r.getMessage() for r in caplog.records if "20000×10000" in r.getMessage()]
        assert said == [f"probe default: frame 20000×10000 (200 Mpx) is over "
                        f"--max-frame-pixels 33.6 Mpx: not decoded ({path}; the previous "
                        "image goes on)"]


def test_a_refusal_the_source_reports_once_is_not_replaced_by_the_next_good_frame():
    from provider.live.probe.capture import Capture, _Attempt
    from provider.live.sources import parse_source
    capture = Capture(parse_source("demo"))
    attempt = _Attempt(1)
    refused = Frame(None, 1.0, info={"path": "b.png", "rejected": "too big",
                                     "too_large": BIG})
    for frame in (Frame(np.zeros((2, 4, 3)), 0.0), refused, Frame(np.ones((2, 4, 3)), 2.0),
                  Frame(np.ones((2, 4, 3)), 3.0)):
        capture._deliver(attempt, frame)
    assert [f.time for f in iter(capture.take, None)] == [1.0, 3.0]   # newest good, kept


# ---- .hdr without temporary files; a failed read is not the file's version ------------------

def _hdr(path, value: float) -> None:
    img = np.full((32, 64, 3), value, np.float32)
    img[:8] = 4 * value
    assert cv2.imwrite(str(path), img)


def test_a_valid_hdr_is_read_when_opencv_cannot_write_its_temporary_files(tmp_path):
    path = tmp_path / "room.hdr"
    _hdr(path, 0.2)
    env = {"OPENCV_TEMP_PATH": str(tmp_path / "no" / "such" / "dir")}   # as with /tmp full
    with ServeProcess("--source", str(path), "--fps", "20", env=env) as proc:
        def dc():
            status, _, body = http_get(proc.http + "/latest.json")
            return json.loads(body)["coefficients"][0] if status == 200 else None
        first = poll(dc, what="lighting from the .hdr")
        _hdr(tmp_path / "new.hdr", 0.8)
        os.replace(tmp_path / "new.hdr", path)
        poll(lambda: dc() > 2 * first, what="the new .hdr's lighting")
        assert not health(proc.http)["probes"]["default"]["bad_files"]


def test_an_image_source_reads_the_file_again_after_a_failure_not_of_its_content(
        tmp_path, monkeypatch):
    from provider.live.sources import files
    path = tmp_path / "room.png"
    _write_png(path, (90, 90, 90))
    source = files.ImageSource(str(path), fps=50)
    source.open()
    first = source.read().image
    _write_png(tmp_path / "new.png", (10, 200, 10))
    os.replace(tmp_path / "new.png", path)
    real, failures = files.read_image, []

    def failing_once(p, max_pixels=0, said=None):
        if not failures:
            failures.append(p)
            raise TransientReadError(f"cannot read {p}: No space left on device")
        return real(p, max_pixels, said)
    monkeypatch.setattr(files, "read_image", failing_once)
    frame = source.read()
    assert frame.image is first and "No space left" in frame.info["bad_file"]
    # the same version of the file, read again (after a short wait), not remembered as bad
    frame = poll(lambda: (lambda f: f if "bad_file" not in f.info else None)(source.read()),
                 what="the file read again")
    assert frame.image[0, 0].tolist() == [255, 255, 255] and frame.image[-1, 0, 1] == 200


def test_a_corrupt_file_is_still_remembered(tmp_path, monkeypatch):
    from provider.live.sources import files
    path = tmp_path / "room.png"
    _write_png(path, (90, 90, 90))
    source = files.ImageSource(str(path), fps=200)
    source.open()
    path.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\x0dIHDR" + bytes(8))   # cut short
    calls = []
    real = files.read_image
    monkeypatch.setattr(files, "read_image", lambda *a: calls.append(a) or real(*a))
    for _ in range(5):
        assert "truncated" in source.read().info["bad_file"]
    assert len(calls) == 1


# ---- codec words: ours, in one line --------------------------------------------------------------

def test_a_png_with_a_bad_crc_is_refused_in_our_words_not_libpngs(tmp_path):
    img = (np.random.default_rng(0).random((32, 64, 3)) * 255).astype(np.uint8)
    ok, data = cv2.imencode(".png", img)
    data = bytearray(data.tobytes())
    data[data.find(b"IDAT") + 20] ^= 0xFF                   # a bit flipped on the way
    path = tmp_path / "flipped.png"
    path.write_bytes(bytes(data))
    r = run_cli("compute", str(path))
    assert r.returncode == 2
    assert r.stderr.splitlines() == [f"shlight compute: error: cannot read {path}: the PNG "
                                     "is corrupt (its 'IDAT' chunk fails its CRC check)"]


class _ErrorPage:
    """An HTTP server answering every GET with ``status`` and ``body`` (``ctype``)."""

    def __init__(self, status: int, body: bytes, ctype: str = "text/plain"):
        class Handler(BaseHTTPRequestHandler):
            def log_message(self, *args):
                pass

            def do_GET(self):
                self.send_response(status, "Service\x1b[31m Unavailable")
                self.send_header("Content-Type", ctype)
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)
        self.httpd = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.thread = threading.Thread(target=self.httpd.serve_forever, daemon=True)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.httpd.server_address[1]}/stream.mjpg"

    def __enter__(self):
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.httpd.shutdown()
        self.httpd.server_close()


@pytest.mark.parametrize("body,ctype,want", [
    (b"line one\r\nline two\n\x1b[2J\x07fake: INFO shlight ok\n" + b"A" * 10000,
     "text/plain", "line one line two [2J fake: INFO shlight ok AAAA"),
    ("<html><head><title>x</title><style>p{}</style></head><body><h1>Camera "
     "offline</h1>\n<p>try &amp; wait\u202e</p></body></html>".encode(),
     "text/html", "x Camera offline try & wait"),
])
def test_a_cameras_error_page_becomes_one_short_log_line(body, ctype, want):
    from provider.live.sources.http import MjpegHttpSource
    with _ErrorPage(503, body, ctype) as page:
        with pytest.raises(SourceError) as err:
            MjpegHttpSource(page.url, SourceOptions(timeout=5)).open()
    text = str(err.value)
    assert not re.search(r"[\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e]", text), text
    assert text.startswith(f"{page.url}: HTTP 503 Service [31m Unavailable: {want}")
    assert len(text) < len(page.url) + 300


def test_printable_keeps_words_and_cuts_long_text():
    assert printable("a\nb\tc\x00d  e") == "a b c d e"
    assert printable("x" * 500, 20) == "x" * 19 + "…"
    assert printable("\u202egnp.exe") == "gnp.exe"


def test_transient_read_errors_are_input_errors():
    assert issubclass(TransientReadError, InputError)
    assert issubclass(FrameTooLarge, InputError)
