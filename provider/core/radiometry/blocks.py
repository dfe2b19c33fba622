"""An 8-bit frame decoded through its table and block-averaged in one pass (no I/O).

:func:`decode_blocks` is what ``cv2.LUT`` followed by an area resize by an integer factor
computes, without the float copy of the frame between them: the C kernel
(``_blocks.c``, built by ``pip install``; see ``setup.py``) sums each block's table values
as it reads the bytes, at about three x86 instructions a sample against ten for the two
OpenCV calls (issue 34). Where the kernel was not built (no C compiler at install time) the
same numbers come from OpenCV; :data:`KERNEL` says which.
"""
from __future__ import annotations

import cv2
import numpy as np

try:
    from ._blocks import decode_blocks as _decode_blocks
except ImportError:          # built without a C compiler: the OpenCV path below
    _decode_blocks = None

#: True when the C kernel is built (``pip install`` with a C compiler).
KERNEL = _decode_blocks is not None


def decode_blocks(frame: np.ndarray, table: np.ndarray, factor: int,
                  out: np.ndarray | None = None, *, spans: np.ndarray | None = None,
                  kernel: bool = True) -> np.ndarray:
    """The mean of ``table[frame]`` over ``factor × factor`` blocks.

    frame : (H, W, 3) uint8, pixels contiguous (rows may be strided: a window's view).
    table : float32 (256,) one curve for all channels, or (256, 1, 3) one per channel (the
        tables :meth:`~provider.core.radiometry.decode.FrameDecoder._lut` makes).
    factor : block side f ≥ 1; rows and columns past ``H // f · f``, ``W // f · f`` are
        not read.
    out : (H // f, W // f, 3) float32 to write, or None for a new array.
    spans : None, or int32 (H // f, 2): only blocks ``[spans[y, 0], spans[y, 1])`` of output
        row y are read (those a projection gives a weight); the rest are 0.
    kernel : False takes the OpenCV path even where the kernel is built (its tests).

    Returns ``out``: linear float32, the block means summed in float32 (equal to the
    OpenCV path to float rounding, ~1e-7 relative).
    """
    if frame.dtype != np.uint8 or frame.ndim != 3:
        raise ValueError(f"decode_blocks takes an (H, W, C) uint8 frame, got "
                         f"{frame.dtype} {frame.shape}")
    f = int(factor)
    if f < 1:
        raise ValueError(f"factor must be at least 1, got {factor}")
    h, w = frame.shape[0] // f, frame.shape[1] // f
    if out is None:
        out = np.empty((h, w, frame.shape[2]), np.float32)
    if kernel and _decode_blocks is not None:
        if frame.strides[2] != 1 or frame.strides[1] != frame.shape[2]:
            frame = np.ascontiguousarray(frame)
        _decode_blocks(frame, np.ascontiguousarray(table, np.float32).reshape(-1), f, out,
                       None if spans is None else np.ascontiguousarray(spans, np.int32))
        return out
    lin = cv2.LUT(frame[:h * f, :w * f], table)
    out[...] = lin if f == 1 else cv2.resize(lin, (w, h), interpolation=cv2.INTER_AREA)
    if spans is not None:
        columns = np.arange(w)
        out[(columns < spans[:, :1]) | (columns >= spans[:, 1:])] = 0.0
    return out


def block_spans(seen: np.ndarray) -> np.ndarray:
    """(h, 2) int32 ``spans`` for :func:`decode_blocks` from an (h, w) mask of the blocks a
    projection gives a weight: each row's first and last such block, + 1 (0, 0 for none)."""
    seen = np.asarray(seen, bool)
    any_ = seen.any(axis=1)
    first = np.argmax(seen, axis=1)
    stop = seen.shape[1] - np.argmax(seen[:, ::-1], axis=1)
    return np.where(any_[:, None], np.stack([first, stop], axis=1), 0).astype(np.int32)


def shrink(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``image`` (H, W, C) float area-averaged to ``size`` (w, h), as ``cv2.INTER_AREA``.
    Where both sides shrink by the same power of two, halved again and again with
    ``cv2.INTER_LINEAR``, which at exactly half size samples between each pixel pair with
    weights ½, ½: the 2×2 block mean to float rounding, at about a third of
    ``INTER_AREA``'s instructions (23 against 66 µs a 32×640 band here)."""
    h, w = image.shape[:2]
    factor = w // size[0] if size[0] else 0
    if factor < 2 or factor & (factor - 1) or (w, h) != (size[0] * factor, size[1] * factor):
        return cv2.resize(image, size, interpolation=cv2.INTER_AREA)
    while factor > 1:
        h, w, factor = h // 2, w // 2, factor // 2
        image = cv2.resize(image, (w, h), interpolation=cv2.INTER_LINEAR)
    return image
