"""``FRAME@SECONDS`` arguments (docs/contract.md §9): an image file and its exposure time.

SECONDS is a decimal (``0.004``) or a fraction (``1/250``); a JPEG or TIFF still whose EXIF
says its ExposureTime needs none (its FNumber and ISO come with it: docs/photometry.md). Only a trailing ``@`` followed
by something made of digits, dots, signs and one slash is read as a time, and a file that
exists under the literal name wins, so a path that itself contains ``@`` still works.
"""
from __future__ import annotations

import os
import re

from ..core.errors import InputError
from ..core.radiometry.response import parse_seconds

_TIMEISH = re.compile(r"[\s\d.+\-eE]*(/[\s\d.+\-eE]*)?")


def parse_frame(text: str) -> tuple[str, float | None]:
    """(path, seconds or None) of one ``FRAME[@SECONDS]`` argument."""
    path, sep, tail = text.rpartition("@")
    if not sep or os.path.exists(text) or not _TIMEISH.fullmatch(tail):
        return text, None
    if not path:
        raise InputError(f"{text}: no image before '@'")
    if not tail.strip():
        raise InputError(f"{text}: missing exposure time after '@' (e.g. {path}@1/60)")
    try:
        return path, parse_seconds(tail)
    except InputError as exc:
        raise InputError(f"{text}: {exc}") from None


def read_frames(texts, *, need_times: bool, max_pixels: int = 0):
    """Images and times of ``FRAME@SECONDS`` arguments; with ``need_times`` every frame
    must have its time (merging, calibrating), from ``@SECONDS`` or its EXIF.
    ``max_pixels`` (pixels, 0: none): an image whose header declares more is refused
    (InputError) before it is decoded."""
    images, exposures, paths = read_exposed_frames(texts, need_times=need_times,
                                                   max_pixels=max_pixels)
    return images, [e.exposure_s for e in exposures], paths


def read_exposed_frames(texts, *, need_times: bool, max_pixels: int = 0,
                        command: str | None = None):
    """Images, what each says of its exposure (:class:`~provider.core.radiometry.exif.
    StillExposure`: ``@SECONDS`` wins over EXIF ExposureTime; f-number and ISO from EXIF)
    and paths of ``FRAME[@SECONDS]`` arguments. An EXIF number no camera records is not
    used: ``command`` (its name) says so on stderr, one warning per value."""
    from ..core.radiometry.exif import StillExposure, read_still_exposure
    from ..core.radiometry.images import read_image
    from .feedback import say
    items = [parse_frame(t) for t in texts]
    for p, _ in items:
        if "@" in p and not os.path.exists(p):
            raise InputError(f"no such file: {p} (an exposure time after '@' is a decimal or "
                             "a fraction such as 1/60)")
    exposures, why = [], {}
    for p, t in items:
        e = read_still_exposure(p)
        exposures.append(StillExposure(t or e.exposure_s, e.f_number, e.iso,
                                       e.exposure_bias_ev))
        refused = [r for r in e.refused if not (t and r.startswith("EXIF ExposureTime"))]
        if refused:
            why[p] = refused
    if need_times:
        missing = [p for (p, _), e in zip(items, exposures) if e.exposure_s is None]
        if missing:
            first = f" ({why[missing[0]][0]})" if missing[0] in why else ""
            raise InputError(f"every frame needs its exposure time as FRAME@SECONDS (e.g. "
                             f"{missing[0]}@1/60) or in its EXIF (ExposureTime); missing "
                             f"for: {', '.join(missing)}{first}")
    for p, lines in why.items() if command else ():
        for line in lines:
            say(command, "warning", f"{p}: {line}")
    return ([read_image(p, max_pixels) for p, _ in items], exposures, [p for p, _ in items])
