"""The light at points of the room from several probes at known positions: the maths of
:mod:`provider.core.probes` turned into the wire message's lighting fields per point
(docs/probes.md, "Light between probes"; ``shlight interpolate``).

With the room's box, each point's panorama is re-projected from the probes' panoramas and
projected by the engine as any frame (lights found there with ``lights="auto"``); without,
the probes' own SH9 are blended (tetrahedra, the hull's nearest face outside) and the
message has no lights (its ambient is the whole SH9, docs/contract.md §10).
"""
from __future__ import annotations

import numpy as np

from ...core.errors import InputError
from ...core.geometry import sh
from ...core.probes import Tetrahedra, blend, parse_room, reproject
from ...core.probes.parallax import DEFAULT_HEIGHT, check_probes
from ...core.sh9.engine import SH9Projector
from ...core.sh9.result import SH9Result
from ..wire.message import light_fields
from .sphere import sphere_of


class Interpolator:
    """Light at points from probes ``names`` at ``positions`` (n, 3; metres) with panoramas
    ``images`` (equirects of linear radiance, the world frame's axes). ``room``: None or
    ``box:X0,Y0,Z0,X1,Y1,Z1``; ``rows``: the panorama re-projected at a point."""

    def __init__(self, names, positions, images=None, *, room: str | None = None,
                 lights: str = "off", rows: int | None = None, coefficients=None,
                 tetrahedra: Tetrahedra | None = None):
        self.names = list(names)
        self.positions = np.asarray(positions, np.float64).reshape(-1, 3)
        self.images = [np.ascontiguousarray(i, np.float32) for i in images or ()]
        self.room = room if room is None or not isinstance(room, str) else parse_room(room)
        self.rows = DEFAULT_HEIGHT if rows is None else int(rows)
        if self.room is None:
            if lights != "off":
                raise InputError("lights need the room (--room): without it a light has no "
                                 "place to be seen from a point")
            self.tetrahedra = tetrahedra or Tetrahedra(self.positions)
            self.coefficients = (np.asarray(coefficients, np.float64).reshape(-1, 9, 3)
                                 if coefficients is not None
                                 else np.array([_sh9(img) for img in self.images]))
        else:
            check_probes(self.positions, self.images, self.room, self.names)
            self._check_rows(self.rows)
        self.lights = lights
        self._projectors: dict = {}

    @staticmethod
    def _check_rows(rows: int) -> None:
        if not 8 <= rows <= 512:
            raise InputError(f"--rows {rows}: 8 to 512 rows")

    @property
    def room_text(self) -> str | None:
        return None if self.room is None else str(self.room)

    def at(self, point, rows: int | None = None) -> dict:
        """The lighting fields at ``point``: position, method, coefficients, matrices and
        the lights' fields; without the room also each probe's weight. ``rows``: of the
        panorama re-projected there (default: the interpolator's)."""
        x = np.asarray(point, np.float64).reshape(3)
        if not np.all(np.isfinite(x)):
            raise InputError("a point's coordinates must be finite numbers")
        out = {"position": [float(v) for v in x]}
        if self.room is not None:
            rows = self.rows if rows is None else int(rows)
            self._check_rows(rows)
            projector = self._projectors.get(rows)
            if projector is None:
                projector = self._projectors[rows] = SH9Projector(
                    2 * rows, rows, "equirect", lights=self.lights, error_estimate=False)
            result = projector.project(reproject(x, self.positions, self.images, self.room,
                                                 rows))
            out["method"] = "parallax"
        else:
            w, inside = self.tetrahedra.weights(x)
            c = blend(self.coefficients, w)
            result = SH9Result(c, sh.irradiance_matrices(c))
            out["method"] = ("tetrahedra" if inside else "hull" if len(self.tetrahedra.cells)
                             else "inverse-distance")
            out["weights"] = {n: round(float(v), 6) for n, v in zip(self.names, w) if v > 0}
        out["coefficients"] = [float(v) for v in result.coefficients.reshape(-1)]
        out["matrices"] = [float(v) for v in result.matrices.reshape(-1)]
        out.update(light_fields(result))
        return out


def _sh9(image: np.ndarray) -> np.ndarray:
    h, w = image.shape[:2]
    if w != 2 * h:
        raise InputError(f"a probe's panorama is {w}×{h}; an equirect (2:1) is needed")
    return SH9Projector(w, h, "equirect", error_estimate=False).project(image).coefficients


#: The live points' panoramas: each probe's newest frame shrunk to this many rows at most.
LIVE_PROBE_ROWS = 128
#: Rows of the panorama re-projected at a point of /probe-grid.json (a grid costs its points
#: times this squared; 32 rows: 1.3 % median in docs/probes.md's room).
GRID_ROWS = 32
#: Most points one /probe-grid.json computes.
MAX_GRID_POINTS = 512
#: A mesh room's rays are cast by trimesh's numpy engine (~40,000 a second): its points
#: have 32 rows (0.5 s with 8 probes), its grids 16 rows and 27 points (about 3 s).
MESH_POINT_ROWS, MESH_GRID_ROWS, MESH_GRID_POINTS = 32, 16, 27
#: Points whose light is kept (the newest), per set of probe frames.
CACHED_POINTS = 256


