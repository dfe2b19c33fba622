"""Limits ``shlight serve`` owns, so that no client can take the server from the others.

* :class:`TokenBucket`: a rate with a burst (and an optional debt), the building block.
* :class:`BudgetedConnection`: a WebSocket connection with a per-client budget on what it
  receives. Bytes: beyond ``byte_rate`` (bytes/s, after a burst) the socket is simply not
  read (TCP back-pressure: the flooder waits, the event loop does not). Frames (messages,
  pings, pongs alike): beyond ``frame_rate`` (frames/s, after a burst) data messages are
  dropped unread; a client that keeps going ``frame_burst`` frames past its budget is
  closed with code 1008 (policy violation). websockets' own limits stay in force as well:
  ``max_size`` (one message: close 1009) and ``max_queue`` (messages the handler has not
  taken yet: the socket is not read).
* :class:`ConnectRate`: WebSocket handshakes per client address (a token bucket each):
  a client that reconnects at once each time it is closed would otherwise cost the server
  a handshake per attempt; beyond the rate it gets HTTP 429 with ``Retry-After``.
* :class:`HostCheck`: the ``Host`` header allow-list against DNS rebinding (a page of
  ``evil.example`` whose name is made to resolve to 127.0.0.1 sends ``Host:
  evil.example``).
* :func:`raise_open_files_limit` and :func:`client_capacity`: clients need one file
  descriptor each; the effective ``--max-clients`` stays below the process's limit.
* :class:`RepeatFilter`: identical log lines (same logger, same text before formatting)
  are let through once per interval, with a count of those held back.

No I/O beyond the sockets and ``resource`` limits; all times are ``time.monotonic()``
seconds unless said otherwise.
"""
from __future__ import annotations

import asyncio
import ipaddress
import logging
import math
import re
import socket
import time

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import InvalidMessage
from websockets.frames import CloseCode, Opcode
from websockets.protocol import State
from websockets.server import ServerProtocol

log = logging.getLogger("shlight.server")


class TokenBucket:
    """``rate`` tokens per second up to ``burst``; :meth:`take` may run into a debt of
    ``debt`` tokens (then it answers False)."""

    def __init__(self, rate: float, burst: float, debt: float = 0.0, now: float | None = None):
        self.rate, self.burst, self.debt = float(rate), float(burst), float(debt)
        self.tokens = float(burst)
        self._at = time.monotonic() if now is None else now

    def refill(self, now: float | None = None) -> float:
        """The tokens available now."""
        now = time.monotonic() if now is None else now
        self.tokens = min(self.burst, self.tokens + (now - self._at) * self.rate)
        self._at = now
        return self.tokens

    def take(self, amount: float = 1.0, now: float | None = None) -> bool:
        """Take ``amount``: True if the budget had it; else False, and the debt grows."""
        if self.refill(now) >= amount:
            self.tokens -= amount
            return True
        self.tokens = max(self.tokens - amount, -self.debt)
        return False

    @property
    def exhausted(self) -> bool:
        """The debt is at its limit: the client went on far past its budget."""
        return self.debt > 0 and self.tokens <= -self.debt

    def wait_for(self, amount: float) -> float:
        """Seconds until ``amount`` tokens are available (0: now)."""
        return max(0.0, (amount - self.refill()) / self.rate)


class LimitCounters:
    """What the limits did, server-wide (for /metrics)."""

    def __init__(self):
        self.frames_dropped = 0         # client messages dropped past the budget
        self.policy_closes = 0          # clients closed with 1008 for flooding
        self.throttled_reads = 0        # times a client's socket was left unread


