"""The size an image file declares in its header, read before decoding it, and the pixel
budget that refuses frames too large to decode (``shlight serve --max-frame-pixels``).

A 20000×10000 frame is a 3 MB JPEG or PNG but 600 MB once decoded and about 3 GB while
projected: the budget is checked on the header, so a refused frame costs the bytes of its
file and nothing more. :func:`header_size` reads JPEG (the SOF marker), PNG (IHDR),
OpenEXR (every part's ``dataWindow``), Radiance .hdr (the resolution line), TIFF (the first
directory), BMP, WebP and PNM/PFM headers; for anything else it answers None and the
caller checks the decoded array instead.
"""
from __future__ import annotations

import re
import struct

from ..errors import InputError

#: The default budget of ``shlight serve``: 8192×4096 (an 8K equirect), 33,554,432 pixels.
DEFAULT_MAX_PIXELS = 8192 * 4096
#: Bytes read from the start of a file to find its size; a header that does not end within
#: them (a TIFF whose directory is at the end) is looked for in the whole file.
HEADER_BYTES = 1 << 16

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
EXR_MAGIC = b"\x76\x2f\x31\x01"


def megapixels(pixels: int) -> str:
    """``pixels`` for people: ``"10000 Mpx"``, ``"200 Mpx"``, ``"33.6 Mpx"``."""
    mpx = pixels / 1e6
    return f"{mpx:.0f} Mpx" if mpx >= 100 else f"{mpx:.3g} Mpx"


class FrameTooLarge(InputError):
    """An image with more pixels than the budget.

    Attributes
    ----------
    width, height : int
        The image's size, pixels.
    budget : int
        The pixel budget it is over, pixels.
    decoded : bool
        Whether it was decoded before its size was known (a format whose size only its
        decoder reads, or a frame its source decoded); else it was refused from its header.
    """

    def __init__(self, width: int, height: int, budget: int, what: str = "frame",
                 decoded: bool = False):
        self.width, self.height, self.budget, self.decoded = width, height, budget, decoded
        super().__init__(f"{what} {width}×{height} ({megapixels(width * height)}) is too "
                         f"large to {'use' if decoded else 'decode'}: over "
                         f"--max-frame-pixels {megapixels(budget)}")


def check_pixels(width: int, height: int, budget: int, what: str = "frame",
                 decoded: bool = False) -> None:
    """Refuse an image past the pixel budget.

    Parameters
    ----------
    width, height : int
        The image's size, pixels.
    budget : int
        Most pixels (width × height) accepted; 0 or None: no budget.
    what : str
        How the message names the image ("frame", "PATH: image").
    decoded : bool
        Whether it was decoded already (the message then says "too large to use").

    Raises
    ------
    FrameTooLarge
        When ``width * height > budget``.
    """
    if budget and width * height > budget:
        raise FrameTooLarge(width, height, budget, what, decoded)


def decode_limits() -> tuple[int, int]:
    """(most pixels, most pixels a side) that OpenCV decodes: its ``OPENCV_IO_MAX_IMAGE_PIXELS``
    (2^30) and ``OPENCV_IO_MAX_IMAGE_WIDTH`` / ``_HEIGHT`` (2^20), read as OpenCV reads them."""
    import os

    def env(name: str, default: int) -> int:
        try:
            return int(os.environ.get(name, default))
        except ValueError:
            return default
    side = min(env("OPENCV_IO_MAX_IMAGE_WIDTH", 1 << 20), env("OPENCV_IO_MAX_IMAGE_HEIGHT",
                                                               1 << 20))
    return env("OPENCV_IO_MAX_IMAGE_PIXELS", 1 << 30), side


#: libpng refuses a PNG wider or taller than this (PNG_USER_WIDTH_MAX / _HEIGHT_MAX), with
#: its own lines on stderr, before OpenCV looks at the size.
PNG_MAX_SIDE = 1_000_000