class RoomLight:
    """The light at points of the room from the live probes that have a position
    (``serve --probe-position``; ``room``: ``serve --room``): rebuilt from their newest
    frames (with the room) or messages (without) when one of them changed, once per
    change; thread-safe (the server calls it off its event loop)."""

    def __init__(self, probes, room: str | None = None, lights: str = "off"):
        import threading
        self.probes = [p for p in probes if getattr(p, "position", None) is not None]
        self.room, self.lights = room, lights
        self.box = None if room is None else parse_room(room)   # refused at start, one line
        self.mesh = self.box is not None and hasattr(self.box, "visible")
        if room is not None:
            if not self.probes:
                raise InputError("--room needs the probes' positions: give "
                                 "--probe-position NAME=X,Y,Z for each probe in the room")
            for p in self.probes:
                if not self.box.contains(p.position):
                    raise InputError(f"probe {p.name} at {tuple(p.position)} is not inside "
                                     f"the room {self.box}")
                if p.projection != "equirect":
                    raise InputError(f"probe {p.name}: --room re-projects equirect panoramas; "
                                     f"this probe's frames are {p.projection}")
        self._lock = threading.Lock()
        # the positions do not move: their tetrahedra once (64 probes: seconds)
        self._tetrahedra = (Tetrahedra([p.position for p in self.probes])
                            if room is None and self.probes else None)
        self._key = None
        self._interpolator: Interpolator | None = None
        self._cache: dict = {}

    def check_point(self, point) -> None:
        """InputError unless the light at ``point`` can be had (inside the room's box)."""
        if self.box is not None and not self.box.contains(point):
            raise InputError(f"the point {tuple(float(v) for v in point)} is not inside the "
                             f"room {self.box}")

    def key(self) -> tuple:
        """What the light at points is made of: the placed probes' newest message (without
        the room) or frame (with it) numbers; None for a probe that has none yet."""
        if self.room is None:
            return tuple(p.seq if p.latest_message else None for p in self.probes)
        return tuple(p.image_seq if p.image is not None else None for p in self.probes)

    def _current(self) -> Interpolator | None:
        """The interpolator of the probes' newest frames or messages; None until each
        placed probe has one."""
        key = self.key()
        if None in key:
            return None
        if key != self._key:
            names = [p.name for p in self.probes]
            positions = [p.position for p in self.probes]
            if self.room is None:
                coefficients = [p.latest_message["coefficients"] for p in self.probes]
                self._interpolator = Interpolator(names, positions, coefficients=coefficients,
                                                  tetrahedra=self._tetrahedra)
            else:
                # each frame as the probe's SH9 sees it: its curve, exposure, lens, rotation
                images = [sphere_of(p, LIVE_PROBE_ROWS) for p in self.probes]
                self._interpolator = Interpolator(names, positions, images, room=self.box,
                                                  lights=self.lights)
            self._key, self._cache = key, {}
        return self._interpolator

    def at(self, point, rows: int | None = None) -> dict | None:
        """The lighting fields at ``point`` (:meth:`Interpolator.at`) from the probes'
        newest frames or messages, or None while a placed probe has none yet."""
        with self._lock:
            interpolator = self._current()
            if interpolator is None:
                return None
            key = (tuple(round(float(v), 4) for v in point), rows)
            found = self._cache.get(key)
            if found is None:
                if self.room is None:
                    rows = None
                elif self.mesh:
                    rows = min(rows or MESH_POINT_ROWS, MESH_POINT_ROWS)
                found = interpolator.at(point, rows)
                if len(self._cache) >= CACHED_POINTS:
                    self._cache.pop(next(iter(self._cache)))
                self._cache[key] = found
            return found

    def grid(self, lo, hi, step: float) -> dict | None:
        """SH9 on a grid from ``lo`` to ``hi`` (metres) every ``step``: positions (3N) and
        coefficients (27N), x fastest, then y, then z (a 3D texture's order)."""
        lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
        if not (step > 0 and np.all(hi >= lo)):
            raise InputError("a grid needs min <= max in x, y and z and a step > 0")
        counts = np.floor((hi - lo) / step + 1e-9).astype(int) + 1
        most = MESH_GRID_POINTS if self.mesh else MAX_GRID_POINTS
        if int(np.prod(counts)) > most:
            raise InputError(f"{int(np.prod(counts))} grid points: at most {most} a request "
                             f"(a larger step{'; a box room takes more' if self.mesh else ''})")
        zs, ys, xs = np.meshgrid(*(lo[i] + step * np.arange(counts[i]) for i in (2, 1, 0)),
                                 indexing="ij")
        points = np.stack([xs.ravel(), ys.ravel(), zs.ravel()], axis=1)
        rows = (MESH_GRID_ROWS if self.mesh else GRID_ROWS) if self.room is not None else None
        found = [self.at(x, rows) for x in points]
        if any(f is None for f in found):
            return None
        return {"type": "probe-grid", "min": lo.tolist(), "max": hi.tolist(),
                "step": float(step), "counts": counts.tolist(),
                "method": "parallax" if self.room is not None else "tetrahedra",
                "positions": [float(v) for v in points.ravel()],
                "coefficients": [v for f in found for v in f["coefficients"]]}


def linear_panorama(image) -> np.ndarray:
    """A probe's panorama as linear float32 radiance (8/16-bit: decoded as sRGB; NaN and
    negative samples: 0)."""
    from ...core.radiometry.decode import srgb_to_linear
    img = np.asarray(image)
    if np.issubdtype(img.dtype, np.integer):
        img = srgb_to_linear(img / float(np.iinfo(img.dtype).max))
    img = np.nan_to_num(np.asarray(img[..., :3], np.float32), nan=0.0, posinf=0.0,
                        neginf=0.0)
    return np.maximum(img, 0.0)