class ConnectRate:
    """WebSocket handshakes one address may start: ``rate`` a second after a burst of
    ``burst`` (a :class:`TokenBucket` per address; ``rate`` 0: no limit). 127.0.0.1 and ::1
    are not limited: this machine's own programs (a reverse proxy, the bench's thousand
    clients) connect from there, and a proxy limits its clients itself. Addresses whose
    bucket is full again are forgotten once more than ``max_addresses`` are known, so the
    table stays small under a scan of many addresses.

    :meth:`admit` holds a handshake past the rate until the address's turn (a sleeping
    coroutine: no CPU) instead of refusing it at once, so that a client which reconnects
    at once each time it is refused waits its turn instead of costing a refusal per
    round trip; past ``HOLD_MAX_S``, or beyond ``HOLD_PER_ADDRESS`` held at once, HTTP 429."""

    EXEMPT = frozenset({"127.0.0.1", "::1", "::ffff:127.0.0.1"})
    HOLD_MAX_S = 2.0
    HOLD_PER_ADDRESS = 4

    def __init__(self, rate: float, burst: float, max_addresses: int = 4096):
        self.rate, self.burst, self.max_addresses = float(rate), float(burst), max_addresses
        self._buckets: dict[str, TokenBucket] = {}
        self._held: dict[str, int] = {}     # address -> handshakes held now

    async def admit(self, address: str | None):
        """None once ``address`` may go on with its WebSocket handshake (at once, or after
        waiting its turn), else the refusal as :func:`early_refusal` gives it (429)."""
        wait = self.retry_after(address)
        held = self._held.get(address, 0)
        if wait > 0 and held < self.HOLD_PER_ADDRESS:
            self._held[address] = held + 1
            try:
                await asyncio.sleep(min(wait, self.HOLD_MAX_S))
            finally:
                if self._held[address] <= 1:
                    del self._held[address]
                else:
                    self._held[address] -= 1
            wait = self.retry_after(address)
        if wait == 0:
            return None
        return (429, "connect_rate", f"too many WebSocket connections from {address} "
                f"({self.rate:g} a second after {self.burst:g}; see --connect-rate): retry "
                f"in {wait:.1f} s", [("Retry-After", str(max(1, math.ceil(wait))))])

    def retry_after(self, address: str | None, now: float | None = None) -> float:
        """0 if ``address`` may start a handshake now (and count it), else the seconds
        until it may."""
        if not self.rate or address is None or address in self.EXEMPT:
            return 0.0
        bucket = self._buckets.get(address)
        if bucket is None:
            if len(self._buckets) >= self.max_addresses:
                self._forget_full(now)
            bucket = self._buckets[address] = TokenBucket(self.rate, self.burst, now=now)
        tokens = bucket.refill(now)        # a refused attempt takes nothing: no lock-out
        if tokens >= 1.0:
            bucket.tokens -= 1.0
            return 0.0
        return (1.0 - tokens) / self.rate

    def _forget_full(self, now: float | None) -> None:
        self._buckets = {a: b for a, b in self._buckets.items() if b.refill(now) < b.burst}
        if len(self._buckets) >= self.max_addresses:   # all busy: start over, each limited
            self._buckets.clear()

    def __len__(self) -> int:
        return len(self._buckets)


#: The kernel send buffer of each connection (Linux doubles it: 128 KiB in all): about three
#: seconds of a probe's messages at 30 a second, or one 32² reflection cube.
SEND_BUFFER_BYTES = 64 * 1024


