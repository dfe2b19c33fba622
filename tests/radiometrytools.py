"""Shared by the live radiometry tests (the fake cameras' panoramas, the messages they
wait for)."""
import cv2
import numpy as np

from conftest import load_hdri


def small(name, size=(128, 64)):
    """A bundled panorama, negatives clipped, area-resized to ``size`` (a fake camera's scene)."""
    return cv2.resize(np.maximum(load_hdri(name), 0), size, interpolation=cv2.INTER_AREA)


def sh9(msg):
    """A fresh (not stale) sh9 message."""
    return msg.get("type") == "sh9" and not msg.get("stale")
