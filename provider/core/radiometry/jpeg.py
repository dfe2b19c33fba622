"""Decoding JPEG bytes into the engine's frame contract (RGB uint8), with the decoder's own
words returned to the caller instead of printed.

libjpeg, as OpenCV builds it, prints "Corrupt JPEG data: ..." straight to file descriptor 2
for every damaged frame; capturing that meant pointing descriptor 2 elsewhere around each
decode, process-wide, one decode at a time (issue 41). ``simplejpeg`` (libjpeg-turbo's
TurboJPEG API, bundled in its wheels) keeps the decoder's message in its handle and raises
it as an exception, and decodes with the GIL released, so that decodes of several cameras
run side by side. OpenCV decodes only where ``simplejpeg`` is not installed.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError

try:
    import simplejpeg
except ImportError:     # a declared dependency; OpenCV (which prints its warnings) otherwise
    simplejpeg = None


def decode_jpeg(data: bytes, what: str) -> tuple[np.ndarray, str | None]:
    """Decode a JPEG.

    Parameters
    ----------
    data : bytes
        The JPEG's bytes (its size already checked against the budget by the caller).
    what : str
        What it is, for the error (e.g. ``"corrupt JPEG frame (812 bytes)"``).

    Returns
    -------
    (numpy.ndarray, str or None)
        The (H, W, 3) RGB uint8 image, and what the decoder said of a frame it could decode
        only by repairing it (e.g. "Corrupt JPEG data: premature end of data segment": the
        rest of the picture grey, as libjpeg has always done), else None.

    Raises
    ------
    InputError
        ``what``, for bytes that do not decode (the decoder's words after a colon).
    """
    if simplejpeg is None:
        return _decode_opencv(data, what), None
    try:
        return simplejpeg.decode_jpeg(data, "RGB", strict=True), None
    except ValueError as exc:       # a warning (the data repaired) or an error (none)
        said = " ".join(str(exc).split())
    try:
        # strict=False: what libjpeg itself does with a damaged scan (decode what it can)
        return simplejpeg.decode_jpeg(data, "RGB", strict=False), said
    except ValueError:              # a damaged header or tables: nothing to decode
        raise InputError(f"{what}: {said[:200]}") from None


def _decode_opencv(data: bytes, what: str) -> np.ndarray:
    import cv2
    try:
        bgr = cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_COLOR)
    except cv2.error:       # a header declaring more than OpenCV decodes
        bgr = None
    if bgr is None:
        raise InputError(what)
    return cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