def check_decodable(width: int, height: int, data: bytes, what: str) -> None:
    """Refuse, from its header, an image that OpenCV would refuse to decode anyway, so that
    it is one line of ours and not libpng's three (``libpng error: PNG unsigned integer out
    of range``) or OpenCV's: a side of 0, or a size past :func:`decode_limits` (or, for a
    PNG, :data:`PNG_MAX_SIDE`). OpenEXR files (read by the ``openexr`` package) are not
    checked here.

    Raises
    ------
    InputError
        In one line naming ``what`` (e.g. ``"cannot read PATH"``) and the declared size.
    """
    if data[:4] == EXR_MAGIC:
        return
    if width <= 0 or height <= 0:
        raise InputError(f"{what}: its header declares a {width}×{height} image (the file "
                         "is truncated or corrupt)")
    pixels, side = decode_limits()
    if data[:8] == PNG_MAGIC:
        side = min(side, PNG_MAX_SIDE)
    if width * height > pixels or max(width, height) > side:
        raise InputError(f"{what}: its header declares a {width}×{height} image "
                         f"({megapixels(width * height)}), too large to decode (at most "
                         f"{megapixels(pixels)} and {side} pixels a side)")


def header_size(data: bytes) -> tuple[int, int] | None:
    """The size an image file's header declares, without decoding it.

    Parameters
    ----------
    data : bytes
        The file's first bytes (:data:`HEADER_BYTES` are enough for all but TIFF files
        whose directory follows the pixels), or all of it.

    Returns
    -------
    tuple of int or None
        (width, height) in pixels; for a multi-part OpenEXR file the largest part's
        ``dataWindow``. None when the format is not one read here, or its header does not
        lie within ``data`` or makes no sense: the caller then checks the decoded array.
    """
    if not isinstance(data, bytes):
        data = bytes(data)
    try:
        if data[:3] == b"\xff\xd8\xff":
            return _jpeg(data)
        if data[:8] == PNG_MAGIC:
            return struct.unpack(">II", data[16:24]) if data[12:16] == b"IHDR" else None
        if data[:4] == EXR_MAGIC:
            return _exr(data)
        if data[:2] == b"#?":
            return _radiance(data)
        if data[:4] in (b"II*\0", b"MM\0*"):
            return _tiff(data)
        if data[:2] == b"BM":
            return _bmp(data)
        if data[:4] == b"RIFF" and data[8:12] == b"WEBP":
            return _webp(data)
        if len(data) > 2 and data[:1] == b"P" and data[1:2] in (b"1", b"2", b"3", b"4", b"5",
                                                                 b"6", b"F", b"f"):
            return _pnm(data)
    except (struct.error, IndexError, ValueError):
        return None
    return None


def jpeg_segments(data: bytes):
    """The marker segments of a JPEG's header, in order, up to its first scan (SOS) or end
    (EOI): ``(marker, start, end)`` with ``data[start:end]`` the segment's payload after its
    two length bytes (``end`` clamped to the data: a truncated segment is cut short, not
    dropped). Tolerant as decoders are (ITU T.81 B.1.1.2): fill bytes (0xFF 0xFF…),
    markers without a length (SOI, TEM, RST0-7) and stray bytes between segments are
    skipped. ``data`` starts with SOI (the caller checks it). One walk for the frame header
    (:func:`header_size`) and the EXIF segment (:func:`provider.core.radiometry.exif.exif_payload`)."""
    pos = 2
    while pos + 4 <= len(data):
        if data[pos] != 0xFF:              # bytes between segments: skip to the next marker
            pos = data.find(b"\xff", pos)
            if pos < 0:
                return
            continue
        marker = data[pos + 1]
        if marker == 0xFF:                 # fill byte
            pos += 1
            continue
        if marker in (0x01, 0xD8) or 0xD0 <= marker <= 0xD7:     # no length
            pos += 2
            continue
        if marker in (0xD9, 0xDA):         # end of image, or the first scan: the header ends
            return
        length = struct.unpack_from(">H", data, pos + 2)[0]
        yield marker, pos + 4, min(pos + 2 + length, len(data))
        pos += 2 + length


def _jpeg(data: bytes) -> tuple[int, int] | None:
    """The first frame header (SOF0-SOF15 but DHT, JPG and DAC) before the first scan."""
    for marker, start, end in jpeg_segments(data):
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            if start + 5 > end:
                return None
            height, width = struct.unpack_from(">HH", data, start + 1)
            return width, height
    return None


