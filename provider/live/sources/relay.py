"""Relay: the coefficients of another ``shlight serve`` (edge device → PC → many headsets).

Every upstream sh9 message is checked before it becomes lighting here, against what this
server's own probe would make (docs/contract.md §3, §9, §10): ``coefficients`` and
``ambient_coefficients`` exactly 27 JSON numbers each (no strings, booleans, nulls, NaN or
Infinity), at most :data:`MAX_MAGNITUDE` in size; ``lights`` a count with 3 numbers per light
in ``light_directions`` (finite, of non-zero length; normalised here) and
``light_irradiance`` (finite, ≥ 0), and ``light_angular_radius_deg`` when present (k numbers
in [0, 90]; absent, from an older upstream: 0, point lights; an empty list beside k > 0 is
corrected to 0 and counted as adjusted); ``time`` a finite number; each optional statistic of
its type and range. A message that breaks any of these is *refused*: it becomes a rejected
frame (``frames_rejected`` in /healthz and /metrics, one log line per 10 s naming the
field), and the probe keeps serving the last good lighting. Two faults are *corrected* and
counted as ``frames_adjusted`` in /healthz: an upstream clock that cannot be right (before
2001, or more than :data:`MAX_CLOCK_AHEAD_S` ahead of this one) gives way to the arrival
time, and more than :data:`~provider.core.options.MAX_LIGHTS` lights are cut to the
strongest (by luminance), the others' SH9 going into the ambient so that ambient + lights
is still the full SH9. The matrices are never taken from upstream: this server makes them
from the coefficients it accepted.

Pace: the relay hands its probe at most ``--fps`` messages a second (default
:data:`RELAY_FPS`): of the messages that arrive before the next slot the newest wins, the
others are dropped unread, never queued; so an upstream that floods costs this server one
JSON parse per message, not a projection and a fan-out to every client.
"""
from __future__ import annotations

import asyncio
import json
import math
import time
import urllib.parse

import numpy as np

from ...core.geometry import sh
from ...core.lights.analysis import Light
from ...core.options import MAX_LIGHTS
from ...core.radiometry.photometry import LUMINANCE_WEIGHTS as _REC709
from ...core.sh9.engine import SH9Result
from .base import USER_AGENT, Frame, Interrupted, Source, SourceError, SourceOptions, redact

#: Messages a second a relay hands to its probe when ``--fps`` is not given: a camera's rate.
RELAY_FPS = 30.0
#: The largest magnitude of a relayed coefficient, ambient coefficient, light irradiance or
#: statistic. Nine orders of magnitude above the brightest real input (the sun's radiance
#: is about 2e7 W m⁻² sr⁻¹; radiance per second of exposure at 1/8000 s about 1e7), and low
#: enough that what clients compute from the numbers in float32 (irradiance, sums of
#: squares of 27 coefficients for a norm: 27e36) stays below its 3.4e38 limit.
MAX_MAGNITUDE = 1e18
#: An upstream time further than this ahead of this clock is not believed (arrival time used).
MAX_CLOCK_AHEAD_S = 60.0
#: An upstream time before this (2001-09-09) comes from a clock that was never set.
MIN_CLOCK = 1e9
#: A light direction within this of unit length is passed on bit for bit.
_UNIT_TOLERANCE = 1e-9
#: A light direction shorter than this names no direction.
_MIN_DIRECTION = 1e-6

#: (minimum, maximum, minimum excluded) of each relayed number statistic (the JSON Schema's).
_NUMBER_RANGES = {**{k: (0.0, MAX_MAGNITUDE, False)
                     for k in ("compute_ms", "order_error", "error_estimate", "coverage_sr",
                               "negative_energy_fraction", "window_cutoff", "light_error",
                               "sh9_error")},
                  "clipped_fraction": (0.0, 1.0, False),
                  "clipped_light_fraction": (0.0, 1.0, False),
                  "exposure_s": (0.0, MAX_MAGNITUDE, True), "gain": (0.0, MAX_MAGNITUDE, True),
                  # absolute units (contract §14): the upstream's exact up-facing lux and the
                  # aperture and ISO it used; lux, EV100 and CCT are rebuilt here
                  "illuminance_lux": (0.0, MAX_MAGNITUDE, False),
                  "f_number": (0.0, MAX_MAGNITUDE, True), "iso": (0.0, MAX_MAGNITUDE, True),
                  # what the upstream's lux meter closed (contract §14): passed on as said
                  **{k: (0.0, MAX_MAGNITUDE, False)
                     for k in ("meter_lux", "meter_camera_lux", "meter_closed_lux",
                               "meter_solid_angle_sr")}}
