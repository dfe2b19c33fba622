"""Relay: the coefficients of another ``shlight serve`` (edge device → PC → many headsets)."""
from __future__ import annotations

import asyncio
import json
import math
import time
import urllib.parse

import numpy as np

from ...core.engine import SH9Result
from ...core.lights_analysis import Light
from .base import USER_AGENT, Frame, Interrupted, Source, SourceError, SourceOptions, redact

_RELAY_STATS = ("compute_ms", "clipped_fraction", "order_error", "error_estimate",
                "coverage_sr", "negative_energy_fraction", "negative_pixels",
                "nonfinite_pixels", "order", "min_irradiance", "ringing", "window_cutoff",
                "light_error", "sh9_error", "light_candidates",
                "radiometry", "response", "exposure_s", "gain", "exposures_s",
                "clipped_light_fraction")


#: The type each relayed optional field must have (docs/contract.md §3, §9, §10).
_NUMBER, _INT, _STRING, _BOOL, _NUMBERS = "number", "integer", "string", "boolean", "numbers"
_RELAY_TYPES = {**{k: _NUMBER for k in ("compute_ms", "clipped_fraction", "order_error",
                                        "error_estimate", "coverage_sr",
                                        "negative_energy_fraction", "window_cutoff",
                                        "light_error", "sh9_error", "exposure_s", "gain",
                                        "clipped_light_fraction")},
                **{k: _INT for k in ("negative_pixels", "nonfinite_pixels", "order",
                                     "light_candidates")},
                "radiometry": _STRING, "response": _STRING, "ringing": _BOOL,
                "min_irradiance": _NUMBERS, "exposures_s": _NUMBERS}


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def relayed_stats(msg: dict) -> dict:
    """The optional fields of an upstream message that this provider passes on, each
    checked against its type; ValueError names the first malformed one."""
    stats = {}
    for k in _RELAY_STATS:
        if k not in msg:
            continue
        v, kind = msg[k], _RELAY_TYPES[k]
        ok = (_is_number(v) if kind == _NUMBER else
              isinstance(v, int) and not isinstance(v, bool) and abs(v) < 1 << 53
              if kind == _INT else
              isinstance(v, str) and len(v) <= 200 if kind == _STRING else
              isinstance(v, bool) if kind == _BOOL else
              isinstance(v, list) and len(v) <= 64 and all(map(_is_number, v)))
        if not ok:
            raise ValueError(f"field {k!r} is not a valid {kind}: {str(v)[:40]!r}")
        stats[k] = v
    return stats


def relayed_lights(msg: dict):
    """(lights, ambient coefficients (9, 3) or None) of an upstream message (docs/contract.md §10);
    each light's key is its slot (upstream sends its lights in a stable order)."""
    if "ambient_coefficients" not in msg:
        return [], None             # an upstream from before lights
    k = int(msg.get("lights", 0))
    dirs = np.asarray(msg.get("light_directions", []), np.float64).reshape(k, 3)
    irr = np.asarray(msg.get("light_irradiance", []), np.float64).reshape(k, 3)
    lights = [Light(d, i, i.copy(), 0.0, 0.0, key=slot)
              for slot, (d, i) in enumerate(zip(dirs, irr))]
    return lights, np.asarray(msg["ambient_coefficients"], np.float64).reshape(9, 3)


class RelaySource(Source):
    """Subscribes to another ``shlight serve`` and re-serves its coefficients (edge device →
    PC → many headsets). Frames carry ready-made lighting, timed by the upstream frame
    time, so latency figures stay end-to-end. The probe is ``?probe=NAME`` (default: the
    upstream's first probe); ``?token=`` is passed on. Upstream messages marked stale are
    not relayed as fresh: this probe then goes stale too."""

    def __init__(self, url: str, options: SourceOptions):
        super().__init__()
        self.url, self.options = url, options
        query = urllib.parse.parse_qs(urllib.parse.urlsplit(url).query)
        self.probe = query.get("probe", [None])[0]
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
        from websockets.exceptions import ConnectionClosed
        try:
            text = self._run(self._ws.recv(), self.options.timeout)
        except (TimeoutError, asyncio.TimeoutError):
            raise SourceError(f"no message from upstream in {self.options.timeout:g} s") from None
        except ConnectionClosed as exc:
            raise SourceError(f"upstream closed the connection ({exc})") from None
        try:
            msg = json.loads(text)
        except ValueError:
            raise SourceError("upstream sent something that is not JSON") from None
        return msg if isinstance(msg, dict) else {}

    def read(self) -> Frame:
        while True:
            if self._stop.is_set():
                raise Interrupted()
            msg = self._recv()
            kind = msg.get("type")
            if kind == "error":
                raise SourceError(f"upstream error: {msg.get('error')}: {msg.get('detail', '')}")
            if kind != "sh9" or msg.get("stale") or msg.get("probe") != self.probe:
                continue
            try:
                coeffs = np.asarray(msg["coefficients"], np.float64).reshape(9, 3)
                mats = np.asarray(msg["matrices"], np.float64).reshape(3, 4, 4)
                t = float(msg["time"])
                if not (math.isfinite(t) and np.all(np.isfinite(coeffs))
                        and np.all(np.isfinite(mats))):
                    raise ValueError("non-finite numbers")
                lights, ambient = relayed_lights(msg)
                stats = relayed_stats(msg)
            except (KeyError, TypeError, ValueError, OverflowError) as exc:
                # One bad message is one rejected frame (counted by the probe); the
                # connection and the messages after it are fine.
                reason = str(exc)[:120] if not isinstance(exc, KeyError) else f"no {exc}"
                return Frame(None, time.time(), info={
                    "upstream_seq": msg.get("seq"),
                    "rejected": f"upstream sent a malformed sh9 message ({reason})"})
            return Frame(None, t, lighting=SH9Result(coeffs, mats, stats, lights, ambient),
                         info={"upstream_seq": msg.get("seq")})

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
