"""The printable registration marker: the pattern at print resolution, a quiet zone and its
size printed under it (no I/O; ``shlight marker`` writes the PNG)."""
from __future__ import annotations

import math

import cv2
import numpy as np

from ..errors import InputError
from .marker_detect import MarkerSpec, check_marker_size

MM_PER_INCH = 25.4
#: The most a QR code (version 40, error correction L: OpenCV's encoder) holds, per mode.
QR_CAPACITY = {"bytes": 2953, "alphanumeric": 4296, "digits": 7089}


def marker_cells(spec: MarkerSpec) -> np.ndarray:
    """The pattern, one pixel per cell (0 black): an ArUco marker with its black border, or
    the QR code encoding ``spec.text`` without its quiet zone."""
    if spec.kind == "aruco":
        if spec.marker_id is None:
            raise InputError(f"marker {spec}: say which id to print (e.g. {spec}:7)")
        return spec.grid()
    if not spec.text:
        raise InputError("marker qr: say what the code encodes (e.g. qr:room-1)")
    try:
        img = cv2.QRCodeEncoder.create().encode(spec.text)
    except cv2.error as exc:
        img = None
        n = len(spec.text.encode("utf-8"))
        if "capacity" in str(exc):
            raise InputError(
                f"marker qr: the text is too long for a QR code ({len(spec.text)} characters, "
                f"{n} bytes): a QR code holds at most {QR_CAPACITY['digits']} digits, "
                f"{QR_CAPACITY['alphanumeric']} characters of 0-9 A-Z space $%*+-./:, or "
                f"{QR_CAPACITY['bytes']} bytes of other text") from None
    if img is None or img.size == 0:
        raise InputError(f"marker {spec}: OpenCV cannot encode that text as a QR code")
    dark = img < 128
    img = img[np.any(dark, axis=1)][:, np.any(dark, axis=0)]
    return np.where(img > 127, 255, 0).astype(np.uint8)


def printable_marker(spec: MarkerSpec, size_m: float, dpi: float = 300.0) -> np.ndarray:
    """(H, W) uint8 page: the pattern whose printed side is ``size_m`` metres at ``dpi``
    (each cell a whole number of dots, so the side is within one cell's rounding of the
    request; the caption gives the side as printed), a white quiet zone (ArUco: one cell;
    QR: four modules, as ISO/IEC 18004 asks) and a caption naming the marker and its size."""
    check_marker_size(size_m, "--size")
    if not (math.isfinite(dpi) and 50 <= dpi <= 2400):
        raise InputError(f"--dpi {dpi:g}: expected 50-2400 dots per inch")
    cells = marker_cells(spec)
    n = cells.shape[0]
    px = max(1, round(size_m * 1000 / MM_PER_INCH * dpi / n))
    pattern = cv2.resize(cells, (n * px, n * px), interpolation=cv2.INTER_NEAREST)
    quiet = (1 if spec.kind == "aruco" else 4) * px
    page = cv2.copyMakeBorder(pattern, quiet, quiet, quiet, quiet, cv2.BORDER_CONSTANT, value=255)
    side_mm = n * px / dpi * MM_PER_INCH
    caption = f"{spec}  side {side_mm:.1f} mm (black square edge to edge) at {dpi:g} dpi"
    scale = max(0.4, page.shape[1] / 2400)
    (tw, th), base = cv2.getTextSize(caption, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    if tw > page.shape[1] - 8:
        scale *= (page.shape[1] - 8) / tw
        (tw, th), base = cv2.getTextSize(caption, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
    band = np.full((th + base + 2 * max(4, quiet // 2), page.shape[1]), 255, np.uint8)
    cv2.putText(band, caption, (4, band.shape[0] - base - max(4, quiet // 2)),
                cv2.FONT_HERSHEY_SIMPLEX, scale, 0, max(1, int(scale)), cv2.LINE_AA)
    return np.vstack([page, band])


def printed_side_m(spec: MarkerSpec, size_m: float, dpi: float = 300.0) -> float:
    """The side, metres, that :func:`printable_marker` prints for a requested ``size_m``."""
    n = marker_cells(spec).shape[0]
    return n * max(1, round(size_m * 1000 / MM_PER_INCH * dpi / n)) / dpi * MM_PER_INCH / 1000
