"""A headset's passthrough camera fitted live against the probe's sphere (``serve --passthrough``).

The server's ``/capture`` route (docs/passthrough.md, docs/contract.md §15) hands each
headset's messages to its :class:`HeadsetFit`: a ``view`` text message (pose, intrinsics,
optional exposure fields) and then one binary message, the view's JPEG. The fit is the
offline one (:class:`~provider.core.passthrough.fit.PassthroughFit`), fed one view at a
time against the probe's latest linear frame (the same frame its SH9 comes from). The sphere
follows the room: a view that finds the probe with a newer frame than the fit's sphere, one
at least ``sphere_every_s`` seconds old, brings the fit onto that frame first
(:meth:`PassthroughFit.set_sphere`); views already sampled keep the sphere of their own time,
which is what they saw (a lamp switched on changes the room and the headset's frames alike):

* every accepted view is sampled (``add_view``) and answered with its exposure, white
  balance, EV100 and residual under the last curve (``estimate``: a median, milliseconds);
* every ``solve_every`` views or ``solve_interval_s`` seconds the joint fit is solved again,
  warm (a few rounds from the last curve), and the view is answered from it; a curve that
  moved is sent as ``passthrough_camera``;
* the work runs in the service's own worker threads (``workers``, one by default), never on
  the event loop nor in the probes' threads; a view that arrives while its headset's fit is
  busy, while every worker is, or sooner than ``1 / hz`` after the last one accepted is
  dropped with a reason and counted: nothing is queued;
* memory: each headset keeps its newest ``max_views`` views' samples (~160 kB a view) and one
  sphere of at most ``SPHERE_HEIGHT`` rows; at most ``max_headsets`` at once.

It may import provider.core (the maths) and is the server's only way to it.
"""
from __future__ import annotations

import asyncio
import collections
import json
import logging
import math
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ...core.errors import InputError
from .sphere import sphere_of

log = logging.getLogger("shlight.passthrough")

#: Views the fit needs before its first solve (answers before it use sRGB as the curve).
FIRST_SOLVE_VIEWS = 4
#: A curve that moves less than this (max |log ratio| over codes and channels) is not resent.
CURVE_CHANGE = 0.01
#: How much nicer than the probes the fitting threads run (Linux ``nice``, per thread).
WORKER_NICE = 10
#: JPEG files begin with SOI and another marker.
JPEG_MAGIC = b"\xff\xd8\xff"


@dataclass
class PassthroughSettings:
    """``serve --passthrough``'s bounds (docs/passthrough.md, "The live route")."""

    max_jpeg_bytes: int = 1 << 20     # a larger JPEG is answered with an error
    max_pixels: int = 4096 * 4096     # a view's declared w × h, and its JPEG's header
    max_views: int = 48               # views each headset's fit keeps (the newest)
    hz: float = 10.0                  # views fitted a second per headset (0: every view)
    solve_every: int = 8              # a warm solve every this many views...
    solve_interval_s: float = 5.0     # ...or this many seconds, whichever first
    workers: int = 1                  # threads fitting for all headsets together
    max_headsets: int = 4             # /capture connections at once
    max_text_bytes: int = 4096        # a view message (--max-message-bytes)
    sphere_every_s: float = 5.0       # the sphere follows the probe's frames at most this often


class PassthroughService:
    """The workers, the bounds and the counters shared by every headset."""

    def __init__(self, settings: PassthroughSettings | None = None):
        self.settings = s = settings or PassthroughSettings()
        self.executor = ThreadPoolExecutor(max(1, s.workers), thread_name_prefix="passthrough",
                                           initializer=_lower_priority)
        self.in_flight = 0
        self.headsets = 0
        self.views = 0                  # view images received
        self.fitted = 0                 # answered with a fit
        self.solves = 0
        self.dropped: collections.Counter = collections.Counter()   # reason -> views
        self.errors: collections.Counter = collections.Counter()    # code -> messages
        self.fit_seconds = 0.0
        self.sphere_updates = 0         # fits moved onto a newer probe frame

    def full(self) -> bool:
        return self.headsets >= self.settings.max_headsets

    def headset(self, probe, reply) -> "HeadsetFit":
        """A new headset's fit against ``probe``'s sphere; ``reply(dict)`` sends it a message
        (called on the event loop)."""
        return HeadsetFit(self, probe, reply)

    def close(self) -> None:
        self.executor.shutdown(wait=False, cancel_futures=True)

    def health(self) -> dict:
        return {"headsets": self.headsets, "views": self.views, "fitted": self.fitted,
                "solves": self.solves, "dropped": dict(self.dropped),
                "errors": dict(self.errors), "fit_seconds": round(self.fit_seconds, 3),
                "sphere_updates": self.sphere_updates,
                "sphere_every_s": self.settings.sphere_every_s,
                "max_headsets": self.settings.max_headsets, "hz": self.settings.hz,
                "max_views": self.settings.max_views,
                "max_jpeg_bytes": self.settings.max_jpeg_bytes}

    def add_metrics(self, m) -> None:
        m.add("shlight_passthrough_headsets", "gauge", "Headsets connected to /capture.",
              self.headsets)
        m.add("shlight_passthrough_views_total", "counter", "View images received on /capture.",
              self.views)
        m.add("shlight_passthrough_views_fitted_total", "counter",
              "Views answered with a fit.", self.fitted)
        m.add("shlight_passthrough_views_dropped_total", "counter",
              "Views dropped unfitted, by reason (busy, rate).",
              [({"reason": r}, n) for r, n in sorted(self.dropped.items())] or 0)
        m.add("shlight_passthrough_solves_total", "counter", "Joint solves.", self.solves)
        m.add("shlight_passthrough_sphere_updates_total", "counter",
              "Headset fits moved onto a newer probe frame.", self.sphere_updates)
        m.add("shlight_passthrough_errors_total", "counter",
              "/capture messages answered with an error, by code.",
              [({"error": r}, n) for r, n in sorted(self.errors.items())] or 0)


