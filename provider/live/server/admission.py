"""Connections that have sent no request yet: they must not lock the headsets out.

A TCP connection costs a file descriptor and a handler task from the moment it is accepted,
before it sends a byte. A device on the LAN that opens hundreds of connections and never
speaks (no token needed) must not keep a headset with the right token, or ``/healthz``, from
being answered. :class:`SilentConnections` keeps such connections few and short-lived:

* each is cut ``head_timeout`` seconds after it was accepted unless its request head (the
  HTTP request or the WebSocket handshake) is complete by then; a client sends it within
  milliseconds of connecting;
* one address holds at most ``per_address`` silent connections: past it, its oldest one
  silent for at least ``min_age`` seconds is cut (a burst of connections about to speak is
  left alone);
* one address may open ``accept_rate`` connections a second after a burst of
  ``accept_burst``: past it, a new connection is cut at once;
* all addresses together hold at most ``max_silent`` (set from the open-files limit): past
  it, the oldest silent connection of the address holding the most is cut.

127.0.0.1 and ::1 (this machine's programs: a reverse proxy, the bench's thousand clients)
are exempt from the per-address rules, as from ``--connect-rate``, but not from the head
timeout or ``max_silent``. Silent connections are never counted against ``--max-clients``
(:func:`~provider.live.server.limits.early_refusal` is given the others). Cuts are counted
by reason for ``/metrics`` and ``/healthz``.
"""
from __future__ import annotations

import collections
import logging
import time

from .limits import ConnectRate

log = logging.getLogger("shlight.server")

#: Addresses the per-address rules exempt (those :class:`~provider.live.server.limits.ConnectRate`
#: exempts).
EXEMPT = ConnectRate.EXEMPT


class SilentConnections:
    """The accepted connections that have not sent a whole request head (see the module
    docstring). The connection calls :meth:`opened` when accepted, :meth:`spoke` when its
    request head is parsed and :meth:`closed` when it is lost; each cut aborts the
    connection's transport."""

    def __init__(self, head_timeout: float = 5.0, per_address: int = 8, min_age: float = 1.0,
                 accept_rate: float = 20.0, accept_burst: float = 40.0,
                 max_silent: int = 4096, max_addresses: int = 4096):
        self.head_timeout, self.per_address, self.min_age = head_timeout, per_address, min_age
        self.accept_rate, self.accept_burst = accept_rate, accept_burst
        self.max_silent = max_silent
        # address -> {connection: (accepted at, timer)}, oldest first (dicts keep order)
        self._silent: dict[str, dict] = {}
        self._count = 0
        # accepted TCP connections per address: the same token-bucket table as handshakes
        self._accepts = ConnectRate(accept_rate, accept_burst, max_addresses)
        self.cut: collections.Counter = collections.Counter()    # reason -> connections

    def __len__(self) -> int:
        return self._count

    def opened(self, connection, address: str | None) -> None:
        """A connection was accepted from ``address``: cut it at once past the address's
        accept rate, else hold it as silent (and cut older ones past the caps)."""
        now = time.monotonic()
        address = address or "?"
        if self._accepts.retry_after(address, now) > 0:
            self._cut(connection, "accept_rate", address)
            return
        timer = connection.loop.call_later(self.head_timeout, self._timed_out, connection,
                                           address)
        self._silent.setdefault(address, {})[connection] = (now, timer)
        self._count += 1
        if address not in EXEMPT:
            self._trim(self._silent[address], address, self.per_address, "per_address", now)
        if self._count > self.max_silent:
            busiest = max(self._silent, key=lambda a: len(self._silent[a]))
            self._trim(self._silent[busiest], busiest,
                       len(self._silent[busiest]) - (self._count - self.max_silent),
                       "too_many_silent", now)

    def spoke(self, connection, address: str | None) -> None:
        """The connection's request head arrived: it is no longer silent."""
        self._forget(connection, address or "?")

    closed = spoke      # a lost connection is forgotten the same way

    # -- internals --------------------------------------------------------------------------
    def _forget(self, connection, address: str) -> bool:
        waiting = self._silent.get(address)
        entry = waiting.pop(connection, None) if waiting is not None else None
        if entry is None:
            return False
        entry[1].cancel()
        self._count -= 1
        if not waiting:
            del self._silent[address]
        return True

    def _trim(self, waiting: dict, address: str, keep: int, reason: str, now: float) -> None:
        for connection, (since, _) in list(waiting.items()):
            if len(waiting) <= max(keep, 0) or now - since < self.min_age:
                break                   # oldest first: the rest are younger still
            self._forget(connection, address)
            self._cut(connection, reason, address)

    def _timed_out(self, connection, address: str) -> None:
        if self._forget(connection, address):
            self._cut(connection, "head_timeout", address)

    def _cut(self, connection, reason: str, address: str) -> None:
        self.cut[reason] += 1
        why = {"head_timeout": f"no request within {self.head_timeout:g} s",
               "per_address": f"more than {self.per_address} connections without a request",
               "accept_rate": f"more than {self.accept_rate:g} connections a second",
               "too_many_silent": f"{self.max_silent} connections without a request in all",
               }[reason]
        # At most one line per reason and address every 10 s: the server's RepeatFilter
        # keys on the text before formatting, which holds both.
        log.warning(f"cut connection(s) from {address}: {why}")
        transport = connection.transport
        if transport is not None and not transport.is_closing():
            transport.abort()
