"""One connected WebSocket client: its outbox, its rate limit, its writer task."""
from __future__ import annotations

import asyncio
import collections
import logging
from dataclasses import dataclass, field

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed
from websockets.protocol import State

from .message import dumps

log = logging.getLogger("shlight.server")

#: Subscription to every probe.
ALL = "*"
#: With a rate cap, a message that comes at most this fraction of the cap's interval early
#: goes at once (a source at the cap's rate jitters: holding its messages would delay each
#: by up to a frame and skip some); one that comes earlier waits for its turn.
RATE_JITTER = 0.4


def text_frame(payload: bytes) -> bytes:
    """``payload`` as one unmasked, unfragmented WebSocket text frame (RFC 6455 §5.2): what
    a server sends, the same bytes for every client without compression, so built once per
    message for all of them."""
    n = len(payload)
    if n < 126:
        head = bytes((0x81, n))
    elif n < 1 << 16:
        head = bytes((0x81, 126)) + n.to_bytes(2, "big")
    else:
        head = bytes((0x81, 127)) + n.to_bytes(8, "big")
    return head + payload


@dataclass
class Counters:
    """Server-wide counters for /metrics."""

    connections: int = 0
    messages_sent: int = 0
    messages_skipped: int = 0       # replaced by a newer one before a slow client took it
    client_errors: int = 0          # malformed client messages answered with an error
    stalled_clients: int = 0        # disconnected because they stopped reading
    rejected: collections.Counter = field(default_factory=collections.Counter)


class ClientSession:
    """One connected client and its outbox.

    The outbox holds, per subscribed probe, only the newest message not yet sent, plus a
    few replies (hello, subscribed, error, pong). Publishing replaces the probe's slot and
    wakes :meth:`write_loop`, the only task that writes to this client: a client that
    reads slowly skips messages, and one that stops reading makes no memory grow and
    delays nobody else. Rate limiting (``max_hz``) leaves the newest message waiting in
    its slot until the client's next turn.
    """

    def __init__(self, ws: ServerConnection, counters: Counters, *, send_timeout: float):
        self.ws, self.counters, self.send_timeout = ws, counters, send_timeout
        host, port = (ws.remote_address or ("?", 0))[:2]
        self.label = f"{host}:{port}"
        self.subscription = ALL
        self.to: str | None = None      # another engine's layout (provider.live.export)
        self.max_hz = 0.0
        self.sent = 0
        self._slots: dict[str, bytes] = {}
        self._replies: collections.deque = collections.deque(maxlen=16)
        self._next_send: dict[str, float] = {}
        self._wake = asyncio.Event()
        self._timer: asyncio.TimerHandle | None = None
        # Frames may be written straight to the socket (see offer) unless this connection
        # compresses them (permessage-deflate: per-client bytes).
        self._direct = not ws.protocol.extensions

    def offer(self, probe: str, text: bytes, frame: bytes | None = None) -> None:
        """Make ``text`` the probe's pending message (replacing an unsent older one).

        ``frame`` (``text_frame(text)``, shared by all clients) is written to the socket at
        once when nothing else waits for this client and its socket has taken everything
        so far: the common case, with no task switch per client. Otherwise the message
        takes the slot and the writer task sends it (send timeout, latest only).
        """
        if frame is not None and self._direct and self._write_now(probe, frame):
            return
        if self._slots.get(probe) is not None:
            self.counters.messages_skipped += 1
        self._slots[probe] = text
        self._wake.set()

    def _write_now(self, probe: str, frame: bytes) -> bool:
        if self._replies or self._slots.get(probe) is not None:
            return False
        ws = self.ws
        transport = ws.transport
        if ws.protocol.state is not State.OPEN or transport.get_write_buffer_size():
            return False
        if self.max_hz > 0:
            now = asyncio.get_running_loop().time()
            if self._next_send.get(probe, 0.0) - now > RATE_JITTER / self.max_hz:
                return False
            self._next_send[probe] = self._next_after(probe, now)
        transport.write(frame)
        self.sent += 1
        self.counters.messages_sent += 1
        return True

    def _next_after(self, probe: str, now: float) -> float:
        """The probe's next turn after a message sent at ``now``: one interval (1/max_hz)
        after this turn, so that at most max_hz go on average (a message up to RATE_JITTER
        of an interval early still goes); after a pause, one interval after ``now`` less
        that tolerance, so that no burst follows a pause."""
        interval = 1.0 / self.max_hz
        return max(self._next_send.get(probe, now) + interval,
                   now + (1.0 - RATE_JITTER) * interval)

    def forget(self, probe: str) -> None:
        self._slots.pop(probe, None)

    def reply(self, message: dict) -> None:
        """Queue a control message (kept in order; the oldest dropped beyond 16)."""
        self._replies.append(dumps(message).encode())
        self._wake.set()

    async def write_loop(self) -> None:
        """Send replies and the newest message of each probe, until the connection ends."""
        loop = asyncio.get_running_loop()
        try:
            while True:
                await self._wake.wait()
                self._wake.clear()
                while self._replies:
                    await self._send(self._replies.popleft())
                for probe in list(self._slots):
                    text = self._slots.get(probe)
                    if text is None:
                        continue
                    now = loop.time()
                    wait = self._next_send.get(probe, 0.0) - now
                    if self.max_hz > 0 and wait > RATE_JITTER / self.max_hz:
                        self._wake_in(loop, wait)      # too early: wait for its turn
                        continue
                    self._slots[probe] = None
                    await self._send(text)
                    if self.max_hz > 0:
                        self._next_send[probe] = self._next_after(probe, now)
        except ConnectionClosed:
            pass
        except asyncio.CancelledError:
            raise
        except Exception:  # noqa: BLE001 - a bug here must not take the server down
            log.exception("client %s: writer failed; closing", self.label)
            self.ws.transport.abort()
        finally:
            if self._timer is not None:
                self._timer.cancel()

    def _wake_in(self, loop, delay: float) -> None:
        """Wake the writer in ``delay`` s, unless a pending wake-up comes sooner (with
        several rate-limited probes, the soonest one decides)."""
        now = loop.time()
        timer = self._timer
        if timer is not None and not timer.cancelled() and now < timer.when() <= now + delay:
            return
        if timer is not None:
            timer.cancel()
        self._timer = loop.call_later(delay, self._wake.set)

    async def _send(self, text: bytes) -> None:
        transport = self.ws.transport
        if transport.get_write_buffer_size() == 0:
            await self.ws.send(text, text=True)    # cannot block: the buffer is empty
        else:
            # A timer, not asyncio.wait_for: before Python 3.12 that can swallow the
            # writer's cancellation. Aborting the transport makes the send raise
            # ConnectionClosed, which ends the writer.
            timer = asyncio.get_running_loop().call_later(self.send_timeout, self._stalled)
            try:
                await self.ws.send(text, text=True)
            finally:
                timer.cancel()
        self.sent += 1
        self.counters.messages_sent += 1

    def _stalled(self) -> None:
        """The client has not read for ``send_timeout`` seconds: cut it off."""
        self.counters.stalled_clients += 1
        log.warning("client %s: not reading for %.0f s; disconnecting", self.label,
                    self.send_timeout)
        self.ws.transport.abort()
