"""A Ricoh Theta over Wi-Fi: the Open Spherical Camera live preview (docs/contract.md §8)."""
from __future__ import annotations

import json
import logging
import threading
import time
import urllib.error
import urllib.parse
import urllib.request

from ...core.errors import InputError
from .base import (USER_AGENT, Frame, Source, SourceError, SourceOptions, printable, redact,
                   split_credentials)
from .http import MultipartJpegReader, http_opener
from .theta_exposure import ThetaExposure

log = logging.getLogger("shlight.source")

#: Times each camera (its base URL) had its settings applied in this process: a later open is
#: a reconnection (the camera slept, was power-cycled, or the Wi-Fi dropped).
_APPLIED: dict = {}
_APPLIED_LOCK = threading.Lock()
#: OSC errors that say a setting is wrong (logged, the stream goes on) rather than the API.
_BAD_SETTING = ("invalidParameterValue", "invalidParameterName")


class OscCommandError(SourceError):
    """An Open Spherical Camera command answered with an error."""

    def __init__(self, command: str, code: str, message: str):
        # the camera's words, fit for one log line (no newlines or control characters)
        code, message = printable(code, 80), printable(message)
        super().__init__(f"{command}: {code}: {message}")
        self.code = code


def theta_url(url: str) -> urllib.parse.SplitResult:
    """The parts of a ``theta://[USER:PASSWORD@]HOST[:PORT]`` URL (serve's source,
    register's still); InputError in one line for one that names no host or a bad one
    (an unclosed IPv6 bracket, a port beyond 65535). The URL is not echoed: it may hold a
    password."""
    scheme = url.partition("://")[0]
    try:
        parts = urllib.parse.urlsplit(url)
        parts.port                                  # noqa: B018 - raises on a bad port
    except ValueError as exc:
        raise InputError(f"{scheme}:// URL: {exc} (e.g. {scheme}://192.168.1.1, "
                         f"{scheme}://[::1])") from None
    if not parts.hostname:
        raise InputError(f"theta source needs a host, e.g. theta://192.168.1.1: "
                         f"{redact(url)}")
    return parts


