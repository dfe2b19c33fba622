"""A probe's live reflection cube (``shlight serve --environment``; docs/contract.md §12,
"Transport"): made in its own worker thread from the frames the probe already decoded for
SH9, at most ``hz`` times a second and only when the lighting changed, then encoded once as
KTX 2.0 (:mod:`.ktx2`) for every client, MQTT and ``GET /environment.ktx2``.

The SH9 path never waits for a cube: :meth:`EnvironmentWorker.offer` (called on the event
loop when the probe sends a changed sh9 message) only replaces the one pending frame and
wakes the thread; the thread takes the newest frame when its turn comes (at most ``hz``),
projects it with :class:`provider.core.reflections.environment.EnvironmentProjector` (built once per frame
size), encodes it and hands an :class:`EnvironmentCube` back to the event loop. Frames offered
meanwhile are replaced, never queued. The thread runs at a lower scheduling priority (nice
+10 where the OS allows it), so that on a busy edge core the cube yields to SH9.

Exports that carry the cube (``/latest.json?to=gltf|arcore``, a client's ``to``;
:mod:`.export`): once someone asks (:meth:`EnvironmentWorker.want`), the thread also encodes
the cube in that format with every cube it makes, for :data:`EXPORT_IDLE_S` after the last
request, and for the latest cube at once if it lacks it: gltf's mips re-prefiltered at
Babylon.js's roughness from the cube's own pyramid (an :meth:`~provider.core.reflections.environment.
EnvironmentProjector.at_roughness` twin's :meth:`~provider.core.reflections.environment.
EnvironmentProjector.refilter`: only the prefilter runs again), then RGBD PNG; arcore's 16²
float16 faces. Encoded once
per cube (:class:`~provider.core.conventions.formats.EncodedCube`, ``EnvironmentCube.exports``), in
this thread, never per request nor on the event loop.
"""
from __future__ import annotations

import asyncio
import json
import logging
import math
import os
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from ... import __version__
from ...core.conventions.formats import CUBE_FORMATS
from ...core.conventions.formats import encode_cube as encode_export_cube
from ...core.errors import InputError
from .ktx2 import encode_cube
from ..wire.message import FRAME, SCHEMA_VERSION, UNITS, dumps

log = logging.getLogger("shlight.environment")
#: One projector build at a time in a process: SH9's and the cube's, made by two threads at
#: a probe's first frame, would otherwise peak together (about 130 MB each for a Theta S
#: frame), more than a 512 MB board can spare (docs: the README's edge section).
TABLE_BUILDS = threading.Lock()

#: Edge sizes a cube may have (powers of two, as the core requires).
SIZES = tuple(1 << k for k in range(3, 9))       # 8 .. 256
#: How long a due cube waits for the frame whose decode the SH9 pass shared (seconds).
WORK_WAIT_S = 0.25
#: How long a format's cube stays wanted after its last request (seconds): the cube of an
#: export that nobody asks for is not encoded.
EXPORT_IDLE_S = 60.0
DEFAULT_SIZE = 32
DEFAULT_HZ = 1.0
MAX_HZ = 30.0
FORMAT, ENCODING = "rgba16f", "ktx2"
LAYOUT = ("faces +X -X +Y -Y +Z -Z (the OpenGL cube-map order); texel [f, i, j] at "
          "s = (j + 1/2)/n, t = (i + 1/2)/n, row i = t; docs/contract.md §12")
FILTER = ("mip 0: radiance, the solid-angle mean over each texel; mip k > 0: GGX-prefiltered "
          "radiance (split sum, n = v = r, alpha = roughness^2); lod = roughness * (mips - 1)")

#: Engine options that only the SH9 path has (the cube takes the input options).
def check_size(size) -> int:
    """``size`` if it is a power of two from 8 to 256, else :class:`InputError` (one line)."""
    from ...core.geometry.cubemap import check_size as core_check
    try:
        return core_check(size if not isinstance(size, bool) else None)
    except ValueError:
        raise InputError(f"environment size {size!r}: a power of two from "
                         f"{SIZES[0]} to {SIZES[-1]} (default {DEFAULT_SIZE})") from None


