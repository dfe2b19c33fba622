"""An analytic room for the light between probes (``shlight bench --sections points``,
tests/core/probes/test_interpolate.py): a box lit by two ceiling panels and a window, its walls'
radiance known at every point, so the light at any point of the room is exact up to the
integration's resolution.

Every surface point emits the same radiance in every direction (a Lambertian emitter or
reflector), so what a probe sees of a wall point is what any other point sees of it. The
light at a point is the SH9 of the panorama rendered there (rays from the point to the box),
supersampled: the best any SH9 message can say, the reference the methods are measured
against (the SH9's own truncation is not an interpolation error)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from provider.core.geometry import sh
from provider.core.geometry.projections import Equirect

#: The room: x across (6 m), y up (3 m), z deep (5 m); metres, docs/contract.md §1's axes.
LO = np.array([0.0, 0.0, 0.0])
HI = np.array([6.0, 3.0, 5.0])
#: Two ceiling panels (x0, x1, z0, z1) of radiance PANEL; a window in the wall x = 0
#: (z0, z1, y0, y1) of radiance WINDOW (a bluish sky).
PANELS = ((1.4, 2.6, 1.6, 3.4), (3.4, 4.6, 1.6, 3.4))
PANEL = np.array([22.0, 20.0, 17.0])
WINDOW_AT = (1.0, 4.0, 1.0, 2.4)
WINDOW = np.array([5.0, 7.0, 10.0])
#: The walls, floor and ceiling as bright as the light they get makes them.
BOUNCE = 4.0


def room_box() -> str:
    """The room as ``--room`` takes it."""
    return "box:" + ",".join(f"{v:g}" for v in (*LO, *HI))


def hits(origin, directions):
    """Where rays from ``origin`` (inside the box) leave it: points (N, 3), and each one's
    wall: axis (0 x, 1 y, 2 z) and side (0 at LO, 1 at HI)."""
    d = np.asarray(directions, np.float64).reshape(-1, 3)
    o = np.asarray(origin, np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(d > 0, (HI - o) / d, np.where(d < 0, (LO - o) / d, np.inf))
    axis = np.argmin(t, axis=1)
    tmin = t[np.arange(len(d)), axis]
    p = o + tmin[:, None] * d
    side = (d[np.arange(len(d)), axis] > 0).astype(int)
    return p, axis, side


def radiance(p, axis, side):
    """The radiance (N, 3) leaving wall points ``p`` (from :func:`hits`)."""
    x, y, z = p[:, 0], p[:, 1], p[:, 2]
    out = np.zeros((len(p), 3))
    floor = (axis == 1) & (side == 0)
    ceiling = (axis == 1) & (side == 1)
    # The floor is brighter under the panels and near the window (light it reflects).
    glow = (np.exp(-((x - 3.0) ** 2 / 2.0 + (z - 2.5) ** 2 / 1.5))
            + 0.6 * np.exp(-(x ** 2 / 1.0 + (z - 2.5) ** 2 / 2.0)))
    out[floor] = np.array([0.20, 0.16, 0.12]) * (1 + 1.5 * glow[floor, None])
    out[ceiling] = np.array([0.25, 0.25, 0.24]) * (1 + 0.5 * np.cos(x[ceiling, None] / 2))
    lit = np.zeros(len(p), bool)
    for x0, x1, z0, z1 in PANELS:
        lit |= ceiling & (x >= x0) & (x <= x1) & (z >= z0) & (z <= z1)
    wall = axis == 0
    west = wall & (side == 0)
    out[west] = np.array([0.30, 0.28, 0.25]) * (0.6 + 0.3 * y[west, None])
    w0, w1, wy0, wy1 = WINDOW_AT
    window = wall & (side == 0) & (z >= w0) & (z <= w1) & (y >= wy0) & (y <= wy1)
    east = wall & (side == 1)
    out[east] = np.array([0.15, 0.30, 0.18]) * (0.7 + 0.2 * y[east, None]
                                                + 0.2 * np.sin(z[east, None]))
    back = (axis == 2) & (side == 0)
    out[back] = np.array([0.35, 0.18, 0.15]) * (0.8 + 0.15 * y[back, None])
    front = (axis == 2) & (side == 1)
    out[front] = np.array([0.16, 0.18, 0.35]) * (1 + 0.3 * np.sin(x[front, None]))
    out *= BOUNCE
    out[lit], out[window] = PANEL, WINDOW
    return out


#: A cabinet in the middle of the room (corners, metres) and its radiance: what a box room
#: does not know (``blocked=True``), so that a mesh of it is measured against the truth.
CABINET = (np.array([2.5, 0.0, 2.1]), np.array([3.5, 1.8, 2.9]))
CABINET_RADIANCE = np.array([0.9, 0.55, 0.3])


def _cabinet_distance(origin, d):
    """Distance along each ray to the cabinet (inf: missed); the origin is outside it."""
    lo, hi = CABINET
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (lo - origin) / d, (hi - origin) / d
    near = np.nanmax(np.minimum(t1, t2), axis=1)
    far = np.nanmin(np.maximum(t1, t2), axis=1)
    return np.where((near <= far) & (near > 0), near, np.inf)


def in_cabinet(point, margin: float = 0.0) -> bool:
    lo, hi = CABINET
    return bool(np.all(np.asarray(point) > lo - margin) and np.all(np.asarray(point) < hi + margin))


def panorama(at, height: int = 128, supersample: int = 3, blocked: bool = False) -> np.ndarray:
    """The room seen from ``at``: an equirect (height, 2·height, 3) float32, each pixel the
    mean of supersample² rays (the panels' edges anti-aliased); with the cabinet if
    ``blocked``."""
    h, w, k = height, 2 * height, supersample
    sub = (np.arange(k) + 0.5) / k
    py = (np.arange(h)[:, None] + sub[None]).reshape(-1)
    px = (np.arange(w)[:, None] + sub[None]).reshape(-1)
    d, _ = Equirect(w, h).pixel_to_direction(*np.meshgrid(px, py))
    d = d.reshape(-1, 3)
    rad = radiance(*hits(at, d))
    if blocked:
        o = np.asarray(at, np.float64)
        t_wall = np.linalg.norm(hits(at, d)[0] - o, axis=1)
        rad[_cabinet_distance(o, d) < t_wall] = CABINET_RADIANCE
    rad = rad.reshape(h, k, w, k, 3)
    return rad.mean(axis=(1, 3)).astype(np.float32)


def cabinet_mesh():
    """The room with the cabinet as one triangle mesh (trimesh), for ``--room room.obj``."""
    import trimesh
    walls = trimesh.creation.box(extents=HI - LO)
    walls.apply_translation((HI + LO) / 2)
    lo, hi = CABINET
    cabinet = trimesh.creation.box(extents=hi - lo)
    cabinet.apply_translation((hi + lo) / 2)
    return trimesh.util.concatenate([walls, cabinet])


def exact_sh9(at, height: int = 256, blocked: bool = False) -> np.ndarray:
    """The light at ``at``: SH9 (9, 3) of the supersampled panorama there."""
    img = panorama(at, height, supersample=4, blocked=blocked).astype(np.float64)
    return Equirect(2 * height, height).sh_weights.T @ img.reshape(-1, 3)


def irradiance_error(coefficients, at) -> float:
    """Relative RMS irradiance error over the sphere of normals against the exact light."""
    return sh.irradiance_error(np.asarray(coefficients).reshape(9, 3), exact_sh9(at))


#: Eight probes: four near the corners at table height, four higher and further in, not a
#: regular grid (cameras stand where they can).
PROBES = np.array([[1.0, 0.8, 1.0], [5.0, 0.9, 0.9], [1.1, 0.8, 4.1], [4.9, 0.7, 4.0],
                   [2.2, 2.0, 1.8], [4.0, 2.1, 2.0], [2.0, 1.9, 3.3], [3.9, 2.0, 3.4]])


def random_points(n: int = 40, seed: int = 7) -> np.ndarray:
    """``n`` points where holograms stand: 0.3 m inside the walls, from 0.3 m above the
    floor to 2 m (a head's height)."""
    rng = np.random.default_rng(seed)
    lo, hi = LO + 0.3, np.array([HI[0] - 0.3, 2.0, HI[2] - 0.3])
    return lo + rng.random((n, 3)) * (hi - lo)


def write_probes(folder: Path, positions=PROBES, height: int = 128,
                 blocked: bool = False) -> Path:
    """Each probe's panorama as a float .pfm (lossless), and PROBES.json naming them (with
    the cabinet in the room if ``blocked``)."""
    import json
    import cv2
    folder.mkdir(parents=True, exist_ok=True)
    probes = []
    for i, p in enumerate(positions):
        name = f"probe{i}.pfm"
        image = panorama(p, height, blocked=blocked)
        assert cv2.imwrite(str(folder / name), image[..., ::-1])   # BGR on disk
        probes.append({"name": f"p{i}", "image": name, "position": [float(v) for v in p]})
    path = folder / "probes.json"
    path.write_text(json.dumps({"probes": probes}))
    return path