class BudgetedConnection(ServerConnection):
    """A :class:`ServerConnection` with a budget on what the client sends (see the module
    docstring). Made by ``serve(create_connection=...)`` through :meth:`factory`."""

    byte_rate = 16384.0                 # bytes per second
    byte_burst = 8192.0
    frame_rate = 20.0                   # frames per second
    frame_burst = 50.0
    counters: LimitCounters | None = None
    silent = None                       # admission.SilentConnections: before the request
    pong_seen = None                    # the session's pong hook (session.STALL_PING_SHARE)

    @classmethod
    def factory(cls, settings, counters: LimitCounters, silent=None):
        """A subclass with the budgets of ``settings`` (a
        :class:`~provider.live.server.service.ServeSettings`: ``client_frame_rate``,
        ``client_frame_burst``, ``client_byte_rate``, 0: four largest messages a second);
        ``serve(create_connection=...)`` calls it as it calls a class. ``silent``: the
        :class:`~provider.live.server.admission.SilentConnections` that holds each
        connection until its request head arrives."""
        size = settings.max_message_bytes
        byte_rate = settings.client_byte_rate or 4.0 * size
        return type("BudgetedConnection", (cls,), {
            "byte_rate": float(byte_rate), "byte_burst": max(byte_rate, 2.0 * size + 64),
            "frame_rate": float(settings.client_frame_rate),
            "frame_burst": float(settings.client_frame_burst), "counters": counters,
            "silent": silent})

    def __init__(self, protocol, *args, **kwargs):
        super().__init__(protocol, *args, **kwargs)
        if type(protocol) is ServerProtocol and protocol.state is State.CONNECTING:
            # Nothing received yet: parse the request with the subclass that answers a
            # request with a body (the server takes none) with 400 instead of a silent close.
            protocol.__class__ = _RequestCheckingProtocol
            protocol.parser = protocol.parse()
            next(protocol.parser)
        self._bytes = TokenBucket(self.byte_rate, self.byte_burst)
        self._frames = TokenBucket(self.frame_rate, self.frame_burst, debt=self.frame_burst)
        self._pending = b""             # received but not yet given to the protocol
        self._feed_timer = None
        self._paused_by_queue = False   # websockets' max_queue
        self._paused_by_budget = False
        self.frames_dropped = 0
        self.peer_address = None        # set when accepted

    def rebudget(self, *, byte_rate: float, byte_burst: float, frame_rate: float,
                 frame_burst: float, max_size: int) -> None:
        """Another budget for this connection, set in its handshake (a route whose messages
        are larger or more frequent than the lighting's: ``/capture``'s JPEGs)."""
        self._bytes = TokenBucket(byte_rate, byte_burst)
        self._frames = TokenBucket(frame_rate, frame_burst, debt=frame_burst)
        self.byte_rate, self.byte_burst, self.frame_rate = byte_rate, byte_burst, frame_rate
        self.protocol.max_message_size = max_size

    # -- reading: the byte budget ----------------------------------------------------------
    def connection_made(self, transport) -> None:
        super().connection_made(transport)
        # websockets pauses reading while its queue is full and resumes when it drains;
        # the byte budget pauses it too: the socket is read again only when neither holds.
        self.recv_messages.pause = lambda: self._pause(queue=True)
        self.recv_messages.resume = lambda: self._resume(queue=True)
        self.peer_address = (self.remote_address or (None,))[0]
        sock = transport.get_extra_info("socket")
        if sock is not None and sock.family in (socket.AF_INET, socket.AF_INET6):
            # A bounded kernel send buffer (Linux would grow it to megabytes), so that a
            # client whose connection stops taking data fills it within seconds and
            # --send-timeout counts from then, not after megabytes have queued.
            try:
                sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER_BYTES)
            except OSError:
                pass
        if self.silent is not None:
            self.silent.opened(self, self.peer_address)

    def _pause(self, *, queue: bool) -> None:
        was = self._paused_by_queue or self._paused_by_budget
        if queue:
            self._paused_by_queue = True
        else:
            self._paused_by_budget = True
        if not was:
            self.transport.pause_reading()

    def _resume(self, *, queue: bool) -> None:
        if queue:
            self._paused_by_queue = False
        else:
            self._paused_by_budget = False
        if not (self._paused_by_queue or self._paused_by_budget):
            self.transport.resume_reading()

    def data_received(self, data: bytes) -> None:
        if not self._pending and self._bytes.take(len(data)):
            super().data_received(data)
            return
        self._pending += data
        if not self._paused_by_budget:
            if self.counters is not None:
                self.counters.throttled_reads += 1
            self._pause(queue=False)
        self._feed()

    def _feed(self) -> None:
        """Give the protocol what the budget allows of the pending bytes; come back later
        for the rest."""
        self._feed_timer = None
        if self.transport is None or self.transport.is_closing():
            self._pending = b""
            return
        n = min(len(self._pending), int(self._bytes.refill()))
        if n > 0:
            chunk, self._pending = self._pending[:n], self._pending[n:]
            self._bytes.take(n)
            super().data_received(chunk)
        if self._pending:
            wait = self._bytes.wait_for(min(len(self._pending), self.byte_burst))
            self._feed_timer = self.loop.call_later(max(wait, 0.005), self._feed)
        elif self._paused_by_budget:
            self._resume(queue=False)

    def connection_lost(self, exc) -> None:
        if self.silent is not None:
            self.silent.closed(self, self.peer_address)
        if self._feed_timer is not None:
            self._feed_timer.cancel()
        self._pending = b""
        super().connection_lost(exc)

    # -- frames: the message budget --------------------------------------------------------
    def process_event(self, event) -> None:
        if self.request is None and self.silent is not None:   # the request head: it spoke
            self.silent.spoke(self, self.peer_address)
        opcode = getattr(event, "opcode", None)
        if opcode is Opcode.PONG and self.pong_seen is not None:
            self.pong_seen(event.data)
        if opcode is Opcode.CLOSE or self.protocol.state is not State.OPEN:
            super().process_event(event)
            return
        if self._frames.take():
            super().process_event(event)
            return
        if self._frames.exhausted:
            if self.counters is not None:
                self.counters.policy_closes += 1
            log.warning("client %s: closed: more than %g messages per second (policy)",
                        _peer(self), self.frame_rate)
            self.protocol.fail(CloseCode.POLICY_VIOLATION, "too many messages")
            self.send_data()
            return
        # Past the budget: a whole data message is dropped unread; parts of a fragmented
        # message and control frames still go through (dropping them would break the
        # stream), but they count.
        if opcode in (Opcode.TEXT, Opcode.BINARY) and event.fin:
            self.frames_dropped += 1
            if self.counters is not None:
                self.counters.frames_dropped += 1
            return
        super().process_event(event)