def _lower_priority() -> None:
    """The fitting thread yields the CPU to the probes' threads and the event loop (Linux
    nices threads one by one): a headset's views must not slow the lighting."""
    import os
    import threading
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), WORKER_NICE)
    except (AttributeError, OSError):      # not Linux, or not allowed: the default priority
        pass


class HeadsetFit:
    """One headset on ``/capture``: its pending view and its incremental fit (module doc).
    :meth:`on_message` is called on the event loop for every message it sends."""

    def __init__(self, service: PassthroughService, probe, reply):
        self.service, self.probe, self.reply = service, probe, reply
        self.settings = service.settings
        self.fit = None
        self._sphere_seq = None         # the probe frame (image_seq) the fit's sphere is
        self._sphere_at = -math.inf     # and when it was taken (monotonic s)
        self._view = None               # the view message waiting for its JPEG
        self._busy = False
        self._last_accepted = -math.inf
        self._since_solve = 0
        self._solved_at = -math.inf
        self._sent_curve = None         # the log table last sent as passthrough_camera
        self._last_exposure = None
        self.received = 0               # views (images) received on this socket
        self.dropped = 0
        service.headsets += 1

    def close(self) -> None:
        self.service.headsets -= 1

    # -- messages (event loop) ----------------------------------------------------------------
    def on_message(self, message) -> None:
        if isinstance(message, str):
            self._on_text(message)
        else:
            self._on_jpeg(bytes(message))

    def _error(self, code: str, detail: str) -> None:
        self.service.errors[code] += 1
        self.reply({"type": "error", "error": code, "detail": detail})

    def _on_text(self, text: str) -> None:
        from ...core.passthrough.views import view_from_record
        if len(text.encode()) > self.settings.max_text_bytes:
            return self._error("bad_request", f"a view message is at most "
                               f"{self.settings.max_text_bytes} bytes (--max-message-bytes)")
        try:
            msg = json.loads(text)
        except (ValueError, RecursionError) as exc:
            return self._error("bad_json", f"not JSON: {str(exc)[:200]}")
        if not isinstance(msg, dict) or msg.get("type") != "view":
            kind = msg.get("type") if isinstance(msg, dict) else None
            return self._error("unknown_type", f"unknown message type {str(kind)[:80]!r}; "
                               "/capture takes view messages, each followed by its JPEG")
        try:
            view = view_from_record(msg, "view", file_path=f"view {self.received}")
        except InputError as exc:
            self._view = None
            return self._error("bad_view", str(exc))
        if view.w * view.h > self.settings.max_pixels:
            self._view = None
            return self._error("too_large", f"view: {view.w}×{view.h} is more than "
                               f"{self.settings.max_pixels} pixels")
        self._view = view

    def _on_jpeg(self, data: bytes) -> None:
        from ...core.radiometry.image_size import header_size
        view, self._view = self._view, None
        if view is None:
            return self._error("bad_request", "a binary message must follow a view message "
                               "(its JPEG)")
        self.received += 1
        self.service.views += 1
        if len(data) > self.settings.max_jpeg_bytes:
            return self._error("too_large", f"the JPEG is {len(data)} bytes: at most "
                               f"{self.settings.max_jpeg_bytes} (--passthrough-max-jpeg-bytes)")
        if not data.startswith(JPEG_MAGIC):
            return self._error("not_jpeg", f"the binary message ({len(data)} bytes) is not a "
                               "JPEG")
        size = header_size(data)
        if size is not None and size != (view.w, view.h):
            return self._error("bad_view", f"the JPEG is {size[0]}×{size[1]} but the view "
                               f"says w {view.w}, h {view.h}")
        now = time.monotonic()
        s = self.settings
        reason = None
        if s.hz > 0 and now - self._last_accepted < 1.0 / s.hz:
            reason = "rate"
        elif self._busy or self.service.in_flight >= max(1, s.workers):
            reason = "busy"
        if reason is not None:
            self.dropped += 1
            self.service.dropped[reason] += 1
            return self.reply({"type": "passthrough", "dropped": True, "reason": reason,
                               "time": view.time, "dropped_views": self.dropped})
        self._last_accepted = now
        self._busy = True
        self.service.in_flight += 1
        loop = asyncio.get_running_loop()
        future = loop.run_in_executor(self.service.executor, self._work, view, data,
                                      self.received - 1)
        future.add_done_callback(self._done)

    def _done(self, future) -> None:
        self._busy = False
        self.service.in_flight -= 1
        if future.cancelled():
            return
        exc = future.exception()
        if isinstance(exc, InputError):
            return self._error("bad_view", str(exc))
        if exc is not None:
            log.error("passthrough fit failed: %s: %s", type(exc).__name__, exc)
            return self._error("fit_failed", f"{type(exc).__name__}: {str(exc)[:200]}")
        for message in future.result():
            self.reply(message)

    # -- the fit (a worker thread) -------------------------------------------------------------
    def _work(self, view, data: bytes, index: int) -> list[dict]:
        from ...core.radiometry.images import check_complete, decode_jpeg
        from ...core.radiometry.image_size import check_pixels
        t0 = time.perf_counter()
        check_complete(f"JPEG ({len(data)} bytes)", data)
        image, _ = decode_jpeg(data, f"corrupt JPEG ({len(data)} bytes)")
        check_pixels(image.shape[1], image.shape[0], self.settings.max_pixels, decoded=True)
        if image.shape[:2] != (view.h, view.w):
            raise InputError(f"the JPEG is {image.shape[1]}×{image.shape[0]} but the view "
                             f"says w {view.w}, h {view.h}")
        self._follow_the_room()
        self.fit.add_view(view, image)
        self._since_solve += 1
        s = self.settings
        now = time.monotonic()
        n = len(self.fit.views)
        out = []
        due = n >= FIRST_SOLVE_VIEWS and (self._sent_curve is None
                                          or self._since_solve >= s.solve_every
                                          or now - self._solved_at >= s.solve_interval_s)
        answer, solved = None, False
        if due:
            try:
                warm = self._sent_curve is not None
                result = self.fit.solve(warm=warm, iterations=4 if warm else 12)
            except InputError:
                result = None           # too few usable pixels yet: answered below
            if result is not None:
                self._since_solve, self._solved_at, solved = 0, now, True
                self.service.solves += 1
                table = np.log(result.response.table)
                if self._sent_curve is None or \
                        np.abs(table - self._sent_curve).max() > CURVE_CHANGE:
                    self._sent_curve = table
                    out.append({"type": "passthrough_camera",
                                "camera": result.response.to_dict()})
                if result.fitted[-1]:
                    answer = (float(result.exposure[-1]), result.wb_gains[-1],
                              float(result.residual_stops[-1]), int(result.samples[-1]))
        if answer is None:
            answer = self.fit.estimate(-1)
        self.service.fit_seconds += time.perf_counter() - t0
        out.insert(0, self._answer(view, index, answer, solved))
        return out

    def _follow_the_room(self) -> None:
        """The fit on the probe's newest frame: made on the first view, moved when the probe
        has a newer frame and the sphere is ``sphere_every_s`` old (a worker thread)."""
        from ...core.passthrough import PassthroughFit
        seq, now = getattr(self.probe, "image_seq", None), time.monotonic()
        if self.fit is None:
            self.fit = PassthroughFit(sphere_of(self.probe), max_views=self.settings.max_views)
        elif seq != self._sphere_seq and now - self._sphere_at >= self.settings.sphere_every_s:
            self.fit.set_sphere(sphere_of(self.probe))
            self.service.sphere_updates += 1
        else:
            return
        self._sphere_seq, self._sphere_at = seq, now

    def _answer(self, view, index: int, answer, solved: bool) -> dict:
        from ...core.radiometry.photometry import METER_K
        from ...core.radiometry.response import ANCHOR_VALUE
        msg = {"type": "passthrough", "time": view.time, "view": index}
        if answer is None:
            # nothing usable in this view (clipped, black, or where the sphere sees nothing):
            # the last exposure stands, said as not fitted
            msg.update(fitted=False, exposure=self._last_exposure, wb_gains=None, ev100=None,
                       residual_stops=None, samples=0)
        else:
            exposure, wb, resid, samples = answer
            self._last_exposure = exposure
            self.service.fitted += 1
            msg.update(exposure=exposure, wb_gains=[float(g) for g in wb],
                       ev100=math.log2(ANCHOR_VALUE / exposure * 100.0 / METER_K),
                       residual_stops=resid, samples=samples)
        msg.update(solved=solved, dropped_views=self.dropped)
        return msg
