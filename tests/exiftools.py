"""EXIF written byte by byte, as the TIFF 6.0 specification lays it out, into real JPEG
stills (OpenCV's encoder): the exposure a camera records, in whichever numeric type."""
from __future__ import annotations

import struct
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np

EXPOSURE_TIME, F_NUMBER, ISO, EXPOSURE_BIAS = 0x829A, 0x829D, 0x8827, 0x9204

#: TIFF 6.0 field types: name -> (type code, struct code of one value).
TYPES = {"BYTE": (1, "B"), "SHORT": (3, "H"), "LONG": (4, "I"), "RATIONAL": (5, "II"),
         "SBYTE": (6, "b"), "SSHORT": (8, "h"), "SLONG": (9, "i"), "SRATIONAL": (10, "ii"),
         "FLOAT": (11, "f"), "DOUBLE": (12, "d")}


def encode(kind: str, value: float, e: str) -> bytes:
    code = TYPES[kind][1]
    if len(code) == 2:                          # a rational: the nearest with 32-bit terms
        f = Fraction(value).limit_denominator(1_000_000)
        return struct.pack(e + code, f.numerator, f.denominator)
    return struct.pack(e + code, value if code in "fd" else round(value))


def tiff(entries, order: str = "II", exif_ifd: bool = True) -> bytes:
    """A TIFF structure whose IFD0 points to an Exif IFD holding ``entries`` [(tag, type
    name, value)] (or holds them itself); values of more than 4 bytes after the IFDs."""
    e = "<" if order == "II" else ">"
    head = order.encode() + struct.pack(e + "HI", 42, 8)
    ifd0 = struct.pack(e + "H", 1) + struct.pack(e + "HHII", 0x8769, 4, 1, 26) \
        + struct.pack(e + "I", 0) if exif_ifd else b""
    at = 8 + len(ifd0)
    data_at = at + 2 + 12 * len(entries) + 4
    body, extra = struct.pack(e + "H", len(entries)), b""
    for tag, kind, value in entries:
        raw = encode(kind, value, e)
        if len(raw) <= 4:
            body += struct.pack(e + "HHI", tag, TYPES[kind][0], 1) + raw.ljust(4, b"\0")
        else:
            body += struct.pack(e + "HHII", tag, TYPES[kind][0], 1, data_at + len(extra))
            extra += raw
    return head + ifd0 + body + struct.pack(e + "I", 0) + extra


def jpeg_with_exif(path, payload: bytes, level: int = 120, rgb=None, quality: int = 95,
                   sampling: int = cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420) -> None:
    """A real JPEG (OpenCV's encoder, 4:2:0 as cameras write) of ``rgb`` (H×W×3 uint8; a
    grey 32×16 frame of ``level`` without) with ``payload`` as its EXIF APP1 segment."""
    if rgb is None:
        rgb = np.full((16, 32, 3), level, np.uint8)
    ok, jpg = cv2.imencode(".jpg", np.ascontiguousarray(rgb[..., ::-1]),
                           [cv2.IMWRITE_JPEG_QUALITY, quality,
                            cv2.IMWRITE_JPEG_SAMPLING_FACTOR, sampling])
    assert ok
    segment = b"Exif\0\0" + payload
    jpg = jpg.tobytes()
    Path(path).write_bytes(jpg[:2] + b"\xff\xe1" + struct.pack(">H", len(segment) + 2) + segment
                     + jpg[2:])


def exposure_exif(t: float, n: float, iso: float) -> bytes:
    """ExposureTime, FNumber and ISO as cameras write them (RATIONAL, RATIONAL, SHORT)."""
    return tiff([(EXPOSURE_TIME, "RATIONAL", t), (F_NUMBER, "RATIONAL", n), (ISO, "SHORT", iso)])