_BODY_HEADER = re.compile(rb"\r\n(content-length[ \t]*:[ \t]*(?!0*[ \t]*\r\n)|"
                          rb"transfer-encoding[ \t]*:)", re.IGNORECASE)


class _RequestCheckingProtocol(ServerProtocol):
    """websockets' server protocol, except that a request announcing a body
    (``Content-Length`` > 0, ``Transfer-Encoding``) is answered ``400 Bad Request``;
    websockets would close the connection without a word."""

    def parse(self):
        if self.state is State.CONNECTING:
            buffer = self.reader.buffer
            # Wait for the whole head, unless it is not HTTP at all (a TLS ClientHello on a
            # plain port): websockets' own parser answers that at once.
            while (b"\r\n\r\n" not in buffer and len(buffer) < 16384 and not self.reader.eof
                   and (not buffer or bytes(buffer[:1]).isalpha())):
                yield
            head = bytes(buffer[: buffer.find(b"\r\n\r\n") + 2])
            if head and _BODY_HEADER.search(head):
                self.handshake_exc = InvalidMessage("request with a body")
                self.send_response(self.reject(
                    400, "this server takes no request body (GET or HEAD only)\n"))
                yield
                return
        yield from super().parse()


def _peer(connection) -> str:
    addr = connection.remote_address or ("?", 0)
    return f"{addr[0]}:{addr[1]}"


# ---- Host allow-list ----------------------------------------------------------------------

#: Names of this machine that every resolver keeps local (RFC 6761).
LOCAL_NAMES = ("localhost", "localhost.localdomain", "ip6-localhost")


