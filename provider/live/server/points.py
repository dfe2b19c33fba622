"""The light at points of the room over HTTP (``serve --probe-position``, ``--room``;
docs/probes.md, "Light between probes"):

* ``/latest.json?at=X,Y,Z`` — the lighting fields at the point, as ``shlight interpolate``
  prints them, with ``"type": "point"``;
* ``/probe-grid.json?min=X,Y,Z&max=X,Y,Z&step=S`` — SH9 on a grid (at most
  :data:`~provider.live.probe.points.MAX_GRID_POINTS` points) for the engines' probe grids.

Behind the same token, origin and host checks as ``/latest.json``. One computation runs at
a time, off the event loop; a request that finds one running is answered 503 with
``Retry-After`` (bounded work: a point costs milliseconds, a grid up to about a second).
"""
from __future__ import annotations

import asyncio
import math

from ...core.errors import InputError
from ..wire.message import dumps
from .replies import _json_error, _response

#: The paths this module answers (/latest.json only with ?at=).
GRID_PATH = "/probe-grid.json"


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


async def point_reply(server, path: str, query):
    """The reply to :func:`wants_point`'s requests."""
    room = getattr(server, "points", None)
    if room is None:
        return _json_error(404, "no_positions", "no probe has a position (shlight serve "
                                                "--probe-position NAME=X,Y,Z)")
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
    lock = room.busy
    if lock.locked():
        return _response(503, dumps({"type": "error", "error": "busy",
                                     "detail": "another point or grid is being computed"}
                                    ).encode(), "application/json", [("Retry-After", "1")])
    async with lock:
        try:
            found = await asyncio.to_thread(work)
        except InputError as exc:
            return _json_error(400, "bad_request", str(exc))
    if found is None:
        return _json_error(503, "no_lighting_yet", "a placed probe has no lighting yet")
    if path != GRID_PATH:
        found = {"type": "point", **found}
    return _response(200, dumps(found).encode(), "application/json")