#: The meter's unit vectors (meter_direction may be zeros: nothing closed).
_METER_VECTORS = ("meter_direction", "meter_facing")
_INT_RANGES = {"negative_pixels": (0, 1 << 53), "nonfinite_pixels": (0, 1 << 53),
               "light_candidates": (0, 1 << 53), "order": (0, 2)}
_RADIOMETRY = ("srgb-assumed", "calibrated", "merged", "linear")
#: The optional fields an upstream message may carry that this provider passes on.
_RELAY_STATS = (*_NUMBER_RANGES, *_INT_RANGES, "radiometry", "response", "ringing",
                "min_irradiance", "exposures_s", "coefficient_units", *_METER_VECTORS,
                "meter_colour")
#: Where the upstream meter's closed light got its colour (contract §14).
_METER_COLOURS = ("measured", "rim", "modelled", "neutral")
_COEFFICIENT_UNITS = ("cd/m²", "relative")


def _show(value) -> str:
    """A value for a log line: short, and quoted so that it cannot forge a line."""
    return repr(value)[:40]


def _is_number(v) -> bool:
    return type(v) in (int, float) and math.isfinite(v)


def _numbers(msg: dict, key: str, count: int | None = None, *,
             minimum: float = -MAX_MAGNITUDE) -> np.ndarray:
    """``msg[key]`` as a float64 array: a list of JSON numbers only (no strings, booleans,
    nulls, NaN or Infinity), ``count`` of them when given, each within
    [``minimum``, :data:`MAX_MAGNITUDE`]; ValueError names what is wrong."""
    if key not in msg:
        raise ValueError(f"no {key!r}")
    values = msg[key]
    if not isinstance(values, list):
        raise ValueError(f"{key!r} is not a list of numbers: {_show(values)}")
    if count is not None and len(values) != count:
        raise ValueError(f"{key!r} holds {len(values)} values, not {count}")
    if not set(map(type, values)) <= {int, float}:          # a bool's type is bool
        bad = next(v for v in values if type(v) not in (int, float))
        raise ValueError(f"{key!r} holds {_show(bad)}, not a number")
    try:
        array = np.array(values, np.float64)
    except OverflowError:                                   # an integer of 400 digits
        raise ValueError(f"{key!r} holds a number beyond float64") from None
    if array.size and not (np.all(np.isfinite(array)) and array.min() >= minimum
                           and array.max() <= MAX_MAGNITUDE):
        raise ValueError(f"{key!r} holds a number outside [{minimum:g}, {MAX_MAGNITUDE:g}] "
                         f"(or NaN, Infinity)")
    return array


def _stat_ok(key: str, v) -> bool:
    if key in _NUMBER_RANGES:
        lo, hi, open_lo = _NUMBER_RANGES[key]
        return _is_number(v) and (v > lo if open_lo else v >= lo) and v <= hi
    if key in _INT_RANGES:
        lo, hi = _INT_RANGES[key]
        return type(v) is int and lo <= v <= hi
    if key == "radiometry":
        return v in _RADIOMETRY
    if key == "response":
        return isinstance(v, str) and 0 < len(v) <= 64 and v.isprintable()
    if key == "ringing":
        return isinstance(v, bool)
    if key == "coefficient_units":
        return v in _COEFFICIENT_UNITS
    if key == "meter_colour":
        return v in _METER_COLOURS
    if key in _METER_VECTORS:
        return (isinstance(v, list) and len(v) == 3 and all(_is_number(x) for x in v)
                and math.hypot(*v) <= 1.0 + 1e-6)
    if key == "min_irradiance":
        return (isinstance(v, list) and len(v) == 3
                and all(_is_number(x) and abs(x) <= MAX_MAGNITUDE for x in v))
    return (isinstance(v, list) and len(v) <= 64                  # exposures_s
            and all(_is_number(x) and 0 < x <= MAX_MAGNITUDE for x in v))


