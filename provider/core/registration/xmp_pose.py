"""A still's gravity from its XMP: Google Photo Sphere ``GPano:PosePitchDegrees`` and
``GPano:PoseRollDegrees`` (written by a Ricoh Theta when it does not level the still itself)."""
from __future__ import annotations

import math
import os
import re

#: XMP is near the start of a JPEG; a Theta still's packet sits in its first APP1 segments.
XMP_SCAN_BYTES = 1 << 20


def _value(text: bytes, name: str):
    m = re.search(rb"GPano:" + name.encode() + rb"\s*=\s*[\"']([-+0-9.eE]+)[\"']", text) or \
        re.search(rb"<GPano:" + name.encode() + rb">\s*([-+0-9.eE]+)\s*<", text)
    if not m:
        return None
    try:
        v = float(m.group(1))
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def parse_pose(xmp: bytes):
    """(pitch, roll) in degrees from XMP text, or None when it does not say both."""
    pitch, roll = _value(xmp, "PosePitchDegrees"), _value(xmp, "PoseRollDegrees")
    return None if pitch is None or roll is None else (pitch, roll)


def read_pose(path):
    """(pitch, roll) in degrees from an image file's XMP, or None (no XMP, other formats)."""
    try:
        with open(os.fspath(path), "rb") as f:
            head = f.read(XMP_SCAN_BYTES)
    except OSError:
        return None
    if b"GPano:" not in head:
        return None
    return parse_pose(head)