class ThetaSource(Source):
    """A Ricoh Theta over Wi-Fi: the Open Spherical Camera live preview (docs/contract.md §8).

    Every command is ``POST /osc/commands/execute`` with ``{"name", "parameters"}``. API
    2.1 (Theta V/Z1, and an S switched to 2.1): ``camera.getLivePreview``. API 2.0 (the
    Theta S default): ``camera.startSession`` gives a ``sessionId``, then
    ``camera._getLivePreview {sessionId}``. ``api="auto"`` tries 2.1 and falls back to
    2.0 when the camera rejects the command. The reply is an endless MJPEG multipart body
    of equirect frames (S/SC: 640×320 at 10 fps). In client mode the camera asks for
    HTTP Digest auth: give ``theta://USER:PASSWORD@HOST``. Exposure (reported in manual
    mode, brackets through ``camera.setOptions``): :mod:`.theta_exposure`.
    """

    EXECUTE = "/osc/commands/execute"

    def __init__(self, url: str, options: SourceOptions):
        super().__init__()
        parts = theta_url(url)
        query = urllib.parse.parse_qs(parts.query)
        self.api = query.get("api", [options.theta_api])[0]
        if self.api not in ("auto", "2.0", "2.1"):
            raise InputError(f"theta source: api must be 2.0, 2.1 or auto, got {self.api!r}")
        scheme = "https" if parts.scheme.endswith("s") and parts.scheme != "theta" else "http"
        base = urllib.parse.urlunsplit((scheme, parts.netloc, "", "", ""))
        self.base, user, password = split_credentials(base)
        self.options = options
        self._open = http_opener(self.base, user, password).open
        self._resp, self._reader, self._session = None, None, None
        self.api_used = None
        self.exposure = ThetaExposure(self)
        #: What /healthz shows of the camera: its settings, when they were (re)applied, its
        #: battery and temperature when OSC's /osc/state reports them.
        self.settings = dict(options.theta_settings or ())
        self.status: dict = {}
        self._next_check = 0.0

    def _execute(self, name: str, parameters: dict, *, stream: bool = False,
                 timeout: float | None = None):
        body = json.dumps({"name": name, "parameters": parameters}).encode()
        req = urllib.request.Request(self.base + self.EXECUTE, data=body, method="POST", headers={
            "Content-Type": "application/json;charset=utf-8", "Accept": "*/*",
            "X-XSRF-Protected": "1", "User-Agent": USER_AGENT})
        try:
            resp = self._open(req, timeout=timeout or self.options.timeout)
        except urllib.error.HTTPError as exc:
            if exc.code == 401:  # client mode: Digest auth refused or not given
                raise SourceError(
                    f"{self.base}: the camera refused the credentials (HTTP 401); in client "
                    "mode give theta://USER:PASSWORD@HOST (user: the serial number, e.g. "
                    "THETAYL00100001; password: its digits)") from None
            try:
                err = json.loads(exc.read(4096) or b"{}").get("error") or {}
            except ValueError:
                err = {}
            raise OscCommandError(name, str(err.get("code", f"HTTP {exc.code}")),
                                  str(err.get("message", exc.reason))) from None
        except urllib.error.URLError as exc:
            raise SourceError(f"{self.base}: {exc.reason}") from None
        if stream:
            return resp
        with resp:
            try:
                reply = json.loads(resp.read(1 << 20))
            except ValueError:
                raise SourceError(f"{name}: the camera's answer is not JSON") from None
        if reply.get("state") == "error":
            err = reply.get("error") or {}
            raise OscCommandError(name, str(err.get("code")), str(err.get("message")))
        return reply

    def _preview(self, resp) -> None:
        ctype = resp.headers.get_content_type()
        if not ctype.startswith("multipart/"):
            resp.close()
            raise SourceError(f"live preview answered {ctype}, not multipart MJPEG")
        self._resp, self._reader = resp, MultipartJpegReader(resp)

    def open(self) -> None:
        self._open_preview()
        self.exposure.setup()

    def _open_preview(self) -> None:
        if self.api in ("auto", "2.1"):
            try:
                self._apply_settings()
                self._preview(self._execute("camera.getLivePreview", {}, stream=True))
                self.api_used = "2.1"
                return
            except OscCommandError as exc:
                if self.api == "2.1":
                    raise
                log.debug("%s: getLivePreview refused (%s); trying API 2.0", self.base, exc)
        reply = self._execute("camera.startSession", {})
        self._session = (reply.get("results") or {}).get("sessionId")
        if not self._session:
            raise SourceError("camera.startSession gave no sessionId")
        self._apply_settings()
        self._preview(self._execute("camera._getLivePreview", {"sessionId": self._session},
                                    stream=True))
        self.api_used = "2.0"

    def read(self) -> Frame:
        if time.monotonic() >= self._next_check:
            self._next_check = time.monotonic() + self.options.theta_check_s
            self._check()
        return self.exposure.read()

    # -- the camera's settings and state (issue 32) ------------------------------------------
    def _apply_settings(self, why: str = "", lost: bool = False) -> None:
        """``camera.setOptions`` with the settings asked for (before the preview starts, so
        that previewFormat holds); says in the log whether this is a re-application.
        ``lost``: the check found them lost; counted in the same update as the reason, so
        that /healthz (read from another thread) never shows the count without its why."""
        if not self.settings:
            return
        try:
            self.exposure._set(dict(self.settings))
        except OscCommandError as exc:
            if exc.code not in _BAD_SETTING:
                raise                   # the API itself (e.g. 2.0 wants a session): not here
            log.warning("%s: the Theta refused its settings %s (%s): left as they are",
                        self.base, self._shown(), exc)
            update = {"settings_error": str(exc)}
            if lost:
                update["settings_lost"] = self.status.get("settings_lost", 0) + 1
            self.status.update(update)
            return
        with _APPLIED_LOCK:
            n = _APPLIED[self.base] = _APPLIED.get(self.base, 0) + 1
        why = why or ("after a reconnection (sleep, power cycle or Wi-Fi)" if n > 1 else "")
        log.info("%s: %s Theta settings %s%s", self.base, "re-applied" if n > 1 else "applied",
                 self._shown(), f" {why}" if why else "")
        update = dict(settings=dict(self.settings), settings_applied=n,
                      settings_applied_at=round(time.time(), 3),
                      settings_reason=why or "first connection")
        if lost:
            update["settings_lost"] = self.status.get("settings_lost", 0) + 1
        self.status.update(update)   # one update: a reader sees all of it or none
        self.status.pop("settings_error", None)

    def _shown(self) -> str:
        return ", ".join(f"{k}={json.dumps(v)}" for k, v in self.settings.items())

    def _check(self) -> None:
        """Battery and temperature from ``/osc/state``; the settings from getOptions, set
        again where the camera lost them (it slept or was power-cycled without the stream
        dropping). A camera that answers neither is left alone."""
        try:
            state = self._state()
        except SourceError as exc:
            log.debug("%s: /osc/state: %s", self.base, exc)
            state = {}
        for key, name in (("batteryLevel", "battery_level"), ("_batteryState", "battery_state"),
                          ("_cameraTemperature", "temperature_c"), ("_boardTemp", "temperature_c"),
                          ("_batteryTemp", "battery_temperature_c")):
            if key in state and isinstance(state[key], (int, float, str)):
                self.status[name] = state[key]
        if not self.settings:
            return
        try:
            reply = self._execute("camera.getOptions", self.exposure._params(
                optionNames=sorted(self.settings)))
        except SourceError as exc:
            log.debug("%s: camera.getOptions: %s", self.base, exc)
            return
        now = (reply.get("results") or {}).get("options") or {}
        lost = {k: now.get(k) for k, v in self.settings.items() if now.get(k) != v}
        if lost:
            self._apply_settings("after the camera lost them (" + ", ".join(
                f"{k} was {json.dumps(v)}" for k, v in lost.items()) + "; it slept or was "
                "power-cycled)", lost=True)

    def _state(self) -> dict:
        req = urllib.request.Request(self.base + "/osc/state", data=b"", method="POST", headers={
            "Content-Type": "application/json;charset=utf-8", "Accept": "application/json",
            "X-XSRF-Protected": "1", "User-Agent": USER_AGENT})
        try:
            with self._open(req, timeout=self.options.timeout) as resp:
                reply = json.loads(resp.read(1 << 16))
        except (urllib.error.URLError, OSError, ValueError) as exc:
            raise SourceError(str(exc)) from None
        return (reply.get("state") or {}) if isinstance(reply, dict) else {}

    def health(self) -> dict:
        """The camera's part of /healthz (see ``status``)."""
        return dict(self.status)

    def close(self) -> None:
        self.exposure.close()
        if self._resp is not None:
            self._resp.close()
        if self._session:
            try:  # frees the camera for the next session; the camera may be gone
                self._execute("camera.closeSession", {"sessionId": self._session}, timeout=1.0)
            except Exception:  # noqa: BLE001
                pass
            self._session = None
