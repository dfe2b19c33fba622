"""Light-probe projections: a mirror ball, Debevec's angular map, the 3×4 / 4×3 cube cross.

Each is a :class:`~provider.core.geometry.projections.Projection` (unit directions per continuous
pixel coordinate in the world frame of docs/contract.md §1; the base class integrates the
SH weights and exact solid angles once). Importing this module registers them in
:func:`~provider.core.geometry.projections.make_projection` as ``"mirrorball"``, ``"angular"`` and
``"cross"`` (the engine imports it).

A ball or angular map is a disc in the frame (``center``, ``radius`` in pixels; default:
the circle inscribed in the frame). Only the integer box holding the disc is integrated:
``window`` = (x0, y0, x1, y1) of that box in the frame (None when it is the whole frame),
and the engine crops every frame to it before anything else, so a small ball in a large
webcam frame costs only its own pixels.
"""
from __future__ import annotations

import math

import numpy as np

from . import sh
from .checks import MIN_CIRCLE_PX, ProjectionError, finite
from .projections import PROJECTIONS, Projection, _gauss_legendre

#: How a mirror ball's unseen cones (behind the ball, the camera's reflection) are filled.
PROBE_FILLS = ("rim", "zero")
#: "rim": an unseen cone gets the mean radiance of the seen band this wide (radians) around it.
RIM_BAND = math.radians(20.0)


