"""One connected WebSocket client: its outbox, its rate limit, its writer task."""
from __future__ import annotations

import asyncio
import collections
import logging
import time
from dataclasses import dataclass, field

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed
from websockets.protocol import State

from ..wire.message import dumps

log = logging.getLogger("shlight.server")

#: Subscription to every probe.
ALL = "*"
#: The rate cap (max_hz) is a token bucket per client and probe: a message takes a token,
#: the bucket holds 1 + RATE_SLACK and refills at max_hz × (1 + RATE_MARGIN). The slack lets
#: a source at the cap's rate through although its frames jitter (a frame may come up to
#: RATE_SLACK of an interval early); the margin heals what a burst took (two frames close
#: together after a stall): at exactly max_hz, one message too many would delay every later
#: one for good. So no message of a source at the cap's rate waits for long, and none is
#: skipped. A faster source is held to max_hz (+ RATE_MARGIN) on average, its messages evenly
#: spaced (never closer than RATE_SPACING of an interval), each the newest when it goes.
RATE_SLACK = 0.5
RATE_MARGIN = 0.1
RATE_SPACING = 0.25

#: websockets' write_limit for every connection (service.serve): above it a send waits for
#: the socket. A payload below it sent into an empty buffer never waits.
WRITE_LIMIT = 1 << 15
#: How the server knows a client stopped reading: with a write, at most once every
#: STALL_PING_SHARE × ``send_timeout``, it pings the client; the pong proves that the client
#: read everything sent before the ping, and a later write that finds the ping unanswered
#: after ``send_timeout`` drops the client. The kernel's buffers cannot tell: a client that
#: stops reading keeps acknowledging TCP data into its own receive buffer until that is
#: full, seconds of cubes (issue 41: dropped after 18-19 s with --send-timeout 10). So a
#: client is dropped at most ``send_timeout`` × (1 + STALL_PING_SHARE) and one message
#: interval after it stopped reading (a write that waits on a full socket has its own timer).
#: One ping every 2.5 s per client at the default 10 s, in the same write as a message and
#: with no timer: at 1,000 clients a ping per write or a timer per ping cost the fan-out.
STALL_PING_SHARE = 0.25
#: The server's stall pings: "sl" and a counter (a client's pong echoes it).
_PING_HEAD = bytes((0x89, 8))

#: The frame being fanned out and the loop time its fan-out began: the rate cap judges a
#: message by when it was published, not by the client's place in the fan-out (with
#: thousands of clients the last ones are offered it milliseconds after the first: jitter).
_fanout: list = [None, 0.0]


def _published_at(frame: bytes, loop) -> float:
    if _fanout[0] is not frame:
        _fanout[0], _fanout[1] = frame, loop.time()
    return _fanout[1]


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


def binary_frame(payload: bytes) -> bytes:
    """``payload`` as one unmasked, unfragmented WebSocket binary frame (opcode 2): like
    :func:`text_frame`, built once per reflection cube for every client."""
    framed = text_frame(payload)
    return bytes((0x82,)) + framed[1:]


