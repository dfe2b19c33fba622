"""One light probe: source → frame → coefficients → message.

A :class:`Probe` owns a :class:`~provider.live.probe.capture.Capture` (its source, read in a
thread), the :class:`~provider.core.sh9.engine.SH9Projector` for each frame size it has seen,
the temporal filter, and the probe's latest message. Its :meth:`Probe.run` task waits for
the newest frame, projects it in a worker thread (the engine's one call), and hands the
serialised message to ``publish(probe_name, text)`` when the lighting changed, when a
keep-alive is due, or when the probe goes stale or fresh again.

States: ``starting`` (no lighting yet), ``live``, ``stale`` (the source is lost or silent:
the last lighting is resent with ``"stale": true`` and its ``age_s``).

With ``lights="auto"`` the probe owns a
:class:`~provider.core.lights.tracking.LightTracker` per frame size (hysteresis across
frames: no flicker, no jumping between two lamps), reset when the source reconnects.

Radiometry (docs/contract.md §9): a frame whose source reports its exposure (``Frame.info``
``exposure_s``, ``gain``) is divided by it; a frame of a bracket (``slot``, ``bracket``) goes
to the probe's :class:`~provider.core.sh9.bracket_projection.BracketProjector`, which keeps
one (9, 3) part per slot and returns merged lighting for every frame.

Reflections (``environment``, docs/contract.md §12): the frame of every sh9 message that
carries changed lighting is offered to the probe's
:class:`~provider.live.reflections.cube.EnvironmentWorker` (its own thread, newest frame only, at
most ``hz``); finished cubes go to ``publish_environment(cube)`` on the event loop. The SH9
path never waits for them.
"""
from __future__ import annotations

import asyncio
import collections
import logging
import time
from dataclasses import dataclass

import numpy as np

from ...core.sh9.bracket_projection import BracketProjector
from ...core.sh9.engine import SH9Projector, SH9Result
from ...core.options import precompute_note
from ...core.errors import InputError
from ...core.radiometry.image_size import FrameTooLarge, megapixels
from ...core.lights.tracking import LightTracker
from .capture import Capture
from ..reflections.cube import TABLE_BUILDS, EnvironmentSettings, EnvironmentWorker, feeds_cube
from ..wire.message import coefficient_message, dumps
from ..sources import Frame, SourceSpec
from .temporal import ChangeGate, LightingFilter, light_model

log = logging.getLogger("shlight.probe")

#: Seconds between two estimates of SH9's own error (``error_estimate``): it follows the
#: scene, not the frame, and costs about a small resize and a 256-normal product, which an
#: edge core should not pay 30 times a second. Messages in between carry the last value.
ERROR_ESTIMATE_INTERVAL_S = 1.0
#: Frame sizes whose projector (and light tracker) a probe keeps, least recently used
#: first out: a source that keeps changing size must not grow memory without bound.
PROJECTORS_KEPT = 4
#: Files a probe lists as unreadable in /healthz (the newest kept).
BAD_FILES_KEPT = 32


@dataclass
class TemporalSettings:
    """How a probe's messages follow the lighting in time (see provider.live.probe.temporal)."""

    smoothing: float = 0.0          # time constant, seconds (0: off)
    snap: float = 0.1               # a change beyond this passes smoothing at once
    change_threshold: float = 0.002  # below this, unchanged lighting is not resent...
    keepalive: float = 1.0          # ...except every this many seconds
    stale_after: float = 2.0        # seconds without a fresh frame before "stale"