def cone_projection(axis, half_angle: float) -> np.ndarray:
    """(9,) ``∫ Y_lm dω`` over the cone of directions within ``half_angle`` (radians) of
    the unit ``axis`` (world frame)."""
    c = math.cos(half_angle)
    local = np.zeros(9)                       # about local +Z
    local[0] = sh.C0 * 2 * math.pi * (1 - c)
    local[2] = sh.C1 * math.pi * (1 - c * c)
    local[6] = sh.C20 * 2 * math.pi * (c - c ** 3)
    z = np.asarray(axis, np.float64) / np.linalg.norm(axis)
    helper = np.array([1.0, 0, 0]) if abs(z[0]) < 0.9 else np.array([0, 1.0, 0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    R = np.stack([x, np.cross(z, x), z], axis=1)   # columns: images of local x, y, z
    return sh.sh_rotation(R) @ local


def ball_distance(radius_px: float, frame_width: float, hfov_deg: float) -> float:
    """Camera-to-ball-centre distance, in ball radii, of a ball ``radius_px`` in radius in a
    frame ``frame_width`` wide, taken through a pinhole lens of horizontal field of view
    ``hfov_deg`` with the ball near its axis: 1 / sin α, where tan α = radius / focal."""
    hfov_deg = finite(hfov_deg, "the camera's field of view")
    if not 0 < hfov_deg < 180:
        raise ProjectionError("the camera's field of view (--fov, for a mirror ball) is in "
                              f"(0, 180) degrees, got {hfov_deg:g}")
    focal = (frame_width / 2) / math.tan(math.radians(hfov_deg) / 2)
    return 1 / math.sin(math.atan(radius_px / focal))


class _Disc(Projection):
    """A projection whose image is a disc: ``center`` (px, frame coordinates) and ``radius``
    (px). With ``crop`` the projection covers only the integer box holding the disc
    (``window``); ``scaled`` copies never crop (the engine crops the full frame first)."""

    what = "disc"

    def _setup_disc(self, width, height, center, radius, crop):
        if width < 1 or height < 1:
            raise ProjectionError(f"empty image: {width}×{height}")
        if center is None:
            cx, cy = width / 2, height / 2
        else:
            try:
                cx, cy = center
            except (TypeError, ValueError):
                raise ProjectionError(
                    f"the {self.what} centre must be two numbers, got {center!r}") from None
        cx, cy = finite(cx, f"{self.what} centre x"), finite(cy, f"{self.what} centre y")
        r = min(width, height) / 2 if radius is None else finite(radius, f"{self.what} radius")
        if r <= 0:
            raise ProjectionError(f"the {self.what} radius must be positive, got {r:g}")
        if not (0 <= cx <= width and 0 <= cy <= height):
            raise ProjectionError(
                f"the {self.what} centre ({cx:g}, {cy:g}) is outside the {width}×{height} "
                "frame: check --ball / --center")
        if r < MIN_CIRCLE_PX:
            raise ProjectionError(
                f"the {self.what} is {r:.1f} px in radius: too small to integrate (at least "
                f"{MIN_CIRCLE_PX:g} px; a larger frame, a smaller --downsample, or check "
                "--ball / --radius)")
        box = (0, 0, int(width), int(height))
        if crop:
            box = (max(0, math.floor(cx - r)), max(0, math.floor(cy - r)),
                   min(int(width), math.ceil(cx + r)), min(int(height), math.ceil(cy + r)))
        Projection.__init__(self, box[2] - box[0], box[3] - box[1])
        self.window = None if box == (0, 0, width, height) else box
        self.cx, self.cy, self.r = cx - box[0], cy - box[1], r
        if cx - r < -0.5 or cy - r < -0.5 or cx + r > width + 0.5 or cy + r > height + 0.5:
            self.warnings.append(
                f"the {self.what} (centre {cx:g}, {cy:g}, radius {r:g} px) runs past the edge "
                f"of the {width}×{height} frame: what lies outside is not seen (coverage_sr)")

    def normalised(self, px, py):
        """(u, v) in units of the radius: u toward image right, v toward image up."""
        return ((np.asarray(px, np.float64) - self.cx) / self.r,
                (self.cy - np.asarray(py, np.float64)) / self.r)

    def _disc_options(self) -> dict:
        return {}

    def scaled(self, factor: int):
        return type(self)(self.width // factor, self.height // factor,
                          center=(self.cx / factor, self.cy / factor), radius=self.r / factor,
                          crop=False, **self._disc_options())

    def describe(self):
        out = {**super().describe(), "center": [self.cx, self.cy], "radius": self.r}
        if self.window is not None:
            out["window"] = list(self.window)
        return out


class MirrorBall(_Disc):
    """A perfect mirror sphere seen by a camera looking along −Z (image right = +X, up =
    +Y), filling the disc ``center``, ``radius`` (default: inscribed in the frame).

    Orthographic view (``distance=None``): the point at normalised image offset (u, v) has
    normal n = (u, v, √(1 − u² − v²)) and reflects r = 2 n_z n − Z: the centre reflects +Z
    (back at the camera), the rim −Z, and every pixel sees the same solid angle, 4/radius²
    steradians per px² (closed form). ``distance`` (camera to ball centre, in ball radii):
    a pinhole camera at that distance instead; the rim then reflects the edge of the
    ball's own shadow cone, asin(1/distance) around −Z. ``fov_deg`` (the camera's horizontal
    field of view) gives that distance from the ball's apparent size in the frame.

    Unseen cones, reported by ``coverage_sr`` and filled by ``fill``:

    * ``unseen_deg``: directions within this angle of −Z (behind the ball: reflected by the
      last, grazing pixels of the rim, which a real ball blurs and an edge detector misses)
      are not used (the perspective shadow cone is always unseen);
    * ``mask_deg``: directions within this angle of +Z (the camera's own reflection in the
      ball's centre, and the photographer) are not used.

    ``fill``: ``"rim"`` (default) fills each unseen cone with the mean radiance of the seen
    band 20° wide around it; ``"zero"`` leaves it black. Both are linear in the pixels and
    folded into the precomputed weights.
    """

    name = "mirrorball"
    what = "ball"
    nodes_per_axis = 2

    def __init__(self, width, height, *, center=None, radius=None, unseen_deg=0.0,
                 mask_deg=0.0, fill="rim", distance=None, fov_deg=None, crop=True):
        if fill not in PROBE_FILLS:
            raise ProjectionError(f"unknown mirror-ball fill {fill!r}; choose from "
                                  f"{', '.join(PROBE_FILLS)}")
        unseen_deg = finite(unseen_deg, "the unseen cone behind the ball")
        mask_deg = finite(mask_deg, "the camera mask")
        if not 0 <= unseen_deg < 90 or not 0 <= mask_deg < 90:
            raise ProjectionError("the unseen cone behind the ball and the camera mask are "
                                  f"angles in [0, 90) degrees; got {unseen_deg:g} and {mask_deg:g}")
        if distance is not None:
            distance = finite(distance, "the ball distance")
            if distance <= 1:
                raise ProjectionError("the camera-to-ball distance is in ball radii and must "
                                      f"exceed 1 (the camera is outside the ball); got {distance:g}")
        self._setup_disc(width, height, center, radius, crop)
        if fov_deg is not None and distance is None:
            distance = ball_distance(self.r, width, fov_deg)
        self.fill, self.distance = fill, distance
        self.unseen_deg, self.mask_deg = unseen_deg, mask_deg
        #: Half-angle (radians) of the ball's own shadow cone around −Z (0: orthographic).
        self.shadow = 0.0 if distance is None else math.asin(1 / distance)
        self.unseen = max(math.radians(unseen_deg), self.shadow)
        self.mask = math.radians(mask_deg)

    def _disc_options(self):
        return dict(unseen_deg=self.unseen_deg, mask_deg=self.mask_deg, fill=self.fill,
                    distance=self.distance)

    def reflect(self, px, py):
        """Reflected unit directions (..., 3) and whether each pixel lies on the ball."""
        u, v = self.normalised(px, py)
        s2 = u * u + v * v
        on_ball = s2 <= 1.0
        if self.distance is None:
            nz = np.sqrt(np.clip(1.0 - s2, 0.0, 1.0))
            d = np.stack([2 * nz * u, 2 * nz * v, 2 * nz * nz - 1], axis=-1)
            return d, on_ball
        D = self.distance
        t = math.tan(self.shadow)                  # image radius of the silhouette, tan α
        ray = np.stack([u * t, v * t, -np.ones_like(u)], axis=-1)
        ray /= np.linalg.norm(ray, axis=-1, keepdims=True)
        b = D * ray[..., 2]                         # ray · camera position (0, 0, D)
        hit = -b - np.sqrt(np.maximum(b * b - (D * D - 1), 0.0))
        n = ray * hit[..., None]
        n[..., 2] += D
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        d = ray - 2 * np.sum(ray * n, axis=-1, keepdims=True) * n
        return d, on_ball

    def _cones(self):
        """(axis, half-angle) of each unseen cone with a non-zero angle."""
        return [(a, g) for a, g in (((0.0, 0.0, -1.0), self.unseen), ((0.0, 0.0, 1.0), self.mask))
                if g > 0]

    def pixel_to_direction(self, px, py):
        d, valid = self.reflect(px, py)
        for axis, angle in self._cones():
            valid = valid & (d[..., 2] * axis[2] < math.cos(angle))
        return d, valid

    def jacobian(self, px, py):
        if self.distance is not None:
            return None
        return np.full(np.shape(px), 4.0 / (self.r * self.r))

    def extra_terms(self, px, py, directions, jacobian):
        if self.fill == "zero" or not self._cones():
            return None
        out = np.zeros(np.shape(jacobian) + (9,))
        for axis, angle in self._cones():
            cos_axis = directions[..., 2] * axis[2]
            outer = min(angle + RIM_BAND, math.pi)
            band = (cos_axis < math.cos(angle)) & (cos_axis >= math.cos(outer))
            band_sr = 2 * math.pi * (math.cos(angle) - math.cos(outer))
            w = np.where(band, jacobian, 0.0) / band_sr
            out += w[..., None] * cone_projection(axis, angle)
        return out

    @property
    def unseen_sr(self) -> float:
        """Solid angle (sr) of the unseen cones, before any frame edge."""
        return sum(2 * math.pi * (1 - math.cos(g)) for _, g in self._cones())

    def describe(self):
        return {**super().describe(), "fill": self.fill, "unseen_deg": self.unseen_deg,
                "mask_deg": self.mask_deg, "distance": self.distance}


class AngularMap(_Disc):
    """Debevec's angular map (light probe format): the disc ``center``, ``radius`` (default:
    inscribed in the frame) looks along −Z at its centre, image right = +X, up = +Y; the
    distance from the centre is proportional to the angle from −Z, θ = π·ρ/radius, so the
    rim is +Z. dω per px² = (π/radius)² · sin θ / θ (closed form)."""

    name = "angular"
    what = "angular map"
    nodes_per_axis = 2

    def __init__(self, width, height, *, center=None, radius=None, crop=True):
        self._setup_disc(width, height, center, radius, crop)

    def pixel_to_direction(self, px, py):
        u, v = self.normalised(px, py)
        s = np.hypot(u, v)
        theta = np.pi * s
        k = np.pi * np.sinc(s)                    # sin θ / s, finite at the centre
        d = np.stack([k * u, k * v, -np.cos(theta)], axis=-1)
        return d, s <= 1.0

    def jacobian(self, px, py):
        u, v = self.normalised(px, py)
        return (math.pi / self.r) ** 2 * np.sinc(np.hypot(u, v))


def _face(name):
    """Direction (x, y, z) of face coordinates a (→ image right) and b (→ image down) in
    [−1, 1], for the cross seen from inside the cube, front −Z at the centre."""
    return {
        "front": lambda a, b: (a, -b, -1.0),     # −Z
        "left": lambda a, b: (-1.0, -b, -a),     # −X
        "right": lambda a, b: (1.0, -b, a),      # +X
        "up": lambda a, b: (a, 1.0, -b),         # +Y, above the front
        "down": lambda a, b: (a, -1.0, b),       # −Y, below the front
        "back": lambda a, b: (-a, -b, 1.0),      # +Z, right of +X (horizontal cross)
        "back-under": lambda a, b: (a, b, 1.0),  # +Z, under −Y, upside down (vertical cross)
    }[name]


#: (columns, rows, {(column, row): face}) of the two crosses.
CROSS_LAYOUTS = {
    "horizontal": (4, 3, {(1, 0): "up", (0, 1): "left", (1, 1): "front", (2, 1): "right",
                          (3, 1): "back", (1, 2): "down"}),
    "vertical": (3, 4, {(1, 0): "up", (0, 1): "left", (1, 1): "front", (2, 1): "right",
                        (1, 2): "down", (1, 3): "back-under"}),
}


class CubeCross(Projection):
    """A cube unfolded into a cross of square faces, seen from inside: 4×3 faces
    (horizontal: −X, −Z, +X, +Z across the middle row, +Y above and −Y below −Z) or 3×4
    (vertical, Debevec's: +Y; −X, −Z, +X; −Y; then +Z upside down). Every seam is
    continuous; the cells outside the cross see nothing."""

    name = "cross"

    def __init__(self, width, height):
        super().__init__(width, height)
        if 3 * width == 4 * height:
            self.layout = "horizontal"
        elif 4 * width == 3 * height:
            self.layout = "vertical"
        else:
            raise ProjectionError(
                "a cube cross is 4×3 (horizontal) or 3×4 (vertical) square faces; got "
                f"{width}×{height}")
        self.cols, self.rows, faces = CROSS_LAYOUTS[self.layout]
        self.face = width // self.cols
        if self.face < 2:
            raise ProjectionError(f"cube cross faces of {self.face} px are too small to "
                                  "integrate (at least 2 px)")
        self.faces = {cell: _face(name) for cell, name in faces.items()}

    def pixel_to_direction(self, px, py):
        px = np.asarray(px, np.float64)
        py = np.asarray(py, np.float64)
        n = self.face
        col = np.clip(np.floor(px / n), 0, self.cols - 1)
        row = np.clip(np.floor(py / n), 0, self.rows - 1)
        a = 2 * (px - col * n) / n - 1
        b = 2 * (py - row * n) / n - 1
        d = np.zeros(px.shape + (3,))
        valid = np.zeros(px.shape, bool)
        for (c, r), f in self.faces.items():
            sel = (col == c) & (row == r)
            d = np.where(sel[..., None], np.stack(np.broadcast_arrays(*f(a, b)), -1), d)
            valid |= sel
        norm = np.linalg.norm(d, axis=-1, keepdims=True)
        return d / np.where(norm > 0, norm, 1.0), valid

    def _compute_weights(self):
        # Exact texel Jacobian per face, (2/n)² / (1 + a² + b²)^{3/2}, as CubeMap.
        out = np.zeros((self.height, self.width, 10))
        nodes, gw = _gauss_legendre(self.nodes_per_axis)
        n = self.face
        for k, ((c, r), f) in enumerate(self.faces.items()):
            for ny, wy in zip(nodes, gw):
                for nx, wx in zip(nodes, gw):
                    py, px = np.meshgrid(np.arange(n) + ny, np.arange(n) + nx, indexing="ij")
                    a, b = 2 * px / n - 1, 2 * py / n - 1
                    d = np.stack(np.broadcast_arrays(*f(a, b)), -1)
                    d /= np.linalg.norm(d, axis=-1, keepdims=True)
                    jac = (2.0 / n) ** 2 / (1 + a * a + b * b) ** 1.5 * wx * wy
                    block = out[r * n:(r + 1) * n, c * n:(c + 1) * n]
                    block[..., :9] += sh.sh_basis(d) * jac[..., None]
                    block[..., 9] += jac
            if self.progress is not None:
                self.progress((k + 1) / 6)
        return out

    def scaled(self, factor):
        m = max(1, self.face // factor)
        return CubeCross(self.cols * m, self.rows * m)

    def scaled_source_size(self, factor):
        return (self.width, self.height)

    def describe(self):
        return {**super().describe(), "layout": self.layout}


PROBE_PROJECTIONS = {"mirrorball": MirrorBall, "angular": AngularMap, "cross": CubeCross}
PROJECTIONS.update(PROBE_PROJECTIONS)
