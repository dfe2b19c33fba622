"""Reading images from files into the engine's frame contract (RGB, uint8/uint16/float32)."""
from __future__ import annotations

import os

import cv2
import numpy as np

from .errors import InputError

#: The first four bytes of every OpenEXR file.
EXR_MAGIC = b"\x76\x2f\x31\x01"

IMAGE_EXTENSIONS = (".exr", ".hdr", ".pic", ".png", ".jpg", ".jpeg", ".tif", ".tiff",
                    ".bmp", ".webp", ".pfm", ".ppm", ".pgm")


def read_image(path) -> np.ndarray:
    """Read an image file as an (H, W, 3) RGB array.

    OpenEXR files are read with the ``openexr`` package (the OpenCV wheels have no EXR
    codec) and returned as float32; everything else through ``cv2.imread`` with
    ``IMREAD_UNCHANGED`` (8-bit, 16-bit and Radiance .hdr float stay as they are).
    Raises :class:`InputError` with a readable message for a missing or unreadable file.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputError(f"no such file: {path}")
    if os.path.isdir(path):
        raise InputError(f"{path} is a directory, not an image")
    # By content, not by name: an EXR saved as .jpg is still an EXR (OpenCV's wheels cannot
    # decode EXR, so the name alone would refuse it).
    try:
        with open(path, "rb") as f:
            magic = f.read(4)
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
    if magic == EXR_MAGIC or (path.lower().endswith(".exr") and len(magic) < 4):
        _check_exr_complete(path)
        return _read_exr(path)
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
    check_complete(path, data)
    try:
        img = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error:
        # OpenCV refuses a header that declares more than CV_IO_MAX_IMAGE_PIXELS (2^30)
        raise InputError(f"cannot read {path}: its header declares an image too large to "
                         "decode (over 2^30 pixels), or it is corrupt") from None
    if img is None:
        raise InputError(f"cannot read {path}: not an image OpenCV can decode")
    if img.ndim == 2:
        return np.repeat(img[..., None], 3, axis=2)
    if img.shape[2] == 4:
        img = img[..., :3]
    return np.ascontiguousarray(img[..., ::-1])  # BGR -> RGB


def _read_exr(path: str) -> np.ndarray:
    try:
        import OpenEXR
    except ImportError:  # pragma: no cover - a declared dependency
        raise InputError("reading .exr needs the 'openexr' package: pip install openexr")
    try:
        with OpenEXR.File(path) as f:
            channels = f.channels()
            if "RGB" in channels:
                rgb = channels["RGB"].pixels
            elif "RGBA" in channels:
                rgb = channels["RGBA"].pixels[..., :3]
            elif all(k in channels for k in "RGB"):
                rgb = np.stack([channels[k].pixels for k in "RGB"], axis=-1)
            elif "Y" in channels:
                rgb = np.repeat(channels["Y"].pixels[..., None], 3, axis=2)
            else:
                raise InputError(f"{path}: no RGB or Y channels (has {sorted(channels)})")
    except InputError:
        raise
    except Exception as exc:
        raise InputError(f"cannot read {path} as OpenEXR: {exc}") from None
    return np.ascontiguousarray(rgb, dtype=np.float32)


def check_complete(path: str, data: bytes) -> None:
    """Refuse a JPEG or PNG that ends before its image does (a copy cut short): OpenCV
    would decode the part it has and fill the rest with grey, and libjpeg/libpng would
    print their own words."""
    if data[:3] == b"\xff\xd8\xff":                                    # JPEG
        tail = data.rstrip(b"\x00\r\n ")
        scan = data.rfind(b"\xff\xda")                     # the last start of scan
        if not tail.endswith(b"\xff\xd9") and (scan < 0 or data.rfind(b"\xff\xd9") < scan):
            raise InputError(f"cannot read {path}: the JPEG is truncated (it ends before its "
                             "end-of-image marker); copy it again")
    elif data[:8] == b"\x89PNG\r\n\x1a\n" and data.rfind(b"IEND") < 0:
        raise InputError(f"cannot read {path}: the PNG is truncated (no IEND chunk); copy it "
                         "again")


#: Scan lines per chunk of each OpenEXR compression (by its number in the header).
_EXR_LINES = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 32, 9: 256}


def _check_exr_complete(path: str) -> None:
    """Refuse a single-part scan-line OpenEXR file whose last chunk lies beyond its end (a
    copy cut short): the OpenEXR library would print its own words on stdout. Other layouts
    (tiled, multi-part, deep) are left to the library."""
    import struct
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
    short = InputError(f"cannot read {path}: the OpenEXR file is truncated or corrupt; copy "
                       "it again")
    if len(data) < 8:
        raise short
    flags = data[5]
    if flags & 0x1E:                         # tiled, long names, deep or multi-part
        return
    pos, attrs = 8, {}
    try:
        while data[pos] != 0:
            end = data.index(b"\0", pos)
            name = data[pos:end]
            end2 = data.index(b"\0", end + 1)
            size = struct.unpack_from("<i", data, end2 + 1)[0]
            attrs[name] = data[end2 + 5:end2 + 5 + size]
            pos = end2 + 5 + size
        pos += 1
        xmin, ymin, xmax, ymax = struct.unpack("<4i", attrs[b"dataWindow"])
        lines = _EXR_LINES.get(attrs[b"compression"][0])
        if lines is None:
            return
        chunks = (ymax - ymin) // lines + 1
        offsets = struct.unpack_from(f"<{chunks}Q", data, pos)
        last = max(offsets)
        size = struct.unpack_from("<i", data, last + 4)[0]
    except (IndexError, KeyError, ValueError, struct.error):
        raise short from None
    if min(offsets) <= pos or last + 8 + size > len(data):
        raise short