class HostCheck:
    """Which ``Host`` header values the server answers (DNS rebinding: a browser sends the
    attacker's name, never an IP address it did not navigate to).

    Allowed: any IP address literal (a page can only be *at* an address by being served
    from it), ``localhost`` and ``*.localhost``, this machine's host name (and
    ``NAME.local``), the bound address, and the ``--allow-host`` entries: a name, a
    ``.example.org`` suffix (any subdomain and the domain itself), or ``*`` (anything).
    A request without ``Host`` (HTTP/1.0 tools) is answered. The port is not compared.
    """

    def __init__(self, bound_host: str = "127.0.0.1", allowed=()):
        names = {n.lower() for n in LOCAL_NAMES}
        try:
            own = socket.gethostname().lower()
        except OSError:
            own = ""
        if own:
            names |= {own, own + ".local", own.split(".")[0]}
        if bound_host and bound_host not in ("0.0.0.0", "::", ""):
            names.add(bound_host.lower().strip("[]"))
        self.any = False
        self.suffixes: list[str] = []
        for entry in allowed:
            entry = entry.strip().lower()
            if entry == "*":
                self.any = True
            elif entry.startswith("."):
                self.suffixes.append(entry)
            elif entry:
                names.add(_strip_port(entry))
        self.names = names

    def allowed(self, host_header: str | None) -> bool:
        if host_header is None or self.any:
            return True
        host = _strip_port(host_header.strip().lower())
        if not host:
            return False
        host = host.rstrip(".")
        if host in self.names or host.endswith(".localhost"):
            return True
        try:
            ipaddress.ip_address(host)
            return True
        except ValueError:
            pass
        return any(host.endswith(s) or host == s[1:] for s in self.suffixes)


def _strip_port(host: str) -> str:
    """``host`` of ``host:port``, ``[v6]:port``, ``[v6]`` or ``host``."""
    if host.startswith("["):
        end = host.find("]")
        return host[1:end] if end > 0 else host
    if host.count(":") == 1:
        return host.rsplit(":", 1)[0]
    return host                     # a bare name, or an IPv6 address without brackets


# ---- open files ----------------------------------------------------------------------------

#: File descriptors kept back from clients: the listening socket, sources, logs, threads'
#: files, HTTP requests and handshakes in progress.
FD_RESERVE = 64


def raise_open_files_limit() -> tuple[int | None, int | None]:
    """Raise the soft RLIMIT_NOFILE to the hard limit where allowed; (soft, hard) after it
    (None, None where the platform has no such limit)."""
    try:
        import resource
    except ImportError:         # Windows
        return None, None
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    if soft != hard:
        try:
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
            soft = hard
        except (ValueError, OSError):   # an infinite hard limit above the kernel's nr_open
            pass
    infinite = resource.RLIM_INFINITY
    return (None if soft == infinite else soft), (None if hard == infinite else hard)


def open_files() -> int:
    """File descriptors this process has open now (0 where it cannot tell)."""
    import os
    for path in ("/proc/self/fd", "/dev/fd"):
        try:
            return len(os.listdir(path))
        except OSError:
            continue
    return 0


def fit_open_files(requested: int) -> tuple[int | None, int]:
    """Raise the open-files limit where allowed; (the limit, the clients it holds: at most
    ``requested``), said in the log when that is fewer than ``requested``."""
    soft, _ = raise_open_files_limit()
    capacity = client_capacity(requested, soft, open_files())
    if capacity < requested:
        log.warning("--max-clients %d is more than %d open files allow (one per client, "
                    "%d kept back): holding at most %d clients; raise the limit (ulimit -n, "
                    "systemd LimitNOFILE=) for more", requested, soft, FD_RESERVE, capacity)
    return soft, capacity


def client_capacity(requested: int, soft_limit: int | None, in_use: int) -> int:
    """The clients this process can hold: ``requested``, or fewer when the open-files
    limit (one descriptor per client, ``in_use`` taken already, :data:`FD_RESERVE` kept
    back) cannot hold them."""
    if soft_limit is None:
        return requested
    return max(1, min(requested, soft_limit - in_use - FD_RESERVE))


