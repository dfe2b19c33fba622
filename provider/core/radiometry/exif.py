"""A still's own exposure from its EXIF: exposure time, f-number and ISO (reads the header only).

JPEG stills keep EXIF in an APP1 segment (``Exif\\0\\0`` then a TIFF structure); TIFF files
are that structure. The tags, all in the Exif IFD (pointer tag 0x8769 of IFD0; some writers
put them in IFD0 itself, read too), EXIF 2.32 (CIPA DC-008):

* 0x829A ``ExposureTime``  RATIONAL, seconds;
* 0x829D ``FNumber``       RATIONAL;
* 0x8827 ``PhotographicSensitivity`` (EXIF 2.2's ``ISOSpeedRatings``) SHORT; a value of
  65535 means "above 65534": the ``RecommendedExposureIndex`` (0x8832, LONG) then says it.

A reader of the standard TIFF tag layout (a few dozen lines) rather than a dependency: the
core stays on numpy + OpenCV, and OpenCV does not read EXIF. Malformed or missing EXIF is not
an error: the fields are None (the frame then needs ``@SECONDS``, as before).
"""
from __future__ import annotations

import math
import os
import stat
import struct
from dataclasses import dataclass

from .image_size import jpeg_segments

#: The JPEG header is read up to here at most (EXIF lives in APP1, at most 64 KiB, near the
#: start; a Theta still puts its XMP and EXIF in its first segments).
JPEG_SCAN_BYTES = 1 << 20

EXIF_IFD = 0x8769
EXPOSURE_TIME = 0x829A
F_NUMBER = 0x829D
ISO = 0x8827
RECOMMENDED_EXPOSURE_INDEX = 0x8832
_SIZES = {1: 1, 2: 1, 3: 2, 4: 4, 5: 8, 7: 1, 9: 4, 10: 8}


@dataclass(frozen=True)
class StillExposure:
    """What a still says of its own exposure; None where it does not say.

    exposure_s : exposure time, seconds; f_number : the aperture's f-number N;
    iso : the ISO speed (sensitivity) the camera recorded."""

    exposure_s: float | None = None
    f_number: float | None = None
    iso: float | None = None

    @property
    def complete(self) -> bool:
        """Time, f-number and ISO all known: enough for absolute units."""
        return None not in (self.exposure_s, self.f_number, self.iso)


def _positive(v) -> float | None:
    return float(v) if v is not None and math.isfinite(v) and v > 0 else None


class _Tiff:
    """The tags of a TIFF structure held in ``data`` (bytes)."""

    def __init__(self, data: bytes):
        self.data = data
        order = data[:2]
        if order == b"II":
            self.e = "<"
        elif order == b"MM":
            self.e = ">"
        else:
            raise ValueError("not a TIFF header")
        if struct.unpack(self.e + "H", data[2:4])[0] != 42:
            raise ValueError("not a TIFF header")
        self.ifd0 = struct.unpack(self.e + "I", data[4:8])[0]

    def tags(self, offset: int) -> dict:
        """{tag: value} of the IFD at ``offset`` (numbers only; the first of a list)."""
        e, d = self.e, self.data
        if offset + 2 > len(d):
            raise ValueError("IFD beyond the data")
        (n,) = struct.unpack(e + "H", d[offset:offset + 2])
        out = {}
        for i in range(n):
            at = offset + 2 + 12 * i
            if at + 12 > len(d):
                break
            tag, kind, count = struct.unpack(e + "HHI", d[at:at + 8])
            size = _SIZES.get(kind)
            if size is None or count < 1:
                continue
            where = at + 8 if size * count <= 4 else struct.unpack(e + "I", d[at + 8:at + 12])[0]
            if where + size > len(d):
                continue
            raw = d[where:where + size]
            if kind == 3:
                out[tag] = struct.unpack(e + "H", raw)[0]
            elif kind in (4, 9):
                out[tag] = struct.unpack(e + ("I" if kind == 4 else "i"), raw)[0]
            elif kind in (5, 10):
                num, den = struct.unpack(e + ("II" if kind == 5 else "ii"), raw)
                out[tag] = num / den if den else float("nan")
            elif kind in (1, 7):
                out[tag] = raw[0]
        return out


def exposure_from_tiff(data: bytes) -> StillExposure:
    """The exposure in a TIFF structure (an EXIF payload after ``Exif\\0\\0``, or a TIFF
    file's bytes); empty for anything malformed."""
    try:
        tiff = _Tiff(data)
        tags = tiff.tags(tiff.ifd0)
        if EXIF_IFD in tags:
            tags = {**tags, **tiff.tags(int(tags[EXIF_IFD]))}
    except (ValueError, struct.error):
        return StillExposure()
    iso = tags.get(ISO)
    if iso == 65535 and tags.get(RECOMMENDED_EXPOSURE_INDEX):
        iso = tags[RECOMMENDED_EXPOSURE_INDEX]
    return StillExposure(_positive(tags.get(EXPOSURE_TIME)), _positive(tags.get(F_NUMBER)),
                         _positive(iso))


def exif_payload(jpeg: bytes) -> bytes | None:
    """The TIFF structure of a JPEG's EXIF APP1 segment, or None (the segments walked by
    :func:`~provider.core.radiometry.image_size.jpeg_segments`)."""
    if jpeg[:2] != b"\xff\xd8":
        return None
    for marker, start, end in jpeg_segments(jpeg):
        if marker == 0xE1 and jpeg[start:start + 6] == b"Exif\x00\x00":
            return jpeg[start + 6:end]
    return None


def read_still_exposure(path) -> StillExposure:
    """What a JPEG or TIFF still says of its exposure (empty for other formats, no EXIF,
    malformed EXIF or an unreadable file: the caller then asks for ``@SECONDS``). Only a
    regular file is opened: a FIFO's bytes belong to the image reader."""
    try:
        if not stat.S_ISREG(os.stat(path).st_mode):
            return StillExposure()
        with open(path, "rb") as f:
            head = f.read(8)
            if head[:2] == b"\xff\xd8":
                f.seek(0)
                payload = exif_payload(f.read(JPEG_SCAN_BYTES))
                return exposure_from_tiff(payload) if payload else StillExposure()
            if head[:4] in (b"II*\x00", b"MM\x00*"):
                f.seek(0)
                return exposure_from_tiff(f.read())
    except OSError:
        pass
    return StillExposure()
