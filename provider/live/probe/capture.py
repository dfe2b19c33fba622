"""The capture thread: reads a source in the background and keeps only the newest frame.

:class:`Capture` runs a source in a background thread, so that slow or hung I/O never
blocks the event loop. It keeps only the newest frame (no backlog: a slow consumer sees
fewer frames, never older ones), reports the source as connected or lost, and after a
failure builds a *fresh* source object and reconnects with exponential backoff (an
OpenCV capture whose ``read()`` failed once does not recover: docs/contract.md §8). A read
that hangs (OpenCV on a dropped network stream) is detected by a watchdog: the stuck
thread is abandoned and a new attempt starts.
"""
from __future__ import annotations

import collections
import logging
import threading
import time

from ...core.errors import InputError
from ..sources import Frame, SourceError, SourceFinished, SourceSpec
from ..sources.base import Interrupted, Source, SourceUnavailable

log = logging.getLogger("shlight.source")

#: The slot of frames that report a refused file: good frames after them do not replace them.
_NOTICE = ("notice",)


class _Attempt:
    """One connection attempt: one fresh source object and the thread that reads it."""

    def __init__(self, number: int):
        self.number = number
        self.source: Source | None = None
        self.thread: threading.Thread | None = None
        self.started = time.monotonic()
        self.connected_at: float | None = None
        self.last_frame: float | None = None
        self.frames = 0
        self.error: str | None = None
        self.unavailable = False     # the source said retrying soon cannot help
        self.finished = False
        self.abandoned = False