def _exr(data: bytes) -> tuple[int, int] | None:
    """Every part's ``dataWindow`` (box2i: xmin, ymin, xmax, ymax, inclusive)."""
    multipart = bool(data[5] & 0x10)
    pos, sizes = 8, []
    while True:
        window = None
        while data[pos] != 0:                                 # one header's attributes
            name_end = data.index(b"\0", pos)
            type_end = data.index(b"\0", name_end + 1)
            size = struct.unpack_from("<i", data, type_end + 1)[0]
            if size < 0 or type_end + 5 + size > len(data):
                return None
            if data[pos:name_end] == b"dataWindow" and size == 16:
                window = struct.unpack_from("<4i", data, type_end + 5)
            pos = type_end + 5 + size
        pos += 1
        if window is None:
            return None
        xmin, ymin, xmax, ymax = window
        sizes.append((max(xmax - xmin + 1, 0), max(ymax - ymin + 1, 0)))
        if not multipart or data[pos] == 0:                   # the empty header ends the list
            return max(sizes, key=lambda s: s[0] * s[1])


_RESOLUTION = re.compile(rb"([-+])([XY])\s+(\d+)\s+([-+])([XY])\s+(\d+)")


def _radiance(data: bytes) -> tuple[int, int] | None:
    """The resolution line after the blank line that ends the header, e.g. ``-Y 512 +X 1024``
    (rows first: height, then width)."""
    end = data.find(b"\n\n")
    if end < 0:
        return None
    line = data[end + 2: data.find(b"\n", end + 2)]
    m = _RESOLUTION.match(line.strip())
    if not m or m.group(2) == m.group(5):
        return None
    first, second = int(m.group(3)), int(m.group(6))
    return (second, first) if m.group(2) == b"Y" else (first, second)


def _tiff(data: bytes) -> tuple[int, int] | None:
    """ImageWidth (256) and ImageLength (257) of the first image file directory."""
    order = "<" if data[:2] == b"II" else ">"
    ifd = struct.unpack_from(order + "I", data, 4)[0]
    count = struct.unpack_from(order + "H", data, ifd)[0]
    found = {}
    for i in range(count):
        tag, kind, n = struct.unpack_from(order + "HHI", data, ifd + 2 + 12 * i)
        if tag in (256, 257) and n == 1 and kind in (3, 4):
            value = struct.unpack_from(order + ("H" if kind == 3 else "I"), data,
                                       ifd + 2 + 12 * i + 8)[0]
            found[tag] = value
    return (found[256], found[257]) if len(found) == 2 else None


def _bmp(data: bytes) -> tuple[int, int] | None:
    header = struct.unpack_from("<I", data, 14)[0]
    if header == 12:                                  # BITMAPCOREHEADER: 16-bit sizes
        return struct.unpack_from("<HH", data, 18)
    width, height = struct.unpack_from("<ii", data, 18)
    return abs(width), abs(height)                    # a negative height: top-down rows


def _webp(data: bytes) -> tuple[int, int] | None:
    chunk = data[12:16]
    if chunk == b"VP8X":                              # extended: the canvas, 24-bit sizes
        w = int.from_bytes(data[24:27], "little") + 1
        h = int.from_bytes(data[27:30], "little") + 1
        return w, h
    if chunk == b"VP8L" and data[20] == 0x2F:         # lossless: 14-bit sizes minus one
        bits = struct.unpack_from("<I", data, 21)[0]
        return (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1
    if chunk == b"VP8 " and data[23:26] == b"\x9d\x01\x2a":   # lossy key frame
        w, h = struct.unpack_from("<HH", data, 26)
        return w & 0x3FFF, h & 0x3FFF
    return None


_PNM = re.compile(rb"P[1-6Ff]((?:\s+|#[^\n]*\n)+)(\d+)((?:\s+|#[^\n]*\n)+)(\d+)\s")


def _pnm(data: bytes) -> tuple[int, int] | None:
    """Netpbm (P1-P6) and PFM (PF, Pf): the width and height after the magic number
    (comments allowed in Netpbm headers)."""
    m = _PNM.match(data[:4096])
    return (int(m.group(2)), int(m.group(4))) if m else None