def relayed_stats(msg: dict) -> dict:
    """The optional fields of an upstream message that this provider passes on, each
    checked against its type and range (those of the JSON Schema); ValueError names the
    first malformed one."""
    stats = {}
    for k in _RELAY_STATS:
        if k in msg:
            if not _stat_ok(k, msg[k]):
                raise ValueError(f"field {k!r} is out of its type or range: {_show(msg[k])}")
            stats[k] = msg[k]
    return stats


def relayed_time(msg: dict, now: float) -> tuple[float, str | None]:
    """(the frame time, a note when it was corrected): the upstream's ``time``, or ``now``
    (the arrival time) when that clock cannot be right; ValueError when it is no number."""
    t = msg.get("time")
    if not _is_number(t):
        raise ValueError(f"'time' is not a finite number: {_show(t)}")
    if t < MIN_CLOCK:
        return now, f"upstream time {t:g} is before 2001 (a clock never set): arrival time used"
    if t > now + MAX_CLOCK_AHEAD_S:
        return now, (f"upstream time is {t - now:.3g} s ahead of this clock (more than "
                     f"{MAX_CLOCK_AHEAD_S:g} s): arrival time used")
    return float(t), None


def relayed_lights(msg: dict):
    """(lights, ambient coefficients (9, 3) or None, a note when lights were cut) of an
    upstream message (docs/contract.md §10); each light's key is its upstream slot
    (upstream sends its lights in a stable order). More than ``MAX_LIGHTS`` lights: the
    strongest (luminance of their irradiance) are kept in their order, the SH9 of the
    others is added to the ambient. ValueError names what breaks the contract."""
    k = msg.get("lights", 0)
    if type(k) is not int or k < 0:
        raise ValueError(f"'lights' is not a count: {_show(k)}")
    if "ambient_coefficients" not in msg:
        if k:
            raise ValueError(f"'lights' is {k} without 'ambient_coefficients'")
        return [], None, None             # an upstream from before lights
    ambient = _numbers(msg, "ambient_coefficients", 27).reshape(9, 3)
    if k == 0 and "light_directions" not in msg and "light_irradiance" not in msg:
        return [], ambient, None
    dirs = _numbers(msg, "light_directions", 3 * k).reshape(k, 3)
    irr = _numbers(msg, "light_irradiance", 3 * k, minimum=0.0).reshape(k, 3)
    radii, note = np.zeros(k), None
    if msg.get("light_angular_radius_deg") == [] and k:
        note = (f"upstream sent {k} lights and no 'light_angular_radius_deg': read as "
                f"point lights")
    elif "light_angular_radius_deg" in msg:
        radii = _numbers(msg, "light_angular_radius_deg", k, minimum=0.0)
        if k and radii.max() > 90.0:
            raise ValueError("'light_angular_radius_deg' holds a radius above 90 degrees")
    norms = np.linalg.norm(dirs, axis=1)
    if k and not norms.min() >= _MIN_DIRECTION:
        i = int(np.argmin(norms))
        raise ValueError(f"light {i}'s direction has length {norms[i]:.3g}: no direction")
    off = np.abs(norms - 1.0) > _UNIT_TOLERANCE
    dirs[off] /= norms[off, None]
    slots = np.arange(k)
    if k > MAX_LIGHTS:
        strength = irr @ _REC709
        slots = np.sort(np.argsort(-strength, kind="stable")[:MAX_LIGHTS])
        dropped = np.ones(k, bool)
        dropped[slots] = False
        ambient = ambient + sh.sh_basis(dirs[dropped]).T @ irr[dropped]
        if not np.abs(ambient).max() <= MAX_MAGNITUDE:
            raise ValueError(f"the SH9 of {k - MAX_LIGHTS} lights is out of range")
        note = "; ".join(filter(None, [
            note, f"upstream sent {k} lights (the contract allows {MAX_LIGHTS}): the "
                  f"{MAX_LIGHTS} strongest kept, the others added to the ambient"]))
    lights = [Light(dirs[s].copy(), irr[s].copy(), irr[s].copy(), 0.0, 0.0, key=int(s),
                    angular_radius_deg=float(radii[s])) for s in slots]
    return lights, ambient, note