class Capture:
    """Reads a source in background threads; keeps only the newest frame.

    * :meth:`take` returns the newest frame not yet taken (or None): frames that arrive
      while the consumer is busy replace each other, so there is never a backlog. A
      bracketing source's frames (``info["slot"]``) replace only frames of their own slot,
      so a slow consumer still sees every exposure of the cycle (at most one frame each).
      A frame that reports a file refused (``info["rejected"]`` or ``info["too_large"]``:
      the source says it once) is not replaced by the good frames after it either.
    * ``state`` is ``"connecting"``, ``"live"``, ``"lost"`` (retrying) or ``"finished"``;
      ``reason`` says why the source was lost. ``notify`` (a thread-safe callable, no
      arguments) is called after every new frame and every state change.
    * After a failure the source object is discarded and a fresh one is made by
      ``spec.make()`` after a backoff that doubles from ``backoff_min`` to ``backoff_max``
      (reset once an attempt has delivered frames).
    * A connected source that delivers no frame for ``hang_timeout`` seconds (or an open
      that takes that long) is declared hung: its thread is abandoned (it exits when its
      call returns) and a new attempt starts.
    """

    def __init__(self, spec: SourceSpec, *, name: str = "default", notify=None,
                 backoff_min: float = 0.5, backoff_max: float = 10.0,
                 hang_timeout: float | None = None):
        self.spec, self.name = spec, name
        self.notify = notify or (lambda: None)
        self.backoff_min, self.backoff_max = backoff_min, max(backoff_min, backoff_max)
        timeout = spec.options.timeout
        fps = spec.nominal_fps
        self.hang_timeout = hang_timeout or max(2.0 * timeout, 3.0 / fps if fps else 0.0)
        self.state = "connecting"
        self.reason = ""
        self.frames = 0
        self.reconnects = 0
        self.lost_since: float | None = None   # unix time the source was lost
        self._latest: dict = {}     # slot (None: not bracketing) -> newest frame, oldest first
        self._lock = threading.Lock()
        self._stopping = threading.Event()
        self._attempt: _Attempt | None = None
        self._arrivals = collections.deque(maxlen=90)
        self._thread: threading.Thread | None = None

    # -- the consumer's side --------------------------------------------------------------
    def start(self) -> None:
        self._thread = threading.Thread(target=self._supervise, daemon=True,
                                        name=f"capture-{self.name}")
        self._thread.start()

    def stop(self, timeout: float = 2.0) -> None:
        """Stop reading; returns within about ``timeout`` seconds (stuck threads are daemons)."""
        self._stopping.set()
        attempt = self._attempt
        if attempt is not None and attempt.source is not None:
            attempt.source.interrupt()
        if self._thread is not None:
            self._thread.join(timeout)

    def take(self) -> Frame | None:
        """The newest frame not yet taken, or None."""
        with self._lock:
            if not self._latest:
                return None
            return self._latest.pop(next(iter(self._latest)))

    def source_health(self) -> dict:
        """What the connected source says of its camera (a Theta: settings, battery,
        temperature), or {}."""
        attempt = self._attempt
        source = attempt.source if attempt is not None else None
        health = getattr(source, "health", None)
        return health() if callable(health) else {}

    @property
    def fps(self) -> float:
        """Frames per second delivered over the last two seconds or so."""
        with self._lock:
            times = list(self._arrivals)
        if len(times) < 2 or time.monotonic() - times[-1] > 2.0:
            return 0.0
        recent = [t for t in times if t >= times[-1] - 2.0]
        if len(recent) < 2:
            return 0.0
        return (len(recent) - 1) / max(recent[-1] - recent[0], 1e-6)

    # -- the threads ---------------------------------------------------------------------------
    def _set_state(self, state: str, reason: str = "") -> None:
        self.state, self.reason = state, reason
        self.notify()

    def _supervise(self) -> None:
        delay = self.backoff_min
        number = 0
        while not self._stopping.is_set():
            number += 1
            attempt = _Attempt(number)
            attempt.thread = threading.Thread(target=self._run_attempt, args=(attempt,),
                                              daemon=True, name=f"source-{self.name}-{number}")
            self._attempt = attempt
            attempt.thread.start()
            self._watch(attempt)
            if self._stopping.is_set():
                break
            if attempt.finished:
                log.info("probe %s: source finished (%s)", self.name, self.spec.description)
                self.lost_since = time.time()
                self._set_state("finished", "the source has no more frames")
                break
            if attempt.frames:
                delay = self.backoff_min
            reason = attempt.error or "unknown error"
            if attempt.unavailable:       # retrying soon cannot help: wait the longest
                delay = self.backoff_max
            # Say what is wrong once; retry quietly while it stays the same (a camera that
            # is not plugged in must not fill the log all day).
            if self.state != "lost":
                self.lost_since = time.time()
                log.warning("probe %s: source lost (%s): %s; retrying every %g s at most, "
                            "quietly while nothing changes", self.name,
                            self.spec.description, reason, self.backoff_max)
            elif reason != self.reason:
                log.info("probe %s: still no source, now: %s", self.name, reason)
            else:
                log.debug("probe %s: still no source (%s)", self.name, reason)
            self._set_state("lost", reason)
            log.debug("probe %s: reconnecting in %.1f s", self.name, delay)
            if self._stopping.wait(delay):
                break
            delay = min(delay * 2, self.backoff_max)
            self.reconnects += 1

    def _watch(self, attempt: _Attempt) -> None:
        """Wait for the attempt's thread to end; abandon it if it hangs."""
        while attempt.thread.is_alive() and not self._stopping.is_set():
            attempt.thread.join(0.1)
            since = attempt.last_frame or attempt.connected_at or attempt.started
            idle = time.monotonic() - since
            if attempt.thread.is_alive() and idle > self.hang_timeout:
                doing = "opening" if attempt.connected_at is None else "reading"
                attempt.error = f"hung while {doing} (nothing for {idle:.1f} s)"
                attempt.abandoned = True
                if attempt.source is not None:
                    attempt.source.interrupt()
                log.warning("probe %s: source %s: abandoning it and reconnecting",
                            self.name, attempt.error)
                return

    def _run_attempt(self, attempt: _Attempt) -> None:
        source = None
        try:
            source = attempt.source = self.spec.make()
            source.open()
            if attempt.abandoned or self._stopping.is_set():
                return
            attempt.connected_at = time.monotonic()
            if self.state == "lost":
                down = time.time() - (self.lost_since or time.time())
                log.info("probe %s: source reconnected after %.1f s (%s)", self.name, down,
                         self.spec.description)
            else:
                log.info("probe %s: source connected (%s)", self.name, self.spec.description)
            self._set_state("live")
            while not (attempt.abandoned or self._stopping.is_set()):
                frame = source.read()
                if attempt.abandoned:
                    break
                self._deliver(attempt, frame)
        except SourceFinished:
            attempt.finished = True
        except Interrupted:
            pass
        except Exception as exc:  # noqa: BLE001 - any failure means: lost, retry
            if not attempt.abandoned:
                attempt.error = _describe(exc)
                attempt.unavailable = isinstance(exc, SourceUnavailable)
        finally:
            if source is not None:
                try:
                    source.close()
                except Exception:  # noqa: BLE001
                    pass

    def _deliver(self, attempt: _Attempt, frame: Frame) -> None:
        now = time.monotonic()
        attempt.last_frame = now
        attempt.frames += 1
        info = frame.info or {}
        # a refusal the source reports once must reach the probe (counted, said in the log)
        slot = _NOTICE if info.get("rejected") or info.get("too_large") else info.get("slot")
        with self._lock:
            self._latest.pop(slot, None)
            self._latest[slot] = frame
            self.frames += 1
            self._arrivals.append(now)
        self.notify()


def _describe(exc: BaseException) -> str:
    if isinstance(exc, (SourceError, InputError)):
        return str(exc)
    if isinstance(exc, TimeoutError) or type(exc).__name__ == "timeout":
        return "timed out"
    if isinstance(exc, OSError) and exc.strerror:
        return exc.strerror
    return f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
