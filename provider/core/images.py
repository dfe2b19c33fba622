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
        return _read_exr(path)
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
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