def relayed_lighting(msg: dict, now: float) -> tuple[SH9Result, float, list[str]]:
    """(lighting, frame time, notes on what was corrected) of an upstream sh9 message,
    checked as described in the module docstring; the matrices are made here from the
    accepted coefficients. ValueError names the first field that breaks the contract."""
    coeffs = _numbers(msg, "coefficients", 27).reshape(9, 3)
    t, time_note = relayed_time(msg, now)
    lights, ambient, lights_note = relayed_lights(msg)
    stats = relayed_stats(msg)
    notes = [n for n in (time_note, lights_note) if n]
    return SH9Result(coeffs, sh.irradiance_matrices(coeffs), stats, lights, ambient), t, notes


class RelaySource(Source):
    """Subscribes to another ``shlight serve`` and re-serves its coefficients (edge device →
    PC → many headsets). Frames carry ready-made lighting, timed by the upstream frame
    time, so latency figures stay end-to-end. The probe is ``?probe=NAME`` (default: the
    upstream's first probe); ``?token=`` is passed on. Upstream messages marked stale are
    not relayed as fresh: this probe then goes stale too. Each message is checked and the
    relay is paced as the module docstring says."""

    def __init__(self, url: str, options: SourceOptions):
        super().__init__()
        self.url, self.options = url, options
        query = urllib.parse.parse_qs(urllib.parse.urlsplit(url).query)
        self.probe = query.get("probe", [None])[0]
        self.interval = 1.0 / (options.fps or RELAY_FPS)
        self._due: float | None = None  # monotonic time of the next slot (see _newest)
        self._ws = None
        # websockets' asyncio client on a loop of this source's own (the reading thread's):
        # one thread does all reads and writes. The threaded client reads in a thread of
        # its own while the caller writes, and OpenSSL forbids SSL_read and SSL_write on
        # one connection at once: over wss:// a request could be lost (a handshake that
        # times out now and then).
        self._loop: asyncio.AbstractEventLoop | None = None     # made by the first _run
        self._task: asyncio.Task | None = None

    def _run(self, coro, timeout: float | None = None):
        """Run ``coro`` on this source's loop, in the calling (reading) thread; raises
        :class:`Interrupted` when :meth:`interrupt` cancels it."""
        async def guarded():
            self._task = asyncio.current_task()
            if self._stop.is_set():
                getattr(coro, "close", lambda: None)()     # never awaited: no warning
                raise Interrupted()
            return await asyncio.wait_for(coro, timeout) if timeout else await coro
        if self._loop is None:
            self._loop = asyncio.new_event_loop()
        try:
            return self._loop.run_until_complete(guarded())
        except asyncio.CancelledError:
            raise Interrupted() from None
        finally:
            self._task = None

    def interrupt(self) -> None:
        super().interrupt()
        task = self._task
        if task is not None and self._loop is not None:
            try:
                self._loop.call_soon_threadsafe(task.cancel)
            except RuntimeError:        # the loop is closed: nothing to wake
                pass

    def open(self) -> None:
        from websockets.asyncio.client import connect
        try:
            self._ws = self._run(connect(self.url, open_timeout=self.options.timeout,
                                         close_timeout=1, compression=None, max_size=1 << 20,
                                         user_agent_header=USER_AGENT))
        except Interrupted:
            raise
        except Exception as exc:  # noqa: BLE001 - refused, HTTP 401/404, timeout...
            raise SourceError(f"{redact(self.url)}: {exc}") from None
        hello = self._recv()
        if hello.get("type") != "hello":
            raise SourceError("the upstream did not say hello")
        if self.probe is None:
            probes = hello.get("probes") or ["default"]
            self.probe = probes[0]
        self._send(json.dumps({"type": "subscribe", "probe": self.probe}))

    def _send(self, text: str) -> None:
        from websockets.exceptions import ConnectionClosed
        try:
            self._run(self._ws.send(text), self.options.timeout)
        except (TimeoutError, asyncio.TimeoutError):
            raise SourceError(f"upstream did not take a message in {self.options.timeout:g} s"
                              ) from None
        except ConnectionClosed as exc:
            raise SourceError(f"upstream closed the connection ({exc})") from None

    def _recv(self) -> dict:
        """The next message (``{}`` for JSON that is not an object); SourceError when none
        comes within the source timeout."""
        return self._run(self._message(None))

    async def _message(self, wait: float | None) -> dict | None:
        """The next message; with ``wait`` (seconds), None when none comes in that time,
        without: SourceError after the source timeout."""
        from websockets.exceptions import ConnectionClosed
        try:
            text = await asyncio.wait_for(self._ws.recv(), wait or self.options.timeout)
        except (TimeoutError, asyncio.TimeoutError):
            if wait is not None:
                return None             # cancelling recv() loses no message (websockets)
            raise SourceError(f"no message from upstream in {self.options.timeout:g} s") from None
        except ConnectionClosed as exc:
            raise SourceError(f"upstream closed the connection ({exc})") from None
        try:
            msg = json.loads(text)
        except ValueError:
            raise SourceError("upstream sent something that is not JSON") from None
        return msg if isinstance(msg, dict) else {}

    async def _newest(self) -> dict:
        """The newest fresh sh9 message of this probe received by the next slot (one every
        ``interval`` seconds): those before it are dropped unchecked. Past the slot, the
        first one that comes. (One coroutine per slot: a flood costs a JSON parse per
        message, not a turn of the event loop's machinery.)"""
        newest = None
        if self._due is None:
            self._due = time.monotonic()
        while True:
            left = self._due - time.monotonic()
            if newest is not None and left <= 0:
                break
            msg = await self._message(left if left > 0 else None)
            if msg is None:
                continue                # the slot came
            kind = msg.get("type")
            if kind == "error":
                raise SourceError(f"upstream error: {_show(msg.get('error'))}: "
                                  f"{_show(msg.get('detail', ''))}")
            if kind == "sh9" and not msg.get("stale") and msg.get("probe") == self.probe:
                newest = msg
        # as base.Pacer: a steady rate, at most one slot of catching up after a pause
        self._due = max(self._due + self.interval, time.monotonic() - self.interval)
        return newest

    def read(self) -> Frame:
        msg = self._run(self._newest())
        now = time.time()
        seq = msg.get("seq")
        info = {"upstream_seq": seq if type(seq) is int else None}
        try:
            lighting, t, notes = relayed_lighting(msg, now)
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            # One bad message is one rejected frame (counted by the probe, which keeps the
            # last good lighting); the connection and the messages after it are fine.
            reason = str(exc)[:160] if not isinstance(exc, KeyError) else f"no {exc}"
            info["rejected"] = f"upstream sent a malformed sh9 message ({reason})"
            return Frame(None, now, info=info)
        if notes:
            info["adjusted"] = "; ".join(notes)     # counted by the probe (frames_adjusted)
        return Frame(None, t, lighting=lighting, info=info)

    def close(self) -> None:
        if self._loop is None:
            return
        try:
            if self._ws is not None:
                self._loop.run_until_complete(self._ws.close())
        except Exception:  # noqa: BLE001 - closing a connection that already failed
            pass
        finally:
            self._ws = None
            self._loop.close()
            self._loop = None           # a later _run makes a new one; interrupt: nothing