class Probe:
    """A named probe; ``publish(name, text)`` receives every message (UTF-8 bytes)."""

    def __init__(self, name: str, spec: SourceSpec, *, projection: str = "equirect",
                 engine_options: dict | None = None, temporal: TemporalSettings | None = None,
                 publish=None, backoff_max: float = 10.0,
                 environment: EnvironmentSettings | None = None, meter=None):
        self.name, self.spec = name, spec
        #: a :class:`~provider.live.probe.luxmeter.LuxMeter` (``serve --lux``), or None
        self.meter = meter
        self.meter_note = ""            # why the meter closed nothing, for the log (once)
        self.meter_warning = ""         # an ill-conditioned closure (a low sun), logged once
        self.projection, self.engine_options = projection, dict(engine_options or {})
        self.temporal = t = temporal or TemporalSettings()
        self.publish = publish or (lambda name, text: None)
        fps = spec.nominal_fps
        # A slow file sequence is not "stale" between two of its frames.
        self.stale_after = max(t.stale_after, 2.5 / fps if fps else 0.0)
        self.capture = Capture(spec, name=name, backoff_max=backoff_max)
        self.filter = LightingFilter(t.smoothing, t.snap)
        self.gate = ChangeGate(t.change_threshold, t.keepalive)
        self.state = "starting"
        self.error = ""                 # the last projection error, for /healthz
        self.seq = 0
        self.latest_message: dict | None = None
        self.latest_text: bytes | None = None
        self.image: np.ndarray | None = None    # the last projected frame (thumbnail)
        self.image_seq = 0
        #: what turns ``image``'s plain linear light into its coefficients' units (exposure,
        #: 1/(t·gain), C·N²: FrameDecoder.radiance_scale); None for a bracket's slot frame
        self.image_scale: float | None = 1.0
        self._image_scale: float | None = 1.0     # of the frame being projected
        self.frames_processed = 0
        self.frames_rejected = 0
        self.frames_adjusted = 0        # frames the source corrected (a relay: see _adjusted)
        #: --max-frame-pixels (pixels; 0: none): larger frames are refused from their header
        self.max_pixels = int(getattr(spec.options, "max_pixels", 0) or 0)
        self.frames_too_large = 0       # frames (file versions) refused for their size
        self._too_large_said = None     # (size, path) of the last refusal logged
        self.loop_errors = 0            # unexpected errors the probe's loop survived
        self.running = False            # the probe's task is running (see ProviderServer)
        self.bad_files: dict[str, str] = {}   # unreadable input file -> why (until it changes)
        #: the source's file whose current version cannot be read while its previous one
        #: goes on (an image source): "PATH: why", for /healthz (status degraded), or None
        self.outdated: str | None = None
        self.compute_ms = 0.0
        self.latency_s = 0.0            # capture → message of the newest frame
        self._projectors: collections.OrderedDict = collections.OrderedDict()
        self._estimated_at = -1e9       # monotonic time of the last error estimate
        self._error_estimate: float | None = None
        self._trackers: dict = {}       # frame size -> LightTracker (lights="auto")
        self._tracked_reconnects = 0
        self._ball_options: dict | None = None   # --ball auto: the options with the ball found
        self._ball_reconnects = 0
        self.ball: dict | None = None            # --ball auto: the circle found, for /healthz
        self._brackets: dict = {}       # (size, slot exposures) -> BracketProjector
        self._lighting: SH9Result | None = None
        self._frame_time = 0.0          # unix time of the newest frame (the source's clock)
        self._arrival = 0.0             # when it was processed here (our clock)
        self._fresh = False             # new lighting since the last message
        self._stale_since = None
        self._wake = asyncio.Event()
        self._last_error_log = -1e9
        self._last_adjust_log = -1e9
        # Reflections (off unless asked): the cube thread, and the frame of the newest lighting.
        self.publish_environment = lambda cube: None
        self.environment = None if environment is None else EnvironmentWorker(
            name, projection, self.engine_options, size=environment.size, hz=environment.hz,
            deliver=lambda cube: self.publish_environment(cube))
        self._environment_frame: Frame | None = None
        self._environment_work = None   # its work image, when SH9's pass filled one
        self._work = None               # the work image of the frame being projected
        #: A :class:`~provider.live.probe.registration.Registrar` (``--marker``), or None.
        self.registrar = None
        #: Where the camera is in the world, (x, y, z) metres (``--probe-position``), or None.
        self.position = None

    # -- the task ----------------------------------------------------------------------------
    async def run(self) -> None:
        """Process frames until cancelled (the capture is stopped on the way out)."""
        loop = asyncio.get_running_loop()

        def notify():
            try:
                loop.call_soon_threadsafe(self._wake.set)
            except RuntimeError:  # the loop is closed: we are shutting down
                pass

        self.capture.notify = notify
        self.capture.start()
        if self.meter is not None:
            self.meter.start()
        if self.environment is not None:
            self.environment.start(loop)
        tick = min(max(min(self.temporal.keepalive, self.stale_after) / 4, 0.02), 0.25)
        try:
            while True:
                # A timer wakes the loop at least every tick (stale marking, keepalives).
                # Not asyncio.wait_for: before Python 3.12 it swallows a cancellation that
                # arrives just as the wait completes, and the probe then never stops (seen as
                # a `shlight serve` that hung on SIGTERM with 30 fps sources).
                timer = loop.call_later(tick, self._wake.set)
                try:
                    await self._wake.wait()
                finally:
                    timer.cancel()
                self._wake.clear()
                try:
                    frame = self.capture.take()
                    while frame is not None:   # a bracket's slots may be waiting side by side
                        await self._process(frame)
                        self._maybe_publish(time.time())
                        frame = self.capture.take()
                    self._maybe_publish(time.time())
                except asyncio.CancelledError:
                    raise
                except Exception as exc:  # noqa: BLE001 - the probe lives on, whatever it is
                    self._loop_error(exc)
        finally:
            if self.registrar is not None:
                self.registrar.close()
            await asyncio.to_thread(self.capture.stop)
            if self.meter is not None:
                await asyncio.to_thread(self.meter.stop)
            if self.environment is not None:
                await asyncio.to_thread(self.environment.stop)

    def _loop_error(self, exc: Exception) -> None:
        """An error no frame check caught (a bug): counted, said (once per 10 s with its
        traceback), shown in /healthz; the loop goes on with the next frame."""
        self.loop_errors += 1
        self.error = f"{type(exc).__name__}: {exc}"
        now = time.monotonic()
        if now - self._last_error_log > 10.0:
            self._last_error_log = now
            log.error("probe %s: unexpected error (%d so far); going on", self.name,
                      self.loop_errors, exc_info=exc)

    async def _process(self, frame: Frame) -> None:
        info = frame.info or {}
        self._note_file(info)
        if info.get("too_large"):        # a file refused from its header by the source
            self._too_large(*info["too_large"], path=info.get("path"),
                            kept=not info.get("rejected"))
            if info.get("rejected"):
                self._rejected(str(info["rejected"]), quiet=True)
                return
        if info.get("rejected"):
            self._rejected(str(info["rejected"]))   # the source read it and found it bad
            return
        if info.get("adjusted"):
            self._adjusted(str(info["adjusted"]))
        try:
            if frame.lighting is not None:
                result = frame.lighting
                # relayed lighting: everything it carries must make a valid message
                coefficient_message(result, probe=self.name, time=frame.time)
            else:
                result = await asyncio.to_thread(self._project, frame)
        except _AlreadySaid as exc:
            self._rejected(str(exc), quiet=True)
            return
        except FrameTooLarge as exc:
            self._too_large(exc.width, exc.height, decoded=exc.decoded)
            self._rejected(str(exc), quiet=True)
            return
        except InputError as exc:
            self._rejected(str(exc))
            return
        except Exception as exc:  # noqa: BLE001 - the process never dies on a bad frame
            self._rejected(f"{type(exc).__name__}: {exc}")
            return
        if not (np.all(np.isfinite(result.coefficients)) and np.all(np.isfinite(result.matrices))):
            self._rejected("non-finite coefficients")
            return
        self._lighting, _ = self.filter.update_result(result, frame.time)
        self._frame_time, self._arrival = frame.time, time.time()
        self._fresh = True
        self.frames_processed += 1
        self._too_large_said = None
        self.compute_ms = float(result.stats.get("compute_ms", 0.0))
        self.error = ""
        if frame.image is not None:
            self.image, self.image_scale = frame.image, self._image_scale
            self.image_seq += 1
            if feeds_cube(frame):
                self._environment_frame = frame
                self._environment_work, self._work = self._work, None
        if self.registrar is not None:     # a time check here; detection in its own thread
            self.registrar.offer(frame)

    def _note_file(self, info: dict) -> None:
        """Keep the list of unreadable input files (Frame.info ``path`` and ``rejected`` or
        ``bad_file``) for /healthz: a file leaves it once it is read fine."""
        path = info.get("path")
        if path is None:
            return
        if not info.get("rejected"):       # a frame: of this version, or kept from an older one
            self.outdated = f"{path}: {info['bad_file']}" if info.get("bad_file") else None
        reason = info.get("rejected") or info.get("bad_file")
        if reason:
            self.bad_files.pop(path, None)
            self.bad_files[path] = str(reason)
            while len(self.bad_files) > BAD_FILES_KEPT:
                self.bad_files.pop(next(iter(self.bad_files)))
        else:
            self.bad_files.pop(path, None)

    def _project(self, frame: Frame) -> SH9Result:
        """Worker thread: decode if needed, build the projector once per size, project."""
        self._work = None
        image = frame.decoded(self.max_pixels)   # past the budget: refused from its header
        if image.ndim < 2:
            raise InputError(f"frame of shape {image.shape}")
        key = (image.shape[1], image.shape[0])
        if (self.engine_options.get("ball") == "auto"
                and self.capture.reconnects != self._ball_reconnects):
            self._projectors.clear()   # a new stream: the camera may have moved
        projector = self._projectors.get(key)
        if projector is None and self.engine_options.get("ball") == "auto":
            self._locate_ball(key, image)   # raises until a frame shows the ball
        if projector is None:
            while len(self._projectors) >= PROJECTORS_KEPT:   # a source that changes size
                old, _ = self._projectors.popitem(last=False)
                self._trackers.pop(old, None)
            projector = self._projectors[key] = self._build_projector(*key)
            self._estimated_at = -1e9
        else:
            self._projectors.move_to_end(key)
        if isinstance(projector, InputError):
            raise _AlreadySaid(str(projector))
        info = frame.info or {}
        self._image_scale = None        # a bracket's slot frame is not the merged light
        if info.get("slot") is not None and info.get("bracket") and info.get("exposure_s"):
            bkey = (key, tuple(info["bracket"]))
            bracket = self._brackets.get(bkey)
            if bracket is None:
                self._brackets.clear()       # a new bracket (or size) replaces the old one
                bracket = self._brackets[bkey] = BracketProjector(projector, info["bracket"])
                bracket.keep_frames = self.meter is not None
            # A bracket merges per-slot projections, never one linear frame: no lights here.
            result = bracket.push(info["slot"], image, info["exposure_s"],
                                  info.get("gain", 1.0), info.get("f_number"))
            lux, colour = self.meter.reading() if self.meter is not None else (None, None)
            if lux is not None and bracket.complete and all(f is not None
                                                            for f in bracket.frames):
                # the meter closes the merged pixels (the slots' newest frames, t·gain each)
                result = self._metered(projector, bracket.frames, bracket.exposures, 1.0,
                                       info.get("f_number"), lux, colour,
                                       stats=result.stats) or result
            return result
        self._image_scale = projector.radiance_scale(info.get("exposure_s"),
                                                     info.get("gain", 1.0), info.get("f_number"))
        tracker = None
        if projector.lights != "off":
            if self.capture.reconnects != self._tracked_reconnects:   # a new stream
                self._tracked_reconnects = self.capture.reconnects
                self._trackers.clear()
            tracker = self._trackers.setdefault(key, LightTracker())
        now = time.monotonic()
        estimate = now - self._estimated_at >= ERROR_ESTIMATE_INTERVAL_S
        # When a cube may be due, SH9's decoding pass also fills the cube's work image (one
        # decode for both products; at most --environment-hz times a second).
        self._work = (self.environment.work_for(image, projector)
                      if self.environment is not None else None)
        lux, colour = self.meter.reading() if self.meter is not None else (None, None)
        result = None
        if lux is not None:     # one decode and one projection, of the closed frame
            result = self._metered(projector, [image], [info.get("exposure_s")],
                                   info.get("gain", 1.0), info.get("f_number"), lux, colour,
                                   tracker=tracker, error_estimate=estimate, work=self._work)
        if result is None:
            result = projector.project(image, error_estimate=estimate, tracker=tracker,
                                       exposure_s=info.get("exposure_s"),
                                       gain=info.get("gain", 1.0),
                                       f_number=info.get("f_number"), work=self._work)
        if estimate:
            self._estimated_at, self._error_estimate = now, result.stats.get("error_estimate")
        elif self._error_estimate is not None:
            result.stats["error_estimate"] = self._error_estimate
        return result

    def _metered(self, projector, frames, times, gain, f_number, lux, colour=None, **kw):
        """``serve --lux``: the frame (or a bracket's newest frame of each slot, merged)
        projected with the meter's missing light in its clipped blob
        (:func:`~provider.core.sh9.meter.project_with_meter`; ``kw``: its ``tracker``,
        ``error_estimate``, ``work``, ``stats``); None for a frame that cannot be closed (no
        exposure, relative units: said once), which is then projected as it is."""
        from ...core.sh9.meter import project_with_meter
        try:
            closed, closure = project_with_meter(
                projector, frames, times, gain, f_number, lux,
                facing=getattr(self.meter, "facing", None), colour=colour, **kw)
        except InputError as exc:
            if str(exc) != self.meter_note:
                self.meter_note = str(exc)
                log.warning("probe %s: lux meter: %s", self.name, exc)
            return None
        if closure.note and closure.note[:40] != self.meter_note[:40]:
            log.info("probe %s: lux meter: %s", self.name, closure.note)
        self.meter_note = closure.note
        if closure.warning and closure.warning[:40] != self.meter_warning[:40]:
            log.warning("probe %s: lux meter: %s", self.name, closure.warning)
        self.meter_warning = closure.warning
        return closed

    def _locate_ball(self, key, image) -> None:
        """``--ball auto``: find the ball in this frame (the first of its size, and again
        after the source reconnects: the camera may have moved), for :meth:`_build_projector`."""
        from ...core.registration.ball import resolve_ball
        self._ball_options, circle = resolve_ball(self.engine_options, image)
        self._ball_reconnects = self.capture.reconnects
        self.ball = {**circle.as_dict(), "frame": [int(key[0]), int(key[1])]}
        log.info("probe %s: ball found at x %.1f, y %.1f, radius %.1f px in %d×%d frames",
                 self.name, circle.x, circle.y, circle.radius, *key)
        if circle.weak:
            log.warning("probe %s: %s", self.name, circle.weak_note())

    def _build_projector(self, width: int, height: int):
        """The projector for frames of this size, or the InputError saying why there is
        none. Said once: frames of this size are then rejected without rebuilding (an
        impossible geometry cannot be retried 30 times a second) and without a log line."""
        log.info("probe %s: building the %s projector for %d×%d frames", self.name,
                 self.projection, width, height)
        note = precompute_note(width, height, self.projection,
                               self.engine_options.get("downsample", 1))
        progress = None
        if note:
            log.warning("probe %s: %s", self.name, note)
            steps = iter((0.25, 0.5, 0.75, 1.0))
            step = [next(steps)]

            def progress(fraction):
                while step[0] is not None and fraction >= step[0]:
                    log.info("probe %s: per-pixel weights %.0f %% done", self.name, step[0] * 100)
                    step[0] = next(steps, None)
        options = self.engine_options
        if options.get("ball") == "auto":
            options = self._ball_options
        try:
            with TABLE_BUILDS:
                projector = SH9Projector(width, height, self.projection, progress=progress,
                                         **options)
        except Exception as exc:  # noqa: BLE001 - a bug must not become a rebuild per frame
            reason = str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
            log.error("probe %s: cannot project %d×%d frames with these options: %s "
                      "(frames of this size are rejected; fix the probe's options)",
                      self.name, width, height, reason)
            return InputError(reason)
        for warning in projector.warnings:
            log.warning("probe %s: %s", self.name, warning)
        if self.environment is not None:     # its cube's tables too, before any frame
            self.environment.prepare(width, height)
        return projector

    def _too_large(self, width: int, height: int, *, path: str | None = None,
                   kept: bool = False, decoded: bool = False) -> None:
        """A frame (or a file's new version) over --max-frame-pixels: counted; said in one
        line, again only after a frame was projected or for another size or file (an HTTP
        camera that sends nothing but oversized frames is said once)."""
        self.frames_too_large += 1
        key = (width, height, path)
        if key == self._too_large_said:
            return
        self._too_large_said = key
        where = f" ({path}{'; the previous image goes on' if kept else ''})" if path else ""
        log.warning("probe %s: frame %d×%d (%s) is over --max-frame-pixels %s: %s%s",
                    self.name, width, height, megapixels(width * height),
                    megapixels(self.max_pixels), "refused" if decoded else "not decoded",
                    where)

    def _rejected(self, reason: str, quiet: bool = False) -> None:
        self.frames_rejected += 1
        self.error = reason
        now = time.monotonic()
        if not quiet and now - self._last_error_log > 10.0:   # one line per 10 s, not per frame
            self._last_error_log = now
            log.error("probe %s: frame rejected (%d so far): %s", self.name,
                      self.frames_rejected, reason)

    def _adjusted(self, note: str) -> None:
        """A frame its source corrected to fit the contract (a relayed message whose
        upstream clock cannot be right, or with more lights than the shaders take):
        counted for /healthz, said once per 10 s."""
        self.frames_adjusted += 1
        now = time.monotonic()
        if now - self._last_adjust_log > 10.0:
            self._last_adjust_log = now
            log.warning("probe %s: frame adjusted (%d so far): %s", self.name,
                        self.frames_adjusted, note)

    # -- messages ----------------------------------------------------------------------------
    def _maybe_publish(self, now: float) -> None:
        if self._lighting is None:
            return
        stale = (self.capture.state in ("lost", "finished")
                 or now - self._arrival > self.stale_after)
        if stale and self.state != "stale":
            self.state, self._stale_since = "stale", now
            why = self.capture.reason if self.capture.state != "live" else \
                f"no frame for {now - self._arrival:.1f} s"
            log.warning("probe %s: stale (%s); clients keep the last lighting", self.name, why)
            self._send(now, stale=True, changed=False)
        elif not stale and self.state != "live":
            if self.state == "stale":
                log.info("probe %s: fresh again after %.1f s", self.name,
                         now - self._stale_since)
            self.state = "live"
            self._send(now, stale=False, changed=True)
        elif stale:
            if self.gate.due(now):
                self._send(now, stale=True, changed=False)
        elif self._fresh and self.gate.changed(self._lighting.coefficients,
                                               light_model(self._lighting)):
            self._send(now, stale=False, changed=True)
        elif self.gate.due(now):
            self._send(now, stale=False, changed=False)

    def _send(self, now: float, *, stale: bool, changed: bool) -> None:
        lighting = self._lighting
        if self._fresh:
            self.latency_s = max(now - self._frame_time, 0.0)
        msg = coefficient_message(
            lighting, probe=self.name, seq=self.seq, time=self._frame_time, stale=stale,
            age_s=max(now - self._frame_time, 0.0), fps=round(self.capture.fps, 3),
            latency_ms=round(self.latency_s * 1e3, 3), resent=not changed,
            source=self.spec.kind)
        registration = self.registrar.fields(now) if self.registrar is not None else None
        if registration is not None:
            msg["registration"] = registration
        if self.position is not None:
            msg["position"] = [float(v) for v in self.position]
        text = dumps(msg).encode()
        if changed and not stale and self._environment_frame is not None \
                and self.environment is not None:
            self.environment.offer(self._environment_frame, self.seq,    # never waits
                                   self._environment_work)
            self._environment_frame = self._environment_work = None
        self.seq += 1
        self._fresh = False
        self.gate.mark_sent(lighting.coefficients, now, light_model(lighting))
        self.latest_message, self.latest_text = msg, text
        try:
            self.publish(self.name, text)
        except Exception as exc:  # noqa: BLE001 - a destination's bug stops no probe
            self._loop_error(exc)

    # -- for /healthz and /metrics ------------------------------------------------------------
    def health(self) -> dict:
        now = time.time()
        health = {"state": self.state, "source": self.spec.description,
                  "source_state": self.capture.state, "source_error": self.capture.reason,
                  "error": self.error, "seq": self.seq,
                  "age_s": round(now - self._frame_time, 3) if self._lighting else None,
                  "fps": round(self.capture.fps, 2), "compute_ms": round(self.compute_ms, 3),
                  "frames": self.frames_processed, "frames_rejected": self.frames_rejected,
                  "frames_adjusted": self.frames_adjusted,
                  "frames_too_large": self.frames_too_large,
                  "max_frame_pixels": self.max_pixels,
                  "reconnects": self.capture.reconnects, "running": self.running,
                  "loop_errors": self.loop_errors, "bad_files": dict(self.bad_files)}
        if self.outdated is not None:   # the lighting is from an older version of its file
            health["outdated"] = (f"{self.outdated} (the lighting is from its previous "
                                  "version)")
        if self.environment is not None:
            health["environment"] = self.environment.health()
        if self.ball is not None:       # --ball auto: where, and whether it may be off
            health["ball"] = self.ball
        if self.registrar is not None:  # --marker: found or not, tries and misses
            health["registration"] = self.registrar.health(now)
        if self.position is not None:   # --probe-position
            health["position"] = [float(v) for v in self.position]
        if self.meter is not None:      # --lux: its last reading, refusals, broker
            health["meter"] = self.meter.health()
        camera = self.capture.source_health()
        if camera:                      # a Theta: its settings, battery, temperature
            health["camera"] = camera
        return health


class _AlreadySaid(InputError):
    """A frame rejected for a reason already logged once (no projector for its size)."""
