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


class Interpolator:
    """Light at points from probes ``names`` at ``positions`` (n, 3; metres) with panoramas
    ``images`` (equirects of linear radiance, the world frame's axes). ``room``: None or
    ``box:X0,Y0,Z0,X1,Y1,Z1``; ``rows``: the panorama re-projected at a point."""

    def __init__(self, names, positions, images, *, room: str | None = None,
                 lights: str = "off", rows: int | None = None):
        self.names = list(names)
        self.positions = np.asarray(positions, np.float64).reshape(-1, 3)
        self.images = [np.ascontiguousarray(i, np.float32) for i in images]
        self.room = None if room is None else parse_room(room)
        self.rows = DEFAULT_HEIGHT if rows is None else int(rows)
        if self.room is None:
            if lights != "off":
                raise InputError("lights need the room (--room): without it a light has no "
                                 "place to be seen from a point")
            self.tetrahedra = Tetrahedra(self.positions)
            self.coefficients = np.array([_sh9(img) for img in self.images])
        else:
            check_probes(self.positions, self.images, self.room, self.names)
            if not 8 <= self.rows <= 512:
                raise InputError(f"--rows {self.rows}: 8 to 512 rows")
            self._projector = SH9Projector(2 * self.rows, self.rows, "equirect",
                                           lights=lights, error_estimate=False)

    @property
    def room_text(self) -> str | None:
        return None if self.room is None else str(self.room)

    def at(self, point) -> dict:
        """The lighting fields at ``point``: position, method, coefficients, matrices and
        the lights' fields; without the room also each probe's weight."""
        x = np.asarray(point, np.float64).reshape(3)
        if not np.all(np.isfinite(x)):
            raise InputError("a point's coordinates must be finite numbers")
        out = {"position": [float(v) for v in x]}
        if self.room is not None:
            pano = reproject(x, self.positions, self.images, self.room, self.rows)
            result = self._projector.project(pano)
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
