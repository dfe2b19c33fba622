"""An 8-bit frame decoded through its table and block-averaged in one pass (no I/O).

:func:`decode_blocks` is what ``cv2.LUT`` followed by an area resize by an integer factor
computes, without the float copy of the frame between them. Its kernel is chosen once, at
import, as the ``websockets`` library chooses its ``speedups``: the C kernel
(``_blocks.c``, built by ``pip install``; see ``setup.py``), which sums each block's table
values as it reads the bytes (about three x86 instructions a sample against ten for the two
OpenCV calls, issue 34), or where it was not built (no C compiler at install time) its
Python twin :func:`_decode_blocks_py`: the same signature, the same numbers to float
rounding, the same errors (``tests/core/kernels/test_kernel_twins.py`` holds them to it).
:data:`KERNEL` says whether the C kernel is built: the products take the one-pass paths
only then (without it their band by band passes keep each band's float copy in cache).
"""
from __future__ import annotations

import operator

import cv2
import numpy as np

#: int32 struct formats: numpy says "i", or "l" where a long is 4 bytes (Windows).
_INT32 = ("i", "l")


def buffer_view(obj, writable: bool, fmt: str, ndim: int, name: str) -> memoryview:
    """``obj``'s buffer as an ``ndim``-d array of struct format ``fmt`` ("B", "f", "d", or
    "i": int32): the twin of the kernels' ``get_view`` (``_kernels/buffer_check.h``), with
    its errors: TypeError for no buffer, ValueError for a read-only one asked to be written
    or for another format or number of dimensions."""
    view = memoryview(obj)
    if writable and view.readonly:
        raise ValueError("buffer source array is read-only")
    int32 = fmt == "i" and view.itemsize == 4 and view.format in _INT32
    if view.ndim != ndim or (not int32 and view.format != fmt):
        raise ValueError(f"{name}: expected a {ndim}-d array of format '{fmt}'")
    return view


def contiguous(view: memoryview) -> bool:
    """C-contiguous, dimensions of length 0 or 1 aside (``buffer_check.h``'s test)."""
    step = view.itemsize
    for size, stride in zip(reversed(view.shape), reversed(view.strides)):
        if size > 1 and stride != step:
            return False
        step *= size
    return True


def c_int(value) -> int:
    """``value`` as the kernels' C ``int`` argument (``PyArg_ParseTuple``'s "i")."""
    v = operator.index(value)
    if not -2 ** 31 <= v < 2 ** 31:
        raise OverflowError("signed integer is greater than maximum" if v > 0
                            else "signed integer is less than minimum")
    return v


def _decode_blocks_py(frame, table, factor, out, spans=None) -> None:
    """The Python twin of the C kernel ``_blocks.decode_blocks`` (its signature and checks,
    see ``_blocks.c`` and ``_blocks.pyi``): ``out`` (H // f, W // f, C) float32 gets the
    means of ``table[frame]`` over f × f blocks, 0 outside ``spans``. Sums in float64 (the
    C in float32: they differ by float rounding)."""
    f = c_int(factor)
    if f < 1:
        raise ValueError("factor must be at least 1")
    fr = buffer_view(frame, False, "B", 3, "frame")
    if fr.shape[0] < f or fr.shape[1] < f:
        raise ValueError("factor: larger than the frame (H // factor or W // factor is 0)")
    tb = buffer_view(table, False, "f", 1, "table")
    ov = buffer_view(out, True, "f", 3, "out")
    sp = None if spans is None else buffer_view(spans, False, "i", 2, "spans")
    H, W, C = fr.shape
    h, w, n = H // f, W // f, tb.shape[0]
    err = None
    if C < 1 or C > 4 or fr.strides[2] != 1 or fr.strides[1] != C:
        err = "frame: pixels must be contiguous, 1 to 4 channels"
    elif tb.strides[0] != 4 or n not in (256, 256 * C):
        err = "table: 256 contiguous entries, or 256 per channel"
    elif ov.shape != (h, w, C) or ov.strides[2] != 4 or ov.strides[1] != 4 * C:
        err = "out: must be (H // factor, W // factor, C) float32 with contiguous pixels"
    elif sp is not None and (sp.shape[0] != h or sp.shape[1] != 2 or sp.strides[1] != 4
                             or sp.strides[0] != 8):
        err = "spans: (H // factor, 2) contiguous int32"
    span = None if sp is None else np.asarray(sp).astype(np.int64)
    if err is None and span is not None and np.any(
            (span[:, 0] < 0) | (span[:, 0] > span[:, 1]) | (span[:, 1] > w)):
        err = "spans: each row's [first, stop) within [0, W // factor]"
    if err is not None:
        raise ValueError(err)
    codes = np.asarray(fr)[:h * f, :w * f]
    t = np.asarray(tb)
    lin = t[codes] if n == 256 else t.reshape(256, C)[codes, np.arange(C)]
    means = lin.reshape(h, f, w, f, C).sum(axis=(1, 3), dtype=np.float64) / (f * f)
    if span is not None:
        columns = np.arange(w)
        means[(columns < span[:, :1]) | (columns >= span[:, 1:])] = 0.0
    np.asarray(ov)[...] = means


try:
    from ._blocks import decode_blocks as _decode_blocks
except ImportError:          # built without a C compiler: its Python twin
    _decode_blocks = _decode_blocks_py

#: True when the C kernel is built (``pip install`` with a C compiler).
KERNEL = _decode_blocks is not _decode_blocks_py


def decode_blocks(frame: np.ndarray, table: np.ndarray, factor: int,
                  out: np.ndarray | None = None, *, spans: np.ndarray | None = None
                  ) -> np.ndarray:
    """The mean of ``table[frame]`` over ``factor × factor`` blocks.

    frame : (H, W, 3) uint8 (1 to 4 channels), any strides (a window's view; pixels that
        are not contiguous are copied first).
    table : float32 (256,) one curve for all channels, or (256, 1, 3) one per channel (the
        tables :meth:`~provider.core.radiometry.decode.FrameDecoder._lut` makes).
    factor : block side f ≥ 1, at most the frame's height and width; rows and columns past
        ``H // f · f``, ``W // f · f`` are not read.
    out : (H // f, W // f, 3) float32 to write, or None for a new array.
    spans : None, or int32 (H // f, 2): only blocks ``[spans[y, 0], spans[y, 1])`` of output
        row y are read (those a projection gives a weight); the rest are 0.

    Returns ``out``: linear float32, the block means (the C kernel sums in float32, its twin
    in float64: equal to float rounding, ~1e-7 relative). Raises ValueError for arrays the
    kernel does not take, with what is wrong.
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
    if frame.strides[2] != 1 or frame.strides[1] != frame.shape[2]:
        frame = np.ascontiguousarray(frame)
    _decode_blocks(frame, np.ascontiguousarray(table, np.float32).reshape(-1), f, out,
                   None if spans is None else np.ascontiguousarray(spans, np.int32))
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