@dataclass
class Counters:
    """Server-wide counters for /metrics."""

    connections: int = 0
    messages_sent: int = 0
    messages_skipped: int = 0       # replaced by a newer one before a slow client took it
    client_errors: int = 0          # malformed client messages answered with an error
    stalled_clients: int = 0        # disconnected because they stopped reading
    messages_held: int = 0          # waited for their turn under a client's max_hz
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
        self.to: str | None = None      # another engine's layout (provider.live.wire.export)
        self.max_hz = 0.0
        self.sent = 0
        self._slots: dict[str, bytes] = {}
        self._replies: collections.deque = collections.deque(maxlen=16)
        self._tokens: dict[str, tuple[float, float]] = {}   # probe -> (tokens, at loop time)
        self._last_sent: dict[str, float] = {}              # probe -> loop time
        self._unmetered: set[str] = set()   # probes whose pending message skips the budget
        self._slot_at: dict[str, float] = {}  # probe -> when its pending message was published
        self._wake = asyncio.Event()
        self._timer: asyncio.TimerHandle | None = None
        # Frames may be written straight to the socket (see offer) unless this connection
        # compresses them (permessage-deflate: per-client bytes).
        self._direct = not ws.protocol.extensions
        # Reflections (docs/contract.md §12), only for a client that asked: per probe the
        # newest (environment message, KTX2 bytes) pair not yet sent; a pair is written as
        # one, never with another message between its two frames.
        self.environment = False
        self._cubes: dict[str, tuple[bytes, bytes] | None] = {}
        self._pair_in_flight = False
        # Stall pings (STALL_PING_SHARE): the one not answered yet, when the next may go.
        self._ping_out: bytes | None = None
        self._ping_sent = 0.0
        self._next_ping = 0.0
        self._pings = 0
        self._dropped = False
        ws.pong_seen = self.pong_seen

    def offer(self, probe: str, text: bytes, frame: bytes | None = None) -> None:
        """Make ``text`` the probe's pending message (replacing an unsent older one).

        ``frame`` (``text_frame(text)``, shared by all clients) is written to the socket at
        once when nothing else waits for this client and its socket has taken everything
        so far: the common case, with no task switch per client. Otherwise the message
        takes the slot and the writer task sends it (send timeout, latest only). Without
        ``frame`` (the latest message, offered on subscribing) it goes at once, whatever
        the ``max_hz`` budget holds: a client's first lighting never waits.
        """
        if frame is not None and self._direct and self._write_now(probe, frame):
            return
        if self._slots.get(probe) is not None:
            self.counters.messages_skipped += 1
        self._slots[probe] = text
        loop = asyncio.get_running_loop()
        self._slot_at[probe] = loop.time() if frame is None else _published_at(frame, loop)
        if frame is None:
            self._unmetered.add(probe)
        else:
            self._unmetered.discard(probe)
        self._wake.set()

    def offer_environment(self, probe: str, text: bytes, data: bytes,
                          frames: bytes | None = None) -> bool:
        """Make (``text``, ``data``) the probe's pending cube, replacing an unsent older one
        (a slow client gets the newest cube only). ``frames``: both, framed once for every
        client, written at once when nothing waits (as :meth:`offer`). True if it replaced
        an unsent one."""
        if frames is not None and self._direct and self._write_now(probe, frames, pair=True):
            return False
        replaced = self._cubes.get(probe) is not None
        self._cubes[probe] = (text, data)
        self._wake.set()
        return replaced

    def _write_now(self, probe: str, frame: bytes, pair: bool = False) -> bool:
        if self._replies or self._pair_in_flight or self._slots.get(probe) is not None:
            return False
        if pair and self._cubes.get(probe) is not None:
            return False
        ws = self.ws
        transport = ws.transport
        if ws.protocol.state is not State.OPEN or transport.get_write_buffer_size():
            return False
        if self.max_hz > 0 and not pair and self._rate_wait(   # cubes: --environment-hz
                probe, _published_at(frame, asyncio.get_running_loop())):
            self.counters.messages_held += 1
            return False
        if self._ping_out is None:
            now = time.monotonic()
            if now >= self._next_ping:
                frame += self._ping(now)    # one write: the message, then the ping
        elif time.monotonic() - self._ping_sent > self.send_timeout:
            self._stalled()
            return True
        transport.write(frame)
        self.sent += 1 + pair
        self.counters.messages_sent += 1 + pair
        return True

    def _ping(self, now: float) -> bytes:
        """The next stall ping's frame (see STALL_PING_SHARE), counted as out from ``now``."""
        self._pings += 1
        payload = b"sl%06d" % (self._pings % 1000000)
        self._ping_out, self._ping_sent = payload, now
        self._next_ping = now + self.send_timeout * STALL_PING_SHARE
        return _PING_HEAD + payload

    def _watch(self, transport) -> None:
        """After the writer's send: ping, or drop the client whose ping is overdue."""
        now = time.monotonic()
        if self._ping_out is None:
            if now >= self._next_ping:
                transport.write(self._ping(now))
        elif now - self._ping_sent > self.send_timeout:
            self._stalled()

    def pong_seen(self, data: bytes) -> None:
        """A pong arrived (:class:`~provider.live.server.limits.BudgetedConnection`): the
        client read up to its ping."""
        if data == self._ping_out:
            self._ping_out = None

    def _rate_wait(self, probe: str, now: float, force: bool = False) -> float:
        """0 if a message of ``probe`` may go at ``now`` (loop time; its token is taken),
        else the seconds until it may (see RATE_SLACK). ``force``: it goes anyway, taking
        what tokens there are."""
        if self.max_hz <= 0:
            return 0.0
        full = 1.0 + RATE_SLACK
        tokens, at = self._tokens.get(probe, (full, now))
        now = max(now, at)          # a publish time may precede the writer's last look
        tokens = min(full, tokens + (now - at) * self.max_hz * (1.0 + RATE_MARGIN))
        self._tokens[probe] = (tokens, now)
        wait = max((1.0 - tokens) / (self.max_hz * (1.0 + RATE_MARGIN)),
                   self._last_sent.get(probe, -1e9) + RATE_SPACING / self.max_hz - now)
        if wait > 0 and not force:
            return wait
        self._tokens[probe] = (max(tokens - 1.0, 0.0), now)
        self._last_sent[probe] = now
        return 0.0

    def _may_send(self, probe: str, loop) -> bool:
        """Whether the writer may send the probe's pending message now (its budget charged
        at its publish time, or when its turn came: a writer running late charges no later
        than that); if not, the writer is woken at its turn."""
        if probe in self._unmetered or self.max_hz <= 0:
            self._unmetered.discard(probe)
            self._rate_wait(probe, loop.time(), force=True)
            return True
        at = self._slot_at.get(probe, loop.time())
        wait = self._rate_wait(probe, at)
        if wait <= 0:
            return True
        turn, now = at + wait, loop.time()
        if now < turn:
            self._wake_in(loop, turn - now)     # too early: wait for its turn
            return False
        self._rate_wait(probe, turn, force=True)
        return True

    def forget(self, probe: str) -> None:
        self._slots.pop(probe, None)
        self._cubes.pop(probe, None)

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
                    if not self._may_send(probe, loop):
                        continue
                    self._slots[probe] = None
                    await self._send(text)
                for probe in list(self._cubes):
                    pair = self._cubes.get(probe)
                    if pair is None:
                        continue
                    self._cubes[probe] = None
                    self._pair_in_flight = True
                    try:
                        await self._send(pair[0])
                        await self._send(pair[1], text=False)
                    finally:
                        self._pair_in_flight = False
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

    async def _send(self, payload: bytes, text: bool = True) -> None:
        transport = self.ws.transport
        if transport.get_write_buffer_size() == 0 and len(payload) < WRITE_LIMIT:
            await self.ws.send(payload, text=text)    # cannot block: the buffer takes it
        else:
            # A timer, not asyncio.wait_for: before Python 3.12 that can swallow the
            # writer's cancellation. Aborting the transport makes the send raise
            # ConnectionClosed, which ends the writer.
            timer = asyncio.get_running_loop().call_later(self.send_timeout, self._stalled)
            try:
                await self.ws.send(payload, text=text)
            finally:
                timer.cancel()
        if self.ws.protocol.state is State.OPEN:
            self._watch(transport)
        self.sent += 1
        self.counters.messages_sent += 1

    def _stalled(self) -> None:
        """The client has not read for ``send_timeout`` seconds: cut it off."""
        if self._dropped:       # the send timer and an overdue ping may both find it
            return
        self._dropped = True
        self.counters.stalled_clients += 1
        log.warning("client %s: not reading for %.0f s; disconnecting", self.label,
                    self.send_timeout)
        self.ws.transport.abort()
