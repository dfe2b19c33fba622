"""Light at a point from the probes and the room's box: each probe's panorama re-projected
through the room to the point (parallax; no I/O).

For every direction from the point, the ray leaves the room's box at a wall point; each
probe saw that wall point too, in the direction from the probe to it, so its panorama there
says the point's radiance in that direction. Where the probes disagree (a wall point one
probe sees at a graze, or furniture the box does not have), the probes that see it closer,
more head-on and from nearer the point's own direction weigh more. The panorama at the point
is then projected onto SH9 (and searched for lights) like any frame: a light's direction is
where its wall point is from this point, not from a camera.

The walls must reflect the same radiance toward the point as toward the probes (matt
walls; windows and panels seen from inside): docs/probes.md measures what that leaves.
"""
from __future__ import annotations

import math
import re

import cv2
import numpy as np

from ..errors import InputError
from ..geometry.projections import Equirect

#: The panorama re-projected at a point: its height (width twice); 64 × 128 rays per probe.
DEFAULT_HEIGHT = 64
#: Most rows of the panorama a point may ask for (bounded work: rows² × 2 × probes samples).
MAX_HEIGHT = 512


class Box:
    """An axis-aligned room, corners ``lo`` and ``hi`` (metres, the probes' world frame)."""

    def __init__(self, lo, hi):
        lo, hi = np.asarray(lo, np.float64), np.asarray(hi, np.float64)
        self.lo, self.hi = np.minimum(lo, hi), np.maximum(lo, hi)
        if not (np.all(np.isfinite(self.lo)) and np.all(np.isfinite(self.hi))):
            raise InputError("the room's corners must be finite numbers")
        if np.any(self.hi - self.lo <= 0):
            raise InputError("the room's box is flat: its corners differ in x, y and z")

    def contains(self, point, margin: float = 0.0) -> bool:
        p = np.asarray(point, np.float64)
        return bool(np.all(p > self.lo + margin) and np.all(p < self.hi - margin))

    def exits(self, origin, directions):
        """Where rays from ``origin`` (inside) leave the box: wall points (N, 3) and the
        walls' normals into the room (N, 3)."""
        d = np.asarray(directions, np.float64).reshape(-1, 3)
        o = np.asarray(origin, np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(d > 0, (self.hi - o) / d,
                         np.where(d < 0, (self.lo - o) / d, np.inf))
        axis = np.argmin(t, axis=1)
        rows = np.arange(len(d))
        points = o + t[rows, axis][:, None] * d
        normals = np.zeros_like(d)
        normals[rows, axis] = -np.sign(d[rows, axis])
        return points, normals

    def __str__(self):
        return "box:" + ",".join(f"{v:g}" for v in (*self.lo, *self.hi))


def parse_room(text: str):
    """``box:X0,Y0,Z0,X1,Y1,Z1`` (two opposite corners, metres): a :class:`Box`; or a mesh
    file (:data:`~.mesh.MESH_EXTENSIONS`): a :class:`~.mesh.MeshRoom`."""
    from .mesh import MESH_EXTENSIONS, read_mesh
    if text.strip().lower().endswith(MESH_EXTENSIONS):
        return read_mesh(text.strip())
    kind, sep, rest = text.strip().partition(":")
    if kind.lower() != "box" or not sep:
        raise InputError(f"--room {text!r}: expected box:X0,Y0,Z0,X1,Y1,Z1 (two opposite "
                         "corners of the room, metres) or a mesh file "
                         f"({', '.join(MESH_EXTENSIONS)})")
    try:
        values = [float(v) for v in re.split(r"[,;\s]+", rest.strip())]
    except ValueError:
        values = []
    if len(values) != 6 or not all(math.isfinite(v) for v in values):
        raise InputError(f"--room {text!r}: expected six finite numbers, "
                         "box:X0,Y0,Z0,X1,Y1,Z1")
    try:
        return Box(values[:3], values[3:])
    except InputError as exc:
        raise InputError(f"--room {text!r}: {exc}") from None


def _direction_to_pixel(directions, width: int, height: int):
    """Equirect pixel coordinates (docs/contract.md §1) of unit directions, as cv2.remap
    takes them (pixel centres at integers)."""
    x, y, z = directions[:, 0], directions[:, 1], directions[:, 2]
    u = np.arctan2(x, -z) / (2 * np.pi) + 0.5
    v = np.arccos(np.clip(y, -1.0, 1.0)) / np.pi
    return (u * width - 0.5).astype(np.float32), (v * height - 0.5).astype(np.float32)


def _sample(image, directions, shape):
    """Bilinear samples (N, 3) of an equirect at unit directions (N = the product of
    ``shape``, the grid cv2.remap is given: fewer than 32767 rows and columns); its seam
    wraps."""
    h, w = image.shape[:2]
    wrapped = np.concatenate([image[:, -1:], image, image[:, :1]], axis=1)
    mx, my = _direction_to_pixel(directions, w, h)
    out = cv2.remap(wrapped, (mx + 1).reshape(shape), my.reshape(shape), cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(-1, 3)


def check_probes(positions, images, box, names=None) -> None:
    """Every probe inside the room, and an equirect (2:1, RGB) of linear radiance."""
    names = names or [str(i) for i in range(len(positions))]
    for name, p, img in zip(names, positions, images):
        if not box.contains(p):
            raise InputError(f"probe {name} at {tuple(float(v) for v in p)} is not inside "
                             f"the room {box}")
        if img.ndim != 3 or img.shape[2] != 3 or img.shape[1] != 2 * img.shape[0]:
            raise InputError(f"probe {name}: an equirect panorama (2:1, RGB) is needed to "
                             f"re-project through the room, got {img.shape[1]}×{img.shape[0]}")


def reproject(point, positions, images, box, height: int = DEFAULT_HEIGHT) -> np.ndarray:
    """The panorama at ``point`` (height × 2·height × 3, float32, linear) from the probes'
    panoramas ``images`` (equirects of linear radiance, float32, the world frame's axes)
    taken at ``positions`` (n, 3) inside the room ``box`` (a :class:`Box`, or a
    :class:`~.mesh.MeshRoom`, whose walls also hide wall points from probes: a wall point
    no probe sees takes what they all see in its direction)."""
    if not box.contains(point):
        raise InputError(f"the point {tuple(float(v) for v in point)} is not inside the "
                         f"room {box}")
    if not 2 <= height <= MAX_HEIGHT:
        raise InputError(f"the panorama's height {height}: 2 to {MAX_HEIGHT} rows")
    rays = Equirect(2 * height, height).directions().reshape(-1, 3)
    walls, normals = box.exits(point, rays)
    total, weight = np.zeros((len(rays), 3)), np.zeros(len(rays))
    hidden, hidden_weight = np.zeros((len(rays), 3)), np.zeros(len(rays))
    occludes = hasattr(box, "visible")
    for p, img in zip(np.asarray(positions, np.float64), images):
        seen = walls - p
        dist = np.linalg.norm(seen, axis=1)
        toward = seen / np.maximum(dist, 1e-9)[:, None]
        # closer and more head-on: more of the probe's pixels on the wall point; from nearer
        # the point's own direction: what a matt-but-not-quite wall shows the point
        head_on = np.clip(-(toward * normals).sum(1), 1e-3, None)
        alike = (0.5 * (1 + (toward * rays).sum(1))) ** 2
        w = head_on / np.maximum(dist, 1e-3) ** 2 * alike + 1e-12
        sample = _sample(img, toward, (height, 2 * height))
        if occludes:
            seen = box.visible(p, walls)
            hidden += (~seen * w)[:, None] * sample
            hidden_weight += ~seen * w
            w = w * seen
        total += w[:, None] * sample
        weight += w
    unseen = weight <= 0
    total[unseen], weight[unseen] = hidden[unseen], hidden_weight[unseen]
    return (total / weight[:, None]).reshape(height, 2 * height, 3).astype(np.float32)