def silent_capacity(soft_limit: int | None, max_clients: int) -> int:
    """Connections that have sent no request yet the server holds at most
    (:class:`~provider.live.server.admission.SilentConnections`): what the open-files limit
    leaves beside ``max_clients`` clients and :data:`FD_RESERVE`, at least half the
    reserve."""
    if soft_limit is None:
        return 1 << 16
    return max(FD_RESERVE // 2, soft_limit - max_clients - FD_RESERVE)


#: Headers the server reads that a request may carry once only: two ``Host`` or
#: ``Authorization`` headers are ambiguous (which one did a proxy check?).
SINGLE_HEADERS = ("Host", "Authorization", "Origin", "Upgrade")


def duplicate_header(request):
    """The refusal (400) of a request that repeats a header of :data:`SINGLE_HEADERS`, or
    None."""
    for name in SINGLE_HEADERS:
        if len(request.headers.get_all(name)) > 1:
            return 400, "bad_request", f"more than one {name} header", ()
    return None


def early_refusal(request, host_check: HostCheck, open_connections: int, max_clients: int):
    """(HTTP status, reason for the counters, text, headers) for a request refused before
    anything else, or None: a Host this server does not answer (421, DNS rebinding), a
    method other than GET and HEAD (405), or more connections open (clients, and handshakes
    and HTTP requests whose request has arrived; connections that sent nothing yet are not
    counted: :mod:`~provider.live.server.admission`) than the clients the open-files limit
    holds, with some room (503)."""
    host = request.headers.get("Host")
    if not host_check.allowed(host):
        return 421, "host", f"Host {host[:80]!r} is not this server's (see --allow-host)", ()
    upgrade = "websocket" in request.headers.get("Upgrade", "").lower()
    if request.method not in ("GET", "HEAD") or (upgrade and request.method != "GET"):
        return 405, "method", "GET or HEAD only", [("Allow", "GET" if upgrade else "GET, HEAD")]
    if open_connections > max_clients + FD_RESERVE // 2:
        return (503, "too_many_connections",
                f"too many connections ({open_connections} open; see --max-clients)", ())
    return None


# ---- log lines --------------------------------------------------------------------------------

class RepeatFilter(logging.Filter):
    """Lets a log line through once per ``interval`` seconds per (logger, level, text
    before formatting, the arguments that say *what* it is about); the next one let through
    says how many were held back. Lines below ``min_level`` always pass.

    An argument names what a line is about (a probe, a file, a camera's address) unless it
    is a number (a count, a time: ``#``) or a peer's port: ``127.0.0.1:50412`` is keyed as
    ``127.0.0.1``, so a flood from one address is one line, while another probe's failure,
    a sequence's second corrupt file or another address still gets its own line."""

    _PORT = re.compile(r"^(\[?[0-9A-Za-z:._-]+?\]?):\d{1,5}$")

    def __init__(self, interval: float = 10.0, min_level: int = logging.WARNING,
                 max_keys: int = 1024):
        super().__init__()
        self.interval, self.min_level, self.max_keys = interval, min_level, max_keys
        self._seen: dict = {}           # key -> [time let through, held back since]

    @classmethod
    def _about(cls, arg):
        if isinstance(arg, (int, float)):
            return "#"
        text = str(arg)
        m = cls._PORT.match(text)
        return m.group(1) if m else text[:200]

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno < self.min_level:
            return True
        args = record.args if isinstance(record.args, tuple) else ()
        key = (record.name, record.levelno, str(record.msg),
               tuple(self._about(a) for a in args))
        now = time.monotonic()
        seen = self._seen.get(key)
        if seen is not None and now - seen[0] < self.interval:
            seen[1] += 1
            return False
        held = seen[1] if seen is not None else 0
        if len(self._seen) >= self.max_keys and seen is None:
            self._seen.clear()
        self._seen[key] = [now, 0]
        if held:
            record.msg = f"{record.msg} (and {held} more like this in the last " \
                         f"{self.interval:g} s)"
        return True


def install_repeat_filter(interval: float = 10.0) -> RepeatFilter:
    """Put a :class:`RepeatFilter` on every handler of the root logger."""
    flt = RepeatFilter(interval)
    for handler in logging.getLogger().handlers:
        handler.addFilter(flt)
    return flt
