"""camera.json: a camera's inverse response on disk (``shlight calibrate-response`` writes
it; ``shlight compute --camera`` and ``shlight serve --camera`` read it).

The content is :meth:`provider.core.radiometry.response.CameraResponse.to_dict` (format
``shlight-camera-response``, version 1: the method, the bit depth, the mid-grey anchor, the
calibration's exposure times and parameters, and the table per channel as flat lists);
the maths validates it. This module only reads and writes the file.
"""
from __future__ import annotations

import json
import os

from ...core.errors import InputError
from ...core.radiometry.response import CameraResponse, ResponseError


def load_camera(path) -> CameraResponse:
    """The response in ``path``; one clear :class:`InputError` for a missing, unreadable,
    non-JSON, corrupt or non-monotone file."""
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except FileNotFoundError:
        raise InputError(f"no such camera file: {path} (make one with shlight "
                         "calibrate-response)") from None
    except UnicodeDecodeError:
        raise InputError(f"cannot read camera file {path}: not a text file (a camera.json "
                         "written by shlight calibrate-response is JSON)") from None
    except OSError as exc:
        raise InputError(f"cannot read camera file {path}: {exc.strerror or exc}") from None
    try:
        data = json.loads(text)
    except ValueError as exc:
        raise InputError(f"camera file {path} is not JSON: {exc}") from None
    try:
        return CameraResponse.from_dict(data)
    except ResponseError as exc:
        raise ResponseError(f"camera file {path}: {exc}") from None


def save_camera(response: CameraResponse, path) -> None:
    """Write ``response`` as camera.json (indented, no NaN)."""
    path = os.fspath(path)
    text = json.dumps(response.to_dict(), indent=1, allow_nan=False)
    try:
        with open(path, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    except OSError as exc:
        raise InputError(f"cannot write {path}: {exc}") from None
