"""A still's own exposure from its EXIF: exposure time, f-number and ISO (reads the header only).

JPEG stills keep EXIF in an APP1 segment (``Exif\\0\\0`` then a TIFF structure); TIFF files
are that structure. The tags, all in the Exif IFD (pointer tag 0x8769 of IFD0; some writers
put them in IFD0 itself, read too), EXIF 2.32 (CIPA DC-008):

* 0x829A ``ExposureTime``  RATIONAL, seconds;
* 0x829D ``FNumber``       RATIONAL;
* 0x8827 ``PhotographicSensitivity`` (EXIF 2.2's ``ISOSpeedRatings``) SHORT; a value of
  65535 means "above 65534": the ``RecommendedExposureIndex`` (0x8832, LONG) then says it;
* 0x9204 ``ExposureBiasValue`` SRATIONAL, EV.

The standard's types are what cameras write, but Pillow writes a Python float as DOUBLE and
some tools write FLOAT, SHORT or LONG: every numeric TIFF type is read (BYTE, SHORT, LONG,
RATIONAL, SBYTE, SSHORT, SLONG, SRATIONAL, FLOAT, DOUBLE), so a still is not refused as
having no exposure for the type its writer chose. A number no camera records (a negative
time, an f-number of 0.1: :mod:`.photometry`'s bounds) is not used, and
``StillExposure.refused`` says why in one line.

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
from .photometry import EXPOSURE_S_RANGE, F_NUMBER_RANGE, ISO_RANGE

#: The JPEG header is read up to here at most (EXIF lives in APP1, at most 64 KiB, near the
#: start; a Theta still puts its XMP and EXIF in its first segments).
JPEG_SCAN_BYTES = 1 << 20

EXIF_IFD = 0x8769
EXPOSURE_TIME = 0x829A
F_NUMBER = 0x829D
ISO = 0x8827
RECOMMENDED_EXPOSURE_INDEX = 0x8832
EXPOSURE_BIAS = 0x9204
#: TIFF 6.0 field types: (byte size, struct code; None for the two-LONG rationals).
_TYPES = {1: (1, "B"), 2: (1, None), 3: (2, "H"), 4: (4, "I"), 5: (8, "II"), 6: (1, "b"),
          7: (1, "B"), 8: (2, "h"), 9: (4, "i"), 10: (8, "ii"), 11: (4, "f"), 12: (8, "d")}
#: An exposure bias beyond this (EV) is no camera's setting (they offer ±5, some ±7).
EXPOSURE_BIAS_RANGE = (-16.0, 16.0)


@dataclass(frozen=True)
class StillExposure:
    """What a still says of its own exposure; None where it does not say.

    exposure_s : exposure time, seconds; f_number : the aperture's f-number N;
    iso : the ISO speed (sensitivity) the camera recorded; exposure_bias_ev : the exposure
    compensation the camera applied (EV, for the record: the time already holds it);
    refused : one line per value the EXIF holds but no camera records (not used)."""

    exposure_s: float | None = None
    f_number: float | None = None
    iso: float | None = None
    exposure_bias_ev: float | None = None
    refused: tuple = ()

    @property
    def complete(self) -> bool:
        """Time, f-number and ISO all known: enough for absolute units."""
        return None not in (self.exposure_s, self.f_number, self.iso)


def _bounded(tags: dict, tag: int, name: str, bounds, unit: str, refused: list):
    """The tag's number when it lies within ``bounds`` (low exclusive when 0), else None,
    with a line in ``refused`` when it was there but out of bounds."""
    v = tags.get(tag)
    if v is None or math.isnan(v):      # absent, or a rational 0/0 ("unknown")
        return None
    low, high = bounds
    if math.isfinite(v) and (v > low if low == 0 else v >= low) and v <= high:
        return float(v)
    refused.append(f"EXIF {name} {v:g}{unit} is not one a camera records ({low:g} to "
                   f"{high:g}{unit}): not used")
    return None


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
        """{tag: value} of the IFD at ``offset`` (numbers of every numeric type, as float or
        int; the first of a list; a rational with a zero denominator is NaN)."""
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
            size, code = _TYPES.get(kind, (None, None))
            if code is None or count < 1:
                continue
            where = at + 8 if size * count <= 4 else struct.unpack(e + "I", d[at + 8:at + 12])[0]
            if where + size > len(d):
                continue
            value = struct.unpack(e + code, d[where:where + size])
            if len(value) == 2:          # RATIONAL, SRATIONAL
                num, den = value
                out[tag] = num / den if den else float("nan")
            else:
                out[tag] = value[0]
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
    if tags.get(ISO) == 65535 and tags.get(RECOMMENDED_EXPOSURE_INDEX):
        tags[ISO] = tags[RECOMMENDED_EXPOSURE_INDEX]
    refused: list = []
    return StillExposure(
        _bounded(tags, EXPOSURE_TIME, "ExposureTime", EXPOSURE_S_RANGE, " s", refused),
        _bounded(tags, F_NUMBER, "FNumber", F_NUMBER_RANGE, "", refused),
        _bounded(tags, ISO, "ISO", ISO_RANGE, "", refused),
        _bounded(tags, EXPOSURE_BIAS, "ExposureBiasValue", EXPOSURE_BIAS_RANGE, " EV",
                 refused),
        tuple(refused))


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
