"""Live registration (docs/contract.md §13): the marker re-measured off the hot path, and a
full-resolution still from a Ricoh Theta for ``shlight register theta://HOST``.

A :class:`Registrar` belongs to one probe. The probe offers it every projected frame
(:meth:`Registrar.offer`, cheap: a time check); every ``every_s`` seconds one frame goes to a
single worker thread of its own (never the event loop, never the capture or projection
threads) that runs :func:`~provider.core.registration.pose.find_marker`. Consecutive measurements
that agree (within :data:`AGREE_DEG` and :data:`AGREE_M`) are averaged, up to
:data:`AVERAGE_FRAMES`; one that disagrees starts a new average (the camera was bumped). The
probe puts :meth:`Registrar.fields` in each message as ``registration`` once known.
"""
from __future__ import annotations

import json
import logging
import math
import os
import tempfile
import threading
import time
import urllib.request
from concurrent.futures import ThreadPoolExecutor

import numpy as np

from ...core.errors import InputError
from ...core.registration.pose import MarkerNotFound, average_poses, find_marker

log = logging.getLogger("shlight.registration")

#: Measurements averaged at most (the newest ones that agree).
AVERAGE_FRAMES = 8
#: Two measurements of an unmoved marker agree within these (rotation degrees, metres).
AGREE_DEG = 2.0
AGREE_M = 0.03


def _angle_deg(a, b) -> float:
    return math.degrees(math.acos(np.clip((np.trace(a.T @ b) - 1) / 2, -1, 1)))


class Registrar:
    """Re-detects ``marker`` (side ``marker_size`` m) every ``every_s`` seconds in frames of
    ``projection`` (with its engine options); thread-safe."""

    def __init__(self, marker, marker_size: float, projection: str = "equirect",
                 projection_options: dict | None = None, every_s: float = 5.0, name="default"):
        from ...core.registration.marker_detect import check_marker_size, parse_marker
        self.spec = parse_marker(marker) if isinstance(marker, str) else marker
        marker_size = check_marker_size(marker_size, "--marker-size")
        if not (math.isfinite(every_s) and every_s > 0):
            raise InputError(f"--register-every {every_s:g}: seconds between detections (> 0)")
        self.size, self.every_s, self.name = float(marker_size), float(every_s), name
        self.projection, self.options = projection, dict(projection_options or {})
        self._pool = ThreadPoolExecutor(1, thread_name_prefix=f"register-{name}",
                                        initializer=_lower_priority)
        self._lock = threading.Lock()
        self._busy = False
        self._last_try = -math.inf
        self._recent = []          # agreeing poses, oldest first
        self._pose = None          # their average
        self._measured_at = 0.0    # unix time of the newest frame measured
        self.attempts = self.misses = 0
        self.missing = 0           # misses in a row since the marker was last found
        self._said_missing = False

    def offer(self, frame, now: float | None = None) -> bool:
        """Hand a frame over if a detection is due and none is running (returns whether)."""
        now = time.monotonic() if now is None else now
        with self._lock:
            if self._busy or now - self._last_try < self.every_s:
                return False
            self._busy, self._last_try = True, now
        self._pool.submit(self._measure, frame)
        return True

    def _measure(self, frame) -> None:
        try:
            image = frame.decoded()
            hint = self._pose.direction if self._pose is not None else None
            pose = find_marker(image, self.spec, self.size, self.projection, hint=hint,
                               **self.options)
        except MarkerNotFound:
            with self._lock:
                self.attempts += 1
                self.misses += 1
                self.missing += 1
                say = not self._said_missing
                self._said_missing = True
            if say:     # once per streak: the first miss, then nothing until it is found
                log.warning("probe %s: marker %s not found in the frame (looked again every "
                            "%g s; /healthz 'registration' counts the misses): is it in view, "
                            "and are --marker and --projection right?", self.name, self.spec,
                            self.every_s)
            return
        except Exception as exc:  # noqa: BLE001 - a bad frame must not stop registration
            log.warning("probe %s: registration failed on a frame: %s", self.name, exc)
            with self._lock:
                self.attempts += 1
            return
        finally:
            with self._lock:
                self._busy = False
        self.add(pose, frame.time)

    def add(self, pose, frame_time: float) -> None:
        """Fold one measurement in: averaged with the agreeing ones before it, or the start
        of a new average when it disagrees (the camera or the marker moved)."""
        with self._lock:
            self.attempts += 1
            if self._said_missing:
                log.info("probe %s: marker found again after %d miss(es)", self.name,
                         self.missing)
            self.missing, self._said_missing = 0, False
            if self._pose is not None and (
                    _angle_deg(self._pose.rotation, pose.rotation) > AGREE_DEG
                    or np.linalg.norm(self._pose.position - pose.position) > AGREE_M):
                log.warning("probe %s: the marker moved relative to the camera (%.1f°); "
                            "registration restarts", self.name,
                            _angle_deg(self._pose.rotation, pose.rotation))
                self._recent = []
            self._recent = (self._recent + [pose])[-AVERAGE_FRAMES:]
            self._pose = average_poses(self._recent)
            self._measured_at = frame_time

    @property
    def pose(self):
        with self._lock:
            return self._pose

    def fields(self, now: float | None = None) -> dict | None:
        """The wire message's ``registration`` (docs/contract.md §13), None until known."""
        with self._lock:
            pose, at = self._pose, self._measured_at
        if pose is None:
            return None
        now = time.time() if now is None else now
        j = pose.to_json()
        return {"marker": j["marker"], "marker_id": str(j["marker_id"]),
                "rotation": j["rotation"], "position": j["position"],
                "age_s": round(max(now - at, 0.0), 3), "error_deg": j["error_deg"],
                "error_px": j["error_px"], "frames": j["frames"],
                "spread_deg": j["spread_deg"], "levelled": j["levelled"]}

    def health(self, now: float | None = None) -> dict:
        """/healthz's ``registration`` of the probe: tries, misses (in all and in a row) and
        whether a pose is known, and how old its newest measurement is."""
        now = time.time() if now is None else now
        with self._lock:
            return {"marker": str(self.spec), "every_s": self.every_s,
                    "found": self._pose is not None, "attempts": self.attempts,
                    "misses": self.misses, "missing": self.missing,
                    "age_s": round(max(now - self._measured_at, 0.0), 3)
                    if self._pose is not None else None}

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)