def check_hz(hz) -> float:
    """``hz`` if it is a finite rate in (0, 30] updates per second, else :class:`InputError`."""
    if isinstance(hz, bool) or not isinstance(hz, (int, float)) or not math.isfinite(hz) \
            or not 0 < hz <= MAX_HZ:
        raise InputError(f"environment rate {hz!r}: updates per second in (0, {MAX_HZ:g}] "
                         f"(default {DEFAULT_HZ:g})")
    return float(hz)


def cube_options(engine_options: dict) -> dict:
    """The engine options that apply to the cube (input decoding, exposure, rotation,
    projection geometry), without the SH9-only ones."""
    from ...core.reflections.environment import SH9_ONLY
    return {k: v for k, v in engine_options.items() if k not in SH9_ONLY}


def feeds_cube(frame) -> bool:
    """Whether a frame may make the cube: any frame with an image; of an exposure bracket
    (``info`` ``slot``, ``bracket``), only the slot of median exposure, so that the cube
    keeps one steady exposure instead of alternating between the slots (each slot is divided
    by its own exposure, so the units are the same either way)."""
    if frame.lighting is not None or frame.image is None:
        return False
    info = frame.info or {}
    bracket, slot = info.get("bracket"), info.get("slot")
    if slot is None or not bracket:
        return True
    order = sorted(range(len(bracket)), key=lambda k: bracket[k])
    return slot == order[len(order) // 2]


def key_values(result, *, probe: str, seq: int, sh9_seq: int | None, time_s: float,
               exposure: float = 1.0, exposure_s=None, gain=None) -> dict[str, str]:
    """The KTX2 key/value data of a cube (all text; lists and objects as JSON): what its
    numbers are (frame, layout, filter, units, exposure) and where it belongs (probe, seq,
    the sh9 message's seq, time)."""
    stats = getattr(result, "stats", None) or {}
    exposure_s = stats.get("exposure_s", exposure_s)
    gain = stats.get("gain", gain)
    kv = {"shlight.frame": FRAME, "shlight.layout": LAYOUT, "shlight.filter": FILTER,
          "shlight.roughness": json.dumps([round(float(r), 6) for r in result.roughness]),
          "shlight.units": str(getattr(result, "units", None) or UNITS),
          "shlight.exposure": json.dumps({"exposure": float(exposure),
                                          "exposure_s": _number(exposure_s),
                                          "gain": _number(gain)}),
          "shlight.probe": probe, "shlight.seq": str(int(seq)),
          "shlight.sh9_seq": "" if sh9_seq is None else str(int(sh9_seq)),
          "shlight.time": repr(float(time_s)),
          "KTXwriter": f"shlight {__version__}"}
    if stats.get("radiometry"):
        kv["shlight.radiometry"] = str(stats["radiometry"])
    return kv


def _number(v):
    return float(v) if v is not None and math.isfinite(float(v)) else None


@dataclass(frozen=True)
class EnvironmentSettings:
    """``shlight serve --environment``: the cube's edge (texels) and its most updates/s."""

    size: int = DEFAULT_SIZE
    hz: float = DEFAULT_HZ

    def __post_init__(self):
        check_size(self.size)
        check_hz(self.hz)


@dataclass
class EnvironmentCube:
    """One encoded cube update: its KTX2 bytes and the ``environment`` message that
    announces them (``text``: that message as UTF-8 JSON)."""

    probe: str
    seq: int
    sh9_seq: int | None
    size: int
    roughness: list
    ktx2: bytes
    message: dict
    text: bytes
    compute_ms: float = 0.0
    encode_ms: float = 0.0
    time: float = field(default_factory=time.time)
    #: format -> :class:`~provider.core.conventions.formats.EncodedCube` (exports that carry the cube),
    #: and format -> why it could not be encoded; filled by the worker, read on the event loop
    exports: dict = field(default_factory=dict)
    export_errors: dict = field(default_factory=dict)


def encode_environment(result, *, probe: str, seq: int, sh9_seq: int | None, time_s: float,
                       exposure: float = 1.0, exposure_s=None, gain=None,
                       compute_ms: float | None = None) -> EnvironmentCube:
    """The KTX2 bytes and the ``environment`` message of a core result (``mips``,
    ``roughness``; provider.core.reflections.environment)."""
    t0 = time.perf_counter()
    data = encode_cube(result.mips, key_values(
        result, probe=probe, seq=seq, sh9_seq=sh9_seq, time_s=time_s, exposure=exposure,
        exposure_s=exposure_s, gain=gain))
    encode_ms = (time.perf_counter() - t0) * 1e3
    stats = getattr(result, "stats", None) or {}
    if compute_ms is None:
        compute_ms = float(stats.get("compute_ms", 0.0))
    size = int(result.mips[0].shape[1])
    roughness = [float(r) for r in result.roughness]
    message = {"type": "environment", "version": SCHEMA_VERSION, "probe": probe,
               "seq": int(seq), "sh9_seq": -1 if sh9_seq is None else int(sh9_seq),
               "time": float(time_s), "frame": FRAME, "size": size, "mips": len(result.mips),
               "roughness": roughness, "format": FORMAT, "encoding": ENCODING,
               "byte_length": len(data),
               "units": str(getattr(result, "units", None) or UNITS),
               "compute_ms": round(float(compute_ms), 3), "encode_ms": round(encode_ms, 3)}
    return EnvironmentCube(probe, int(seq), sh9_seq, size, roughness, data, message,
                           dumps(message).encode(), compute_ms, encode_ms)


class EnvironmentWorker:
    """A probe's cube thread (see the module docstring). ``deliver(cube)`` is called on the
    event loop given to :meth:`start` with every new :class:`EnvironmentCube`."""

    def __init__(self, probe: str, projection: str, engine_options: dict, *,
                 size: int = DEFAULT_SIZE, hz: float = DEFAULT_HZ, deliver=None):
        self.probe, self.projection = probe, projection
        self.size, self.hz = check_size(size), check_hz(hz)
        self.options = cube_options(engine_options)
        self.exposure = float(self.options.get("exposure", 1.0))
        self.deliver = deliver or (lambda cube: None)
        self.updates = 0                # cubes made
        self.offered = 0                # frames offered (changed lighting)
        self.replaced = 0               # offered frames replaced by a newer one unprojected
        self.errors = 0
        self.error = ""
        self.compute_ms = 0.0           # the last cube: projection, then encoding
        self.encode_ms = 0.0
        self.bytes = 0                  # the last cube's KTX2 length
        self.latest: EnvironmentCube | None = None
        self._pending = None            # (frame, sh9_seq, work image or None)
        self._next_at = 0.0             # monotonic time the next cube may be made
        self._work_at = -1e9            # when a work image was last handed out
        self.shared = 0                 # cubes made from the SH9 pass's decode
        self._integer_frames = False    # the source's frames are 8/16-bit (can be shared)
        self._cond = threading.Condition()
        self._stopping = False
        self._thread: threading.Thread | None = None
        self._loop = None
        self._projectors: dict = {}
        self._last_error_log = -1e9
        # exports that carry the cube (see the module docstring)
        self.exported = lambda cube: None   # called on the event loop when a cube gains one
        self.export_ms: dict = {}           # format -> the last encoding's ms (re-prefilter too)
        self.encoded: dict = {}             # format -> cubes encoded in it
        self._wanted: dict = {}             # format -> monotonic time it was last asked for
        self._made = None                   # thread: (cube, frame, result) of the last cube made
        self._made_formats: set = set()     # thread: formats encoded (or failed) for it
        self._twins: dict = {}              # frame size -> projector at Babylon's roughness
        self._waiters: list = []            # event loop: (format, future) of export_ready

    # -- event loop side ---------------------------------------------------------------------
    def start(self, loop) -> None:
        self._loop = loop
        self._stopping = False
        self._thread = threading.Thread(target=self._run, daemon=True,
                                        name=f"environment-{self.probe}")
        self._thread.start()

    def stop(self, timeout: float = 5.0) -> None:
        """End the thread (blocking: call it in a worker thread)."""
        with self._cond:
            self._stopping = True
            self._cond.notify()
        if self._thread is not None:
            self._thread.join(timeout)

    def work_for(self, image, decoder):
        """A :class:`~provider.core.reflections.work_image.WorkImage` for the SH9 pass (``decoder``, its
        projector) to fill while it decodes ``image`` anyway, so that the cube of this frame
        needs no second decode; None unless a cube may be due (at most ``hz`` a second) and
        the cube's projector for this frame size is built. Called from the probe's worker
        thread; never blocks."""
        now = time.monotonic()
        self._integer_frames = image.dtype in (np.uint8, np.uint16)
        if not self._integer_frames or now < self._next_at \
                or self._work_at >= self._next_at:      # one per period, no more
            return None
        projector = self._projectors.get((image.shape[1], image.shape[0]))
        if projector is None or isinstance(projector, InputError):
            return None
        work = projector.new_work(decoder, getattr(decoder, "BAND_ROWS", 32))
        if work is not None:
            self._work_at = now
        return work

    def offer(self, frame, sh9_seq: int, work=None) -> None:
        """The frame of a changed sh9 message (seq ``sh9_seq``; ``work``: its work image
        from :meth:`work_for`, if the SH9 pass filled one): it replaces any frame still
        waiting; never blocks."""
        with self._cond:
            if self._pending is not None:
                self.replaced += 1
            self._pending = (frame, sh9_seq, work)
            self.offered += 1
            self._cond.notify()

    def want(self, fmt: str) -> None:
        """Someone asked for ``fmt``'s export (one of CUBE_FORMATS): its cube is encoded with
        every cube for the next EXPORT_IDLE_S, and for the latest cube now if it lacks it.
        Never blocks."""
        with self._cond:
            self._wanted[fmt] = time.monotonic()
            latest = self.latest
            if latest is None or (fmt not in latest.exports and fmt not in latest.export_errors):
                self._cond.notify()

    async def export_ready(self, fmt: str, timeout: float) -> None:
        """Ask for ``fmt`` (:meth:`want`) and wait, at most ``timeout`` seconds and without
        blocking the event loop, until the latest cube carries it (or failed to)."""
        self.want(fmt)
        if self._has_export(self.latest, fmt):
            return
        waiter = (fmt, asyncio.get_running_loop().create_future())
        self._waiters.append(waiter)
        try:
            await asyncio.wait_for(waiter[1], timeout)
        except asyncio.TimeoutError:
            pass
        finally:
            if waiter in self._waiters:
                self._waiters.remove(waiter)

    @staticmethod
    def _has_export(cube, fmt: str) -> bool:
        return cube is not None and (fmt in cube.exports or fmt in cube.export_errors)

    def _arrived(self, cube: EnvironmentCube) -> None:
        self.latest = cube
        self.deliver(cube)
        self._wake(cube)

    def _attach(self, cube: EnvironmentCube, exports: dict, errors: dict) -> None:
        """Exports encoded for a cube after it was delivered (event loop)."""
        cube.exports.update(exports)
        cube.export_errors.update(errors)
        if cube is self.latest:
            self._wake(cube)
            self.exported(cube)

    def _wake(self, cube: EnvironmentCube) -> None:
        for waiter in [w for w in self._waiters if self._has_export(cube, w[0])]:
            self._waiters.remove(waiter)
            if not waiter[1].done():
                waiter[1].set_result(None)

    # -- the thread --------------------------------------------------------------------------
    def _run(self) -> None:
        try:     # yield to SH9 on a busy core (Linux: per-thread nice)
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), 10)
        except (AttributeError, OSError):
            pass
        while True:
            missing = []
            with self._cond:
                while not self._stopping:
                    now = time.monotonic()
                    wait = self._wait_s(now)
                    if wait <= 0:
                        break
                    missing = self._missing_exports(now)
                    if missing:         # the latest cube lacks an export someone asked for
                        break
                    self._cond.wait(None if wait == math.inf else wait)
                if self._stopping:
                    return
                if not missing:
                    frame, sh9_seq, work = self._pending
                    self._pending = None
            if missing:
                cube, frame, result = self._made
                self._made_formats.update(missing)
                exports, errors = self._encode_exports(missing, frame, result)
                try:
                    self._loop.call_soon_threadsafe(self._attach, cube, exports, errors)
                except RuntimeError:    # the event loop is closed: shutting down
                    return
                continue
            self._next_at = time.monotonic() + 1.0 / self.hz
            try:
                cube = self._make(frame, sh9_seq, work)
            except Exception as exc:  # noqa: BLE001 - the thread never dies on a bad frame
                self._failed(str(exc) if isinstance(exc, InputError)
                             else f"{type(exc).__name__}: {exc}")
                continue
            if cube is None:
                continue
            try:
                self._loop.call_soon_threadsafe(self._arrived, cube)
            except RuntimeError:        # the event loop is closed: shutting down
                return

    def _wait_s(self, now: float) -> float:
        """Seconds until the pending frame should be taken (inf: none is pending). With an
        8/16-bit source, a due frame without a work image waits a moment (WORK_WAIT_S) for a
        frame whose decode the SH9 pass shares, then goes anyway (the cube decodes it)."""
        if self._pending is None:
            return math.inf
        if now < self._next_at:
            return self._next_at - now
        if self._pending[2] is None and self._integer_frames and self._projectors:
            since = self._work_at if self._work_at >= self._next_at else self._next_at
            return since + WORK_WAIT_S - now
        return 0.0

    def _make(self, frame, sh9_seq: int, work=None) -> EnvironmentCube | None:
        image = frame.decoded()         # decoded already by the SH9 path: no second decode
        key = (image.shape[1], image.shape[0])
        projector = self._projectors.get(key)
        if projector is None:
            if len(self._projectors) >= 4:
                self._projectors.clear()
                self._twins.clear()
            projector = self._projectors[key] = self._build(*key)
        if isinstance(projector, InputError):
            return None                 # said once when it was built
        info = frame.info or {}
        t0 = time.perf_counter()
        result = projector.project(image, exposure_s=info.get("exposure_s"),
                                   gain=info.get("gain", 1.0), work=work)
        self.shared += bool(result.stats.get("shared_decode"))
        compute_ms = (time.perf_counter() - t0) * 1e3
        cube = encode_environment(result, probe=self.probe, seq=self.updates, sh9_seq=sh9_seq,
                                  time_s=frame.time, exposure=self.exposure,
                                  exposure_s=info.get("exposure_s"), gain=info.get("gain"),
                                  compute_ms=compute_ms)
        self.updates += 1
        self.compute_ms, self.encode_ms, self.bytes = compute_ms, cube.encode_ms, len(cube.ktx2)
        self.error = ""
        with self._cond:
            formats = self._wanted_formats(time.monotonic())
        self._made, self._made_formats = (cube, frame, result), set(formats)
        exports, errors = self._encode_exports(formats, frame, result)
        cube.exports.update(exports)    # not handed to the event loop yet
        cube.export_errors.update(errors)
        return cube

    # -- exports that carry the cube (the thread) ---------------------------------------------
    def _wanted_formats(self, now: float) -> list:
        return [f for f, t in self._wanted.items() if now - t < EXPORT_IDLE_S]

    def _missing_exports(self, now: float) -> list:
        """Formats asked for that the last cube made lacks (under the lock)."""
        if self._made is None:
            return []
        return [f for f in self._wanted_formats(now) if f not in self._made_formats]

    def _encode_exports(self, formats, frame, result) -> tuple[dict, dict]:
        """({format: EncodedCube}, {format: why not}) of one cube (``result``, the
        :class:`~provider.core.reflections.environment.EnvironmentResult` made from ``frame``)."""
        exports, errors = {}, {}
        for fmt in formats:
            if fmt not in CUBE_FORMATS:
                continue
            t0 = time.perf_counter()
            try:
                mips = result.mips
                if fmt == "gltf":       # the same frame's pyramid prefiltered at Babylon's
                    mips = self._twin(frame.decoded()).refilter(result).mips   # roughness
                exports[fmt] = encode_export_cube(fmt, mips)
                self.encoded[fmt] = self.encoded.get(fmt, 0) + 1
            except Exception as exc:  # noqa: BLE001 - the thread never dies on an export
                errors[fmt] = str(exc) if isinstance(exc, InputError) \
                    else f"{type(exc).__name__}: {exc}"
                log.error("probe %s: no %s cube: %s", self.probe, fmt, errors[fmt])
            self.export_ms[fmt] = (time.perf_counter() - t0) * 1e3
        return exports, errors

    def _twin(self, image):
        """The projector of this frame size at Babylon.js's roughness (built once: it shares
        the cube projector's geometry and builds only its prefilter operator; it refilters
        the cube's pyramid)."""
        from ...core.reflections.gltf_ibl import babylon_roughness
        key = (image.shape[1], image.shape[0])
        twin = self._twins.get(key)
        if twin is None:
            projector = self._projectors.get(key)
            if projector is None or isinstance(projector, InputError):
                raise InputError(f"no reflection cube for {key[0]}×{key[1]} frames")
            if len(self._twins) >= 4:
                self._twins.clear()
            twin = self._twins[key] = projector.at_roughness(babylon_roughness(self.size))
        return twin

    def prepare(self, width: int, height: int) -> None:
        """Build the cube's projector for frames of this size now (the probe's thread, right
        after SH9's, before its first frame): the cube's build then never peaks on top of
        frames in flight (a 512 MB board; a restart reads both from the table cache)."""
        if (width, height) not in self._projectors:
            self._projectors[(width, height)] = self._build(width, height)

    def _build(self, width: int, height: int):
        from ...core.reflections.environment import EnvironmentProjector
        try:
            with TABLE_BUILDS:
                ready = self._projectors.get((width, height))
                if ready is not None:           # prepared by the probe's thread meanwhile
                    return ready
                projector = EnvironmentProjector(width, height, self.projection,
                                                 size=self.size, **self.options)
            for note in projector.table_notes:       # a damaged table file, rebuilt
                log.warning("probe %s: reflection cube: %s", self.probe, note)
            return projector
        except Exception as exc:  # noqa: BLE001 - a bug must not become a rebuild per frame
            reason = str(exc) if isinstance(exc, InputError) else f"{type(exc).__name__}: {exc}"
            log.error("probe %s: no reflection cube for %d×%d frames: %s", self.probe, width,
                      height, reason)
            self.errors += 1
            self.error = reason
            return InputError(reason)

    def _failed(self, reason: str) -> None:
        self.errors += 1
        self.error = reason
        now = time.monotonic()
        if now - self._last_error_log > 10.0:
            self._last_error_log = now
            log.error("probe %s: reflection cube failed (%d so far): %s", self.probe,
                      self.errors, reason)

    # -- /healthz ----------------------------------------------------------------------------
    def health(self) -> dict:
        latest = self.latest
        return {"size": self.size, "hz": self.hz, "updates": self.updates,
                "seq": latest.seq if latest else None,
                "sh9_seq": latest.sh9_seq if latest else None,
                "bytes": self.bytes, "compute_ms": round(self.compute_ms, 3),
                "encode_ms": round(self.encode_ms, 3), "offered": self.offered,
                "replaced": self.replaced, "shared_decode": self.shared,
                "errors": self.errors, "error": self.error,
                "exports": {f: {"encoded": self.encoded.get(f, 0), "encode_ms": round(ms, 3),
                                "error": (latest.export_errors.get(f, "") if latest else "")}
                            for f, ms in self.export_ms.items()}}
