"""Printed registration markers in a pinhole view: which marker, where its corners are.

Detection is OpenCV's own (``cv2.aruco.ArucoDetector``, ``cv2.QRCodeDetector``); this
module only names the marker (:class:`MarkerSpec`, parsed from ``aruco:DICT_4X4_50:7`` or
``qr[:TEXT]``), keeps the detections of that marker, and refines their corners on every
pixel of the marker with :func:`cv2.findTransformECC`: the marker's known pattern (its cell
grid) is aligned to the view by a homography, which uses all the edges, not four corner
neighbourhoods. No I/O.

Corners are in OpenCV's order and pixel convention (integer coordinates at pixel centres):
the marker's top-left, top-right, bottom-right, bottom-left as printed. Its frame, as
OpenCV's ArUco defines it: origin at the centre, +x toward the printed right, +y toward the
printed top, +z out of the printed face; corner i sits at ``OBJECT_CORNERS[i] · size``.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

import cv2
import numpy as np

from ..errors import InputError

#: The corners in the marker's own frame for a marker of side 1 (OpenCV ArUco's order).
OBJECT_CORNERS = np.array([[-0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.5, -0.5, 0.0],
                           [-0.5, -0.5, 0.0]])

#: The side of a printed marker, metres: what ``shlight marker`` prints and what a pose is
#: measured from (a side of 1e300 m makes the pose's solve fail, 1e-9 m gives a pose at 0).
MARKER_SIZE_M = (0.005, 5.0)


def check_marker_size(size, what: str = "marker size") -> float:
    """``size`` (metres) as a float, or :class:`InputError` naming ``what`` (e.g.
    ``--marker-size``) when it is not a number within :data:`MARKER_SIZE_M`."""
    try:
        value = float(size)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number of metres, got {size!r}") from None
    lo, hi = MARKER_SIZE_M
    if not lo <= value <= hi:          # NaN fails too
        raise InputError(f"{what} {value:g}: a printed marker is {lo:g}-{hi:g} m on a side")
    return value


ARUCO_DICTIONARIES = tuple(n for n in dir(cv2.aruco) if n.startswith("DICT_")
                           and not re.search(r"[a-z]", n))


@dataclass(frozen=True)
class MarkerSpec:
    """Which printed marker: ``kind`` "aruco" (with ``dictionary`` and, optionally,
    ``marker_id``) or "qr" (with, optionally, the ``text`` it encodes)."""

    kind: str
    dictionary: str | None = None
    marker_id: int | None = None
    text: str | None = None

    def __str__(self):
        if self.kind == "qr":
            return "qr" + (f":{self.text}" if self.text is not None else "")
        return f"aruco:{self.dictionary}" + (f":{self.marker_id}" if self.marker_id is not None else "")

    def aruco_dictionary(self):
        return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))

    def grid(self, marker_id=None) -> np.ndarray:
        """The printed pattern, one pixel per cell, black border included (0 black, 255
        white); an ArUco marker's only (a QR code's comes from its detection)."""
        d = self.aruco_dictionary()
        cells = d.markerSize + 2
        mid = self.marker_id if marker_id is None else marker_id
        return cv2.aruco.generateImageMarker(d, int(mid), cells, borderBits=1)


def parse_marker(text: str) -> MarkerSpec:
    """``aruco:DICT_4X4_50:7`` (dictionary and id; ``aruco:DICT_4X4_50``: any id of it),
    ``qr`` (any QR code) or ``qr:TEXT`` (the one that encodes TEXT). InputError otherwise."""
    text = str(text).strip()
    kind, _, rest = text.partition(":")
    kind = kind.lower()
    if kind == "qr":
        return MarkerSpec("qr", text=rest or None)
    if kind != "aruco":
        raise InputError(f"marker {text!r}: expected aruco:DICT_4X4_50:ID or qr[:TEXT]")
    name, _, mid = rest.partition(":")
    name = name.upper()
    if name and not name.startswith("DICT_"):
        name = "DICT_" + name
    if name not in ARUCO_DICTIONARIES:
        raise InputError(f"marker {text!r}: unknown ArUco dictionary {name or '(none)'!r}; "
                         f"e.g. DICT_4X4_50, DICT_6X6_250, DICT_APRILTAG_36H11")
    marker_id = None
    if mid:
        try:
            marker_id = int(mid)
        except ValueError:
            raise InputError(f"marker {text!r}: the id must be a whole number") from None
        size = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name)).bytesList.shape[0]
        if not 0 <= marker_id < size:
            raise InputError(f"marker {text!r}: {name} has ids 0-{size - 1}")
    return MarkerSpec("aruco", dictionary=name, marker_id=marker_id)


@dataclass
class Detection:
    """One marker found in a view: its id (ArUco) or text (QR), corners (4, 2) in view
    pixels, and its cell grid (0 black, 255 white, border included)."""

    marker_id: int | str | None
    corners: np.ndarray
    grid: np.ndarray


def _aruco_detector(spec: MarkerSpec, refine: bool):
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = (cv2.aruco.CORNER_REFINE_SUBPIX if refine
                                     else cv2.aruco.CORNER_REFINE_NONE)
    return cv2.aruco.ArucoDetector(spec.aruco_dictionary(), params)


def detect(gray: np.ndarray, spec: MarkerSpec, refine: bool = False,
           decode: bool = True) -> list[Detection]:
    """The detections of ``spec`` in an 8-bit grey view. ``decode=False``: QR codes are only
    located (their id and grid None), where they may be too small to read."""
    out = []
    if spec.kind == "aruco":
        corners, ids, _ = _aruco_detector(spec, refine).detectMarkers(gray)
        for c, i in zip(corners, [] if ids is None else ids.ravel()):
            if spec.marker_id is None or int(i) == spec.marker_id:
                out.append(Detection(int(i), np.asarray(c, np.float64).reshape(4, 2),
                                     spec.grid(int(i))))
        return out
    if not decode:        # the ArUco-based finder-pattern search finds smaller codes
        try:
            ok, points = cv2.QRCodeDetectorAruco().detectMulti(gray)
        except cv2.error:
            ok = False
        return [Detection(None, np.asarray(p, np.float64).reshape(4, 2), None)
                for p in (points if ok and points is not None else [])]
    for qr in (cv2.QRCodeDetector(), cv2.QRCodeDetectorAruco()):
        try:
            ok, texts, points, straight = qr.detectAndDecodeMulti(gray)
        except cv2.error:
            ok = False
        if not ok or points is None:
            continue
        straight = straight if straight is not None else [None] * len(texts)
        for text, pts, grid in zip(texts, points, straight):
            if not text or grid is None or (spec.text is not None and text != spec.text):
                continue
            grid = np.where(np.asarray(grid) > 127, 255, 0).astype(np.uint8)
            out.append(Detection(text, np.asarray(pts, np.float64).reshape(4, 2), grid))
        if out:
            break
    return out


def refine_corners(view: np.ndarray, detection: Detection, blur_px: float = 1.0,
                   iterations: int = 100) -> np.ndarray | None:
    """The detection's corners aligned on every pixel of the marker: the pattern (cell grid
    with half a cell of white around it) warped to the view by the homography that
    maximises their correlation (:func:`cv2.findTransformECC`, gain and offset free). None
    if the alignment does not converge (then keep the detector's corners).

    ``view`` is float32 grey, linear in light, so that an edge blurred by the lens and the
    resampling is symmetric about its true position; ``blur_px`` is that blur's standard
    deviation in view pixels."""
    grid = detection.grid
    cells = grid.shape[0]
    side = float(np.mean(np.linalg.norm(np.roll(detection.corners, -1, 0) - detection.corners, axis=1)))
    k = int(np.clip(round(side / cells), 4, 24))          # template pixels per cell
    margin = k // 2
    pattern = cv2.resize(grid, (cells * k, cells * k), interpolation=cv2.INTER_NEAREST)
    template = cv2.copyMakeBorder(pattern, margin, margin, margin, margin,
                                  cv2.BORDER_CONSTANT, value=255).astype(np.float32)
    # The view is blurred (lens, panorama pixels, resampling): blur the sharp pattern alike.
    template = cv2.GaussianBlur(template, (0, 0), max(0.5, blur_px * cells * k / max(side, 1.0)))
    lo, hi = margin - 0.5, margin + cells * k - 0.5
    t_corners = np.array([[lo, lo], [hi, lo], [hi, hi], [lo, hi]], np.float32)
    warp = cv2.getPerspectiveTransform(t_corners, detection.corners.astype(np.float32))
    warp = (warp / warp[2, 2]).astype(np.float32)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, iterations, 1e-6)
    try:
        _, warp = cv2.findTransformECC(template, np.ascontiguousarray(view, np.float32), warp,
                                       cv2.MOTION_HOMOGRAPHY, criteria, None, 3)
    except cv2.error:
        return None
    pts = cv2.perspectiveTransform(t_corners.reshape(-1, 1, 2).astype(np.float64),
                                   warp.astype(np.float64)).reshape(4, 2)
    if not np.all(np.isfinite(pts)) or np.max(np.abs(pts - detection.corners)) > 0.25 * side:
        return None
    return pts