def _lower_priority() -> None:
    """Detection yields to SH9 on a busy core, as the cube's thread does (Linux: per-thread
    nice); a 4096×2048 frame's detection otherwise delays the frame's projection."""
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 10)
    except (AttributeError, OSError):
        pass


# -- a still from a Theta ---------------------------------------------------------------------
def theta_still(url: str, timeout: float = 60.0) -> str:
    """Take a full-resolution still with the Theta at ``theta://[USER:PASS@]HOST`` (OSC
    ``camera.takePicture``, polled with ``/osc/commands/status``), download it, and return the
    path of a temporary JPEG (its XMP keeps the camera's pitch and roll)."""
    from ..sources.base import SourceError, SourceOptions
    from ..sources.theta import OscCommandError, ThetaSource
    cam = ThetaSource(url, SourceOptions(timeout=min(timeout, 10.0)))
    try:
        params = {}
        if cam.api == "2.0":
            reply = cam._execute("camera.startSession", {})
            params["sessionId"] = (reply.get("results") or {}).get("sessionId")
        try:
            reply = cam._execute("camera.takePicture", params)
        except OscCommandError as exc:
            raise InputError(f"{url}: camera.takePicture refused: {exc}") from None
        deadline = time.monotonic() + timeout
        while reply.get("state") == "inProgress":
            if time.monotonic() > deadline:
                raise InputError(f"{url}: no picture after {timeout:g} s")
            time.sleep(0.2)
            reply = _status(cam, reply.get("id"))
        results = reply.get("results") or {}
        file_url = results.get("fileUrl") or results.get("fileUri")
        if not file_url:
            raise InputError(f"{url}: the camera gave no picture ({results})")
        if str(file_url).startswith(("http://", "https://")):     # API 2.1
            with cam._open(urllib.request.Request(file_url), timeout=timeout) as resp:
                data = resp.read()
        else:                                                      # API 2.0: a camera path
            with cam._execute("camera.getImage", {"fileUri": file_url}, stream=True,
                              timeout=timeout) as resp:
                data = resp.read()
    except SourceError as exc:
        raise InputError(f"{url}: {exc}") from None
    fd, path = tempfile.mkstemp(prefix="shlight-still-", suffix=".jpg")
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    return path


def _status(cam, command_id) -> dict:
    body = json.dumps({"id": command_id}).encode()
    req = urllib.request.Request(cam.base + "/osc/commands/status", data=body, method="POST",
                                 headers={"Content-Type": "application/json;charset=utf-8"})
    with cam._open(req, timeout=cam.options.timeout) as resp:
        reply = json.loads(resp.read(1 << 20))
    if reply.get("state") == "error":
        raise InputError(f"camera.takePicture: {(reply.get('error') or {}).get('message')}")
    return reply
