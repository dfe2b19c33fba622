"""The light at points of the room (``serve --probe-position``, ``--room``; docs/probes.md,
"Light between probes"), from :class:`~provider.live.probe.points.RoomLight`:

* ``GET /latest.json?at=X,Y,Z`` — the lighting fields at the point, as ``shlight
  interpolate`` prints them, with ``"type": "point"``;
* ``GET /probe-grid.json?min=X,Y,Z&max=X,Y,Z&step=S`` — SH9 on a grid (at most
  :data:`~provider.live.probe.points.MAX_GRID_POINTS` points, x fastest) for the engines'
  probe grids;
* ``{"type": "subscribe", "at": [x, y, z]}`` on the WebSocket — ``point`` messages for that
  point whenever the placed probes' light changed, at most :data:`POINT_HZ` a second
  (``"at": null`` stops them); at most :data:`MAX_POINTS` points followed at once.

Behind the same token, origin and host checks as ``/latest.json``. One computation runs at
a time, off the event loop; an HTTP request that finds one running is answered 503 with
``Retry-After`` (bounded work: a point costs milliseconds, a grid up to about a second).
"""
from __future__ import annotations

import asyncio
import math

from ...core.errors import InputError
from ..wire.message import dumps
from .replies import _json_error, _response

GRID_PATH = "/probe-grid.json"
#: How often the followed points are brought up to date with the probes (at most).
POINT_HZ = 2.0
#: Distinct points followed over WebSocket at once (each costs a point per probe change).
MAX_POINTS = 16
#: The slot of a client's point messages (beside its probes' names, which it cannot be).
SLOT = "@point"


def wants_point(path: str, query) -> bool:
    return path == GRID_PATH or (path == "/latest.json" and "at" in query)


def _triple(query, key: str):
    text = query.get(key, [""])[0]
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise InputError(f"{key}={text[:40]!r}: expected X,Y,Z (metres)")
    return values


class PointFanout:
    """The server's light at points: its HTTP replies and the clients following a point.
    ``room`` (a :class:`~provider.live.probe.points.RoomLight`) is set by ``serve`` when a
    probe has a position; None answers 404."""

    def __init__(self, server):
        self.server = server
        self.room = None
        self.busy = asyncio.Lock()
        self.followers: dict = {}        # client -> the point it follows (x, y, z)
        self._made: dict = {}            # point -> the RoomLight key its message is of
        self._timer = None
        self.sent = 0

    # -- HTTP ------------------------------------------------------------------------------
    async def http(self, path: str, query):
        """The reply to :func:`wants_point`'s requests."""
        if self.room is None:
            return _json_error(404, "no_positions", "no probe has a position (shlight serve "
                                                    "--probe-position NAME=X,Y,Z)")
        room = self.room
        try:
            if path == GRID_PATH:
                lo, hi = _triple(query, "min"), _triple(query, "max")
                try:
                    step = float(query.get("step", [""])[0])
                except ValueError:
                    step = math.nan
                if not math.isfinite(step):
                    raise InputError("step: expected a number of metres")
                work = lambda: room.grid(lo, hi, step)      # noqa: E731
            else:
                at = _triple(query, "at")
                work = lambda: room.at(at)                  # noqa: E731
        except InputError as exc:
            return _json_error(400, "bad_request", str(exc))
        if self.busy.locked():
            body = dumps({"type": "error", "error": "busy",
                          "detail": "another point or grid is being computed"}).encode()
            return _response(503, body, "application/json", [("Retry-After", "1")])
        async with self.busy:
            try:
                found = await asyncio.to_thread(work)
            except InputError as exc:
                return _json_error(400, "bad_request", str(exc))
        if found is None:
            return _json_error(503, "no_lighting_yet", "a placed probe has no lighting yet")
        if path != GRID_PATH:
            found = {"type": "point", **found}
        return _response(200, dumps(found).encode(), "application/json")

    # -- WebSocket -------------------------------------------------------------------------
    def subscribe(self, client, msg: dict) -> dict | None:
        """A subscribe message's ``at``: follow that point (None: stop); the problem, as
        an ``error`` reply's fields, or None."""
        if "at" not in msg:
            return None
        at = msg["at"]
        if at is None:
            if self.followers.pop(client, None) is not None:
                client.forget(SLOT)
            return None
        if self.room is None:
            return {"error": "no_positions", "detail": "no probe has a position (shlight "
                                                       "serve --probe-position NAME=X,Y,Z)"}
        if not (isinstance(at, list) and len(at) == 3
                and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                        and math.isfinite(v) for v in at)):
            return {"error": "bad_request", "detail": "at: expected [x, y, z] (metres)"}
        point = tuple(float(v) for v in at)
        try:
            self.room.check_point(point)
        except InputError as exc:
            return {"error": "bad_request", "detail": str(exc)}
        if point not in set(self.followers.values()) and \
                len(set(self.followers.values()) - {self.followers.get(client)}) >= MAX_POINTS:
            return {"error": "busy", "detail": f"{MAX_POINTS} points are followed already; "
                                               "follow one of them or try later"}
        self.followers[client] = point
        self._made.pop(point, None)      # its newest message goes to the new follower too
        if self._timer is None:
            self._timer = asyncio.get_running_loop().call_soon(self._tick)
        return None

    def _tick(self) -> None:
        self._timer = None
        self.followers = {c: p for c, p in self.followers.items()
                          if c in self.server.clients}
        if not self.followers:
            self._made.clear()
            return
        key = self.room.key()
        due = [p for p in set(self.followers.values()) if self._made.get(p) != key]
        if due and None not in key and not self.busy.locked():
            asyncio.get_running_loop().create_task(self._update(due, key))
        self._timer = asyncio.get_running_loop().call_later(1 / POINT_HZ, self._tick)

    async def _update(self, points, key) -> None:
        async with self.busy:
            for point in points:
                try:
                    found = await asyncio.to_thread(self.room.at, point)
                except InputError as exc:
                    found = {"error": str(exc)}
                if found is None:
                    continue
                text = dumps({"type": "point", **found} if "error" not in found else
                             {"type": "error", "error": "bad_request",
                              "detail": found["error"]}).encode()
                self._made[point] = key
                for client, followed in list(self.followers.items()):
                    if followed == point:
                        client.offer(SLOT, text)
                        self.sent += 1
