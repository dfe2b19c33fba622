"""A picture of a camera's inverse response beside sRGB (OpenCV drawing only, so that
``shlight calibrate-response`` works on a Raspberry Pi without matplotlib)."""
from __future__ import annotations

import math

import cv2
import numpy as np

from ..core.radiometry.response import CameraResponse

W, H = 800, 560
LEFT, RIGHT, TOP, BOTTOM = 80, 30, 50, 60
COLOURS = {"r": (40, 40, 220), "g": (40, 170, 40), "b": (220, 90, 30), "sRGB": (0, 0, 0)}


def plot_response(response: CameraResponse, path: str) -> None:
    """Write a PNG: g(code) per channel on a log scale, with sRGB dashed (both anchored at
    mid-grey 0.18 at code 118)."""
    r8 = response.to_bits(8)
    srgb = CameraResponse.srgb().table[:, 0]
    z = np.arange(1, 256)
    curves = {c: r8.table[1:, i] for i, c in enumerate("rgb")}
    values = np.concatenate([v for v in curves.values()] + [srgb[1:]])
    lo = math.floor(math.log10(max(values[values > 0].min(), 1e-6)))
    hi = math.ceil(math.log10(values.max()))
    img = np.full((H, W, 3), 255, np.uint8)
    pw, ph = W - LEFT - RIGHT, H - TOP - BOTTOM

    def xy(code, v):
        y = (math.log10(max(v, 10.0 ** lo)) - lo) / (hi - lo)
        return int(LEFT + code / 255 * pw), int(TOP + (1 - y) * ph)

    font = cv2.FONT_HERSHEY_SIMPLEX
    for d in range(lo, hi + 1):                       # decades
        _, y = xy(0, 10.0 ** d)
        cv2.line(img, (LEFT, y), (LEFT + pw, y), (225, 225, 225), 1)
        cv2.putText(img, f"1e{d}", (8, y + 5), font, 0.45, (60, 60, 60), 1, cv2.LINE_AA)
    for code in range(0, 256, 32):
        x, _ = xy(code, 1)
        cv2.line(img, (x, TOP), (x, TOP + ph), (235, 235, 235), 1)
        cv2.putText(img, str(code), (x - 10, TOP + ph + 20), font, 0.45, (60, 60, 60), 1,
                    cv2.LINE_AA)
    cv2.rectangle(img, (LEFT, TOP), (LEFT + pw, TOP + ph), (0, 0, 0), 1)
    pts = np.array([xy(c, v) for c, v in zip(z, srgb[1:])], np.int32)
    for i in range(0, len(pts) - 1, 2):               # dashed sRGB
        cv2.line(img, tuple(pts[i]), tuple(pts[i + 1]), COLOURS["sRGB"], 1, cv2.LINE_AA)
    for c, v in curves.items():
        pts = np.array([xy(code, val) for code, val in zip(z, v)], np.int32)
        cv2.polylines(img, [pts], False, COLOURS[c], 2, cv2.LINE_AA)
    x, y = xy(118, 0.18)
    cv2.circle(img, (x, y), 4, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, f"inverse camera response ({response.method}) against sRGB (dashed)",
                (LEFT, 30), font, 0.6, (0, 0, 0), 1, cv2.LINE_AA)
    cv2.putText(img, "code value", (LEFT + pw // 2 - 40, H - 15), font, 0.5, (0, 0, 0), 1,
                cv2.LINE_AA)
    cv2.putText(img, "exposure (mid-grey 0.18 at code 118)", (LEFT + 10, TOP + 20), font, 0.45,
                (60, 60, 60), 1, cv2.LINE_AA)
    for i, c in enumerate(("r", "g", "b", "sRGB")):
        cv2.putText(img, c, (LEFT + pw - 60, TOP + ph - 80 + 18 * i), font, 0.5, COLOURS[c],
                    2 if c != "sRGB" else 1, cv2.LINE_AA)
    if not cv2.imwrite(path, img):
        from ..core.errors import InputError
        raise InputError(f"cannot write {path}")
