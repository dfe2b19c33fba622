"""Projections: per-pixel directions, solid angles and SH weights (no I/O, no pixels).

Every projection maps continuous pixel coordinates ``(px, py)`` (pixel ``(i, j)`` covers
``[i, i+1) × [j, j+1)``; y grows downward) to unit directions in the right-handed, +Y-up
world frame of docs/contract.md §1. From that one map the base class precomputes, once per
(size, options): ``sh_weights`` (H·W, 9), ``∫_pixel Y_lm(ω) dω`` for each pixel (times any
overlap or fill factor), so that the coefficients of a frame are ``weightsᵀ · pixels``: the
exact projection of an image whose radiance is constant over each pixel; ``solid_angle``
(H, W), ``∫_pixel dω`` in steradians, 0 for pixels that see nothing. The integrals use
Gauss-Legendre nodes inside each pixel (:meth:`Projection.quadrature`) and the exact Jacobian
``|∂ω/∂px × ∂ω/∂py|`` (central differences of the direction map), so no projection derives
its own solid-angle formula. Equirect, the common case, is separable and overrides this with
closed-form row and column integrals.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import sh
from .checks import (ProjectionError, check_fisheye_calibration, check_fov,  # noqa: F401
                     check_lens_in_frame, finite)
from .lens_profiles import LensCurve, lens_profile

#: Lower-hemisphere fill models for a fisheye (see :class:`Fisheye`).
FILL_MODELS = ("zero", "ground", "mirror")


def _gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Nodes in [0, 1) and weights summing to 1."""
    x, w = np.polynomial.legendre.leggauss(n)
    return (x + 1) / 2, w / 2


class Projection:
    """Base class. Subclasses set ``name``, ``width``, ``height`` and implement
    :meth:`pixel_to_direction`; they may override :meth:`node_factor`."""

    name = "projection"
    #: Gauss-Legendre nodes per pixel and axis.
    nodes_per_axis = 3

    def __init__(self, width: int, height: int):
        if width < 1 or height < 1:
            raise ProjectionError(f"empty image: {width}×{height}")
        self.width = int(width)
        self.height = int(height)
        self._weights = None
        #: Things that are allowed but probably wrong (a panorama read as a fisheye).
        self.warnings: list[str] = []
        #: Called with the fraction done while the per-pixel weights are integrated.
        self.progress = None

    # -- geometry -------------------------------------------------------------------
    def pixel_to_direction(self, px: np.ndarray, py: np.ndarray):
        """Unit directions (..., 3) and a validity mask (...) for pixel coordinates."""
        raise NotImplementedError

    def node_factor(self, px, py, directions):
        """Extra weight per sample (overlap blending); 1 by default."""
        return 1.0

    def jacobian(self, px, py):
        """Closed-form dω/dpixel² where known; None: central differences of the map."""
        return None

    def extra_terms(self, px, py, directions, jacobian):
        """Additional (..., 9) SH-weight terms per sample (e.g. a fill model); None."""
        return None

    def scaled(self, factor: int) -> "Projection":
        """The same geometry for an image area-downsampled by an integer ``factor``."""
        raise NotImplementedError

    def scaled_source_size(self, factor: int) -> tuple[int, int]:
        """(width, height) of the part of a full frame that :meth:`scaled` covers: the frame
        is cropped to it, then area-averaged to the scaled size."""
        return (self.width // factor * factor, self.height // factor * factor)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.height, self.width)

    def directions(self) -> np.ndarray:
        """Unit direction of each pixel centre, (H, W, 3); zeros where invalid."""
        py, px = np.mgrid[0:self.height, 0:self.width] + 0.5
        d, valid = self.pixel_to_direction(px, py)
        return np.where(valid[..., None], d, 0.0)

    # -- precomputed integrals ----------------------------------------------------------
    def quadrature(self) -> tuple[np.ndarray, np.ndarray]:  # nodes in [0, 1), weights
        return _gauss_legendre(self.nodes_per_axis)          # per pixel side (overridable)

    def _compute_weights(self) -> np.ndarray:
        nodes, gw = self.quadrature()
        out = np.zeros((self.height, self.width, 10))  # 9 SH + plain solid angle
        h = 1e-3
        cols = np.arange(self.width, dtype=np.float64)
        rows_per_chunk = max(1, 400_000 // (self.width * len(nodes) ** 2))
        for r0 in range(0, self.height, rows_per_chunk):
            rows = np.arange(r0, min(self.height, r0 + rows_per_chunk), dtype=np.float64)
            for ny, wy in zip(nodes, gw):
                for nx, wx in zip(nodes, gw):
                    py, px = np.meshgrid(rows + ny, cols + nx, indexing="ij")
                    d, valid = self.pixel_to_direction(px, py)
                    jac = self.jacobian(px, py)
                    if jac is None:
                        dxp, _ = self.pixel_to_direction(px + h, py)
                        dxm, _ = self.pixel_to_direction(px - h, py)
                        dyp, _ = self.pixel_to_direction(px, py + h)
                        dym, _ = self.pixel_to_direction(px, py - h)
                        jac = np.linalg.norm(
                            np.cross((dxp - dxm) / (2 * h), (dyp - dym) / (2 * h)), axis=-1)
                    jac = np.where(valid & np.isfinite(jac), jac, 0.0)
                    d = np.where(valid[..., None], d, 0.0)
                    f = jac * self.node_factor(px, py, d) * (wx * wy)
                    block = np.empty(d.shape[:-1] + (10,))
                    block[..., :9] = sh.sh_basis(d) * f[..., None]
                    block[..., 9] = f
                    extra = self.extra_terms(px, py, d, jac * (wx * wy))
                    if extra is not None:
                        block[..., :9] += extra
                    out[r0:r0 + len(rows)] += block
            if self.progress is not None:
                self.progress(min(1.0, (r0 + len(rows)) / self.height))
        return out

    def _ensure(self):
        if self._weights is None:
            self._weights = self._compute_weights()
        return self._weights

    @property
    def sh_weights(self) -> np.ndarray:
        """(H·W, 9) float64: ``∫_pixel Y_lm dω`` (with overlap/fill terms)."""
        return self._ensure()[..., :9].reshape(-1, 9)

    @property
    def solid_angle(self) -> np.ndarray:
        """(H, W) float64 steradians seen by each pixel (overlap-weighted)."""
        return self._ensure()[..., 9]

    @property
    def coverage(self) -> float:
        """Total solid angle the image sees, in steradians (4π for a full sphere)."""
        return float(self.solid_angle.sum())

    def describe(self) -> dict:
        return {"projection": self.name, "width": self.width, "height": self.height}


class Equirect(Projection):
    """Equirectangular (2:1) panorama, docs/contract.md §1: θ = πv, φ = 2π(u − 0.5),
    d = (sin φ sin θ, cos θ, −cos φ sin θ); the centre looks along −Z."""

    name = "equirect"

    def __init__(self, width: int, height: int):
        super().__init__(width, height)
        if width != 2 * height:
            raise ProjectionError(
                f"an equirect panorama is 2:1 (width = 2 × height); got {width}×{height}")

    def pixel_to_direction(self, px, py):
        theta = np.pi * np.asarray(py) / self.height
        phi = 2 * np.pi * (np.asarray(px) / self.width - 0.5)
        st = np.sin(theta)
        d = np.stack([np.sin(phi) * st, np.cos(theta), -np.cos(phi) * st], axis=-1)
        return d, np.ones(d.shape[:-1], bool)

    def scaled(self, factor: int) -> "Equirect":
        h = max(1, self.height // factor)
        return Equirect(2 * h, h)

    def scaled_source_size(self, factor):
        return (self.width, self.height)  # the whole sphere, resampled by exact areas

    # Separable closed form: every Y_lm·dω is Σ row(θ) × col(φ).
    ROW_FUNCS = 6  # 1, cosθ, sinθ, cos²θ, sinθcosθ, sin²θ   (each times sinθ dθ)
    COL_FUNCS = 6  # 1, sinφ, cosφ, sin²φ, sinφcosφ, cos²φ   (each times dφ)

    def row_integrals(self) -> np.ndarray:
        """(6, H): ∫ f(θ) sin θ dθ over each pixel row, f = 1, cos, sin, cos², sin·cos, sin²."""
        nodes, gw = _gauss_legendre(8)
        t0 = np.arange(self.height)[:, None] + nodes[None]
        theta = np.pi * t0 / self.height
        jac = np.sin(theta) * (np.pi / self.height)
        c, s = np.cos(theta), np.sin(theta)
        funcs = [np.ones_like(c), c, s, c * c, s * c, s * s]
        return np.stack([(f * jac) @ gw for f in funcs])

    def col_integrals(self) -> np.ndarray:
        """(6, W): ∫ g(φ) dφ over each pixel column, g = 1, sin, cos, sin², sin·cos, cos²."""
        nodes, gw = _gauss_legendre(8)
        phi = 2 * np.pi * ((np.arange(self.width)[:, None] + nodes[None]) / self.width - 0.5)
        dphi = 2 * np.pi / self.width
        s, c = np.sin(phi), np.cos(phi)
        funcs = [np.ones_like(c), s, c, s * s, s * c, c * c]
        return np.stack([(g * dphi) @ gw for g in funcs])

    # Y_lm·dω = Σ_k const_k · row[ri_k] · col[ci_k]  with x = sinφ sinθ, y = cosθ, z = -cosφ sinθ
    #: (coefficient index, constant, row function, column function)
    SEPARABLE_TERMS = (
        (0, sh.C0, 0, 0),
        (1, sh.C1, 1, 0),                 # y
        (2, -sh.C1, 2, 2),                # z = -sinθ cosφ
        (3, sh.C1, 2, 1),                 # x = sinθ sinφ
        (4, sh.C2, 4, 1),                 # xy = sinθcosθ sinφ
        (5, -sh.C2, 4, 2),                # yz = -sinθcosθ cosφ
        (6, 3 * sh.C20, 5, 5),            # 3z² = 3 sin²θ cos²φ
        (6, -sh.C20, 0, 0),               # -1
        (7, -sh.C2, 5, 4),                # xz = -sin²θ sinφ cosφ
        (8, sh.C22, 5, 3),                # x² = sin²θ sin²φ
        (8, -sh.C22, 3, 0),               # -y² = -cos²θ
    )

    def _compute_weights(self):
        rows, cols = self.row_integrals(), self.col_integrals()
        out = np.zeros((self.height, self.width, 10))
        for k, const, ri, ci in self.SEPARABLE_TERMS:
            out[..., k] += const * np.outer(rows[ri], cols[ci])
        out[..., 9] = np.outer(rows[0], cols[0])
        return out


def _orthonormal_frame(forward, right):
    f = np.asarray(forward, np.float64)
    f = f / np.linalg.norm(f)
    r = np.asarray(right, np.float64)
    r = r - f * (r @ f)
    r = r / np.linalg.norm(r)
    up = np.cross(r, f)  # right-handed: right × forward = image up
    return f, r, up


@dataclass
class FisheyeLens:
    """One circular fisheye image: centre (pixels), focal length (pixels per radian for the
    equidistant model r = f·θ), field of view (degrees), and its mount: the world direction
    of the optical axis and of the image's +x (right). Or an OpenCV fisheye calibration
    (Kannala-Brandt: ``K`` 3×3, ``D`` 4), valid below 180°. ``curve``: a
    :class:`~.lens_profiles.LensCurve` (r = focal·p(θ), e.g. Ricoh's design table) instead
    of the equidistant r = focal·θ."""

    cx: float
    cy: float
    focal: float
    fov_deg: float = 180.0
    forward: tuple = (0.0, 1.0, 0.0)
    right: tuple = (1.0, 0.0, 0.0)
    K: np.ndarray | None = None
    D: np.ndarray | None = None
    frame: tuple = field(init=False, repr=False)
    curve: LensCurve | None = None

    def __post_init__(self):
        self.fov_deg = check_fov(self.fov_deg)
        if self.K is not None:
            self.K, self.D = check_fisheye_calibration(self.K, self.D, self.fov_deg)
            self.cx, self.cy = float(self.K[0, 2]), float(self.K[1, 2])
        elif not (math.isfinite(self.focal) and self.focal > 0):
            raise ProjectionError(f"fisheye focal length must be positive, got {self.focal:g}")
        self.cx = finite(self.cx, "fisheye centre x")
        self.cy = finite(self.cy, "fisheye centre y")
        self.frame = _orthonormal_frame(self.forward, self.right)
        if self.curve is not None:   # a curve replaces the equidistant model, not K, D
            self.curve.check_covers(self.theta_max, "the fisheye", self.K is not None)

    @property
    def circle_radius(self) -> float:
        """Pixel radius of the image circle at the edge of the field of view (the lens
        curve's; for a calibration, its focal length times θ_max, close enough to tell a
        usable circle from a few pixels)."""
        if self.K is None:
            return float(self.radius_of(self.theta_max))
        return float(min(self.K[0, 0], self.K[1, 1])) * self.theta_max

    def radius_of(self, theta):
        """Pixel radius of angles ``theta`` (rad) from the axis (not for a K, D calibration)."""
        return self.focal * (theta if self.curve is None else self.curve.radius(theta))

    @property
    def theta_max(self) -> float:
        return math.radians(self.fov_deg) / 2

    def angles(self, px, py):
        """(θ from the axis, ψ from image right toward image up) of pixel coordinates."""
        dx = np.asarray(px, np.float64) - self.cx
        dy = np.asarray(py, np.float64) - self.cy
        if self.K is None:
            theta = np.hypot(dx, dy) / self.focal
            if self.curve is not None:
                theta = self.curve.theta(theta)
            return theta, np.arctan2(-dy, dx)
        import cv2
        pts = np.stack([np.asarray(px, np.float64), np.asarray(py, np.float64)], -1)
        und = cv2.fisheye.undistortPoints(pts.reshape(-1, 1, 2), self.K, self.D)
        und = und.reshape(pts.shape)
        theta = np.arctan(np.hypot(und[..., 0], und[..., 1]))
        psi = np.arctan2(-und[..., 1], und[..., 0])
        return theta, psi

    def jacobian(self, px, py):
        """dω = sin θ dθ dψ and dA = r dr dψ: dω/dA = sin θ / (r · dr/dθ). Equidistant
        (r = fθ): sin θ / (θ f²); a curve r = f·p(θ): sin θ / (f² p(θ) p′(θ))."""
        if self.K is not None:
            return None
        rho = np.hypot(np.asarray(px) - self.cx, np.asarray(py) - self.cy) / self.focal
        if self.curve is None:
            return np.sinc(rho / np.pi) / self.focal ** 2
        theta = self.curve.theta(rho)   # rho = p(θ); at the axis sin θ / p → 1 / p′(0)
        ratio = np.where(rho > 1e-12, np.sin(theta) / np.maximum(rho, 1e-12),
                         1.0 / self.curve.coefficients[0])
        return ratio / (self.curve.slope(theta) * self.focal ** 2)

    def to_world(self, theta, psi):
        f, r, u = self.frame
        st = np.sin(theta)
        return ((st * np.cos(psi))[..., None] * r + (st * np.sin(psi))[..., None] * u
                + np.cos(theta)[..., None] * f)

    def theta_of(self, directions):
        """Angle between world directions and the optical axis."""
        return np.arccos(np.clip(directions @ self.frame[0], -1.0, 1.0))

    def scaled(self, factor: int) -> "FisheyeLens":
        K = None if self.K is None else self.K * np.array([[1 / factor], [1 / factor], [1]])
        return FisheyeLens(self.cx / factor, self.cy / factor, self.focal / factor,
                           self.fov_deg, self.forward, self.right, K, self.D, curve=self.curve)


class Fisheye(Projection):
    """A single circular fisheye (e.g. a Raspberry Pi camera with a 180° lens).

    Default mount (docs/contract.md §1): optical axis +Y (looking up), image right = +X, image
    top = +Z; equidistant lens r = f·θ with the image circle inscribed in the frame
    (``radius`` = the pixel radius at ``fov/2``). A calibration ``K, D`` (cv2.fisheye), or a
    ``curve`` (:class:`~.lens_profiles.LensCurve`, ``shlight calibrate-lens``), replaces it.

    The directions the lens does not see (the cap beyond ``fov/2``) are filled by
    ``fill`` (all linear in the pixels, so folded into the precomputed weights):

    * ``"ground"`` (default): uniform radiance ``albedo · E_axis / π``, a Lambertian floor
      of albedo ``albedo`` lit by what the lens sees (E_axis: irradiance on a surface facing
      the lens axis). Measured on the nine real panoramas it errs least (docs/compute.md).
    * ``"mirror"``: the seen hemisphere reflected across the lens plane, times ``albedo``.
    * ``"zero"``: nothing (black); under-estimates irradiance facing away from the lens.
    """

    name = "fisheye"
    nodes_per_axis = 2  # the Jacobian is closed-form: 2×2 nodes reach 5e-5 of the coverage

    def __init__(self, width, height, *, fov_deg=180.0, center=None, radius=None,
                 K=None, D=None, forward=(0, 1, 0), right=(1, 0, 0),
                 fill="ground", albedo=0.1, curve=None):
        super().__init__(width, height)
        if fill not in FILL_MODELS:
            raise ProjectionError(f"unknown fill model {fill!r}; choose from {FILL_MODELS}")
        if not 0 <= albedo <= 1:
            raise ProjectionError(f"albedo must be in [0, 1], got {albedo}")
        fov_deg = check_fov(fov_deg)
        if center is None:
            cx, cy = width / 2, height / 2
        else:
            try:
                cx, cy = center
            except (TypeError, ValueError):
                raise ProjectionError(f"fisheye centre must be two numbers, got {center!r}") from None
        if radius is None:
            radius = min(width, height) / 2
        radius = finite(radius, "fisheye radius")
        if radius <= 0:
            raise ProjectionError(f"fisheye radius must be positive, got {radius:g}")
        th = math.radians(fov_deg / 2)   # radius at fov/2, by the curve (a lens file) if given
        focal = radius / (th if curve is None else float(curve.radius(min(th, curve.theta_limit))))
        self.lens = FisheyeLens(cx, cy, focal, fov_deg, tuple(forward), tuple(right), K, D, curve=curve)
        check_lens_in_frame(self.lens, 0, 0, width, height, "the fisheye")
        self.fill, self.albedo = fill, float(albedo)
        if width >= 1.8 * height:
            self.warnings.append(
                f"a {width}×{height} frame is shaped like an equirect panorama (2:1), not a "
                "fisheye circle: is --projection fisheye right?")

    def pixel_to_direction(self, px, py):
        theta, psi = self.lens.angles(px, py)
        valid = theta <= self.lens.theta_max
        return self.lens.to_world(theta, psi), valid

    def jacobian(self, px, py):
        return self.lens.jacobian(px, py)

    def cap_projection(self) -> np.ndarray:
        """(9,) ∫ Y_lm dω over the unseen cap (θ > fov/2) in world coordinates."""
        c0 = math.cos(self.lens.theta_max)
        local = np.zeros(9)
        local[0] = sh.C0 * 2 * math.pi * (c0 + 1)
        local[2] = sh.C1 * math.pi * (c0 * c0 - 1)
        local[6] = sh.C20 * 2 * math.pi * (c0 ** 3 - c0)
        # Rotation taking local +Z to the optical axis.
        f, r, u = self.lens.frame
        R = np.stack([r, u, f], axis=1)  # columns: images of local x, y, z
        return sh.sh_rotation(R) @ local

    def extra_terms(self, px, py, directions, jacobian):
        if self.fill == "zero" or self.albedo == 0:
            return None
        f = self.lens.frame[0]
        cos_axis = directions @ f
        if self.fill == "ground":
            # Each pixel adds albedo/π · max(0, d·a) dω to E_axis, spread over the cap.
            w = (self.albedo / math.pi) * np.maximum(cos_axis, 0.0) * jacobian
            return w[..., None] * self.cap_projection()
        # mirror: seen directions whose reflection lands in the unseen cap.
        theta = np.arccos(np.clip(cos_axis, -1, 1))
        into_cap = (math.pi - theta) > self.lens.theta_max
        reflected = directions - 2 * cos_axis[..., None] * f
        w = self.albedo * jacobian * into_cap
        return sh.sh_basis(reflected) * w[..., None]

    def scaled(self, factor: int) -> "Fisheye":
        p = Fisheye.__new__(Fisheye)
        Projection.__init__(p, self.width // factor, self.height // factor)
        p.lens = self.lens.scaled(factor)
        check_lens_in_frame(p.lens, 0, 0, p.width, p.height,
                            f"after --downsample {factor}, the fisheye")
        p.fill, p.albedo = self.fill, self.albedo
        return p

    def describe(self):
        return {**super().describe(), "fov_deg": self.lens.fov_deg, "fill": self.fill,
                "albedo": self.albedo}


class DualFisheye(Projection):
    """The raw two-circle frame of a Ricoh Theta (USB live mode, dual-fisheye stills),
    integrated lens by lens with no stitching.

    ``lens``: a profile of :mod:`.lens_profiles` ("equidistant": r = f·θ, 90° ring 284 px at
    1280×720; "theta-s", "-sc", "-sc2", "-v", "-z1", "-x": Ricoh's design curves at each
    model's frame size): curve, centres, ring, field of view; ``centers``, ``focal`` (90°
    ring / (π/2), px) and ``fov_deg`` given here (a per-unit calibration) override them.
    ``front``: the circle whose axis is −Z (docs/contract.md §8), "left" or "right": image
    right +X, up +Y; the other's axis +Z, right −X, up +Y. Directions both lenses see are
    shared by a partition of unity: w_A = s_A / (s_A + s_B), s = θ_max − θ.
    """

    name = "dual-fisheye"
    nodes_per_axis = 2

    def __init__(self, width, height, *, fov_deg=None, centers=None, focal=None,
                 yaw_deg=0.0, lens="equidistant", front=None):
        super().__init__(width, height)
        if width < height:
            raise ProjectionError(
                f"a dual-fisheye frame holds two circles side by side; got {width}×{height}")
        profile = lens_profile(lens)
        if centers is None or focal is None:
            p_centers, p_focal, _ = profile.geometry(width, height)
            centers = p_centers if centers is None else centers
            focal = p_focal if focal is None else focal
        fov_deg = profile.fov_deg if fov_deg is None else fov_deg
        front = profile.front if front is None else front
        if front not in ("left", "right"):
            raise ProjectionError(f"the front circle is 'left' or 'right', not {front!r}")
        R = sh.rotation_from_euler(finite(yaw_deg, "dual-fisheye yaw"))
        focal = finite(focal, "dual-fisheye focal length")
        mounts = [(R @ [0, 0, -1], R @ [1, 0, 0]), (R @ [0, 0, 1], R @ [-1, 0, 0])]
        if front == "right":
            mounts.reverse()
        self.lenses = tuple(
            FisheyeLens(*c, focal, fov_deg, tuple(f), tuple(r), curve=profile.curve())
            for c, (f, r) in zip(centers, mounts))
        self._check_lenses()
        self.lens_name, self.front, self._yaw = profile.name, front, yaw_deg

    def _check_lenses(self, what=""):
        half = self.width / 2
        check_lens_in_frame(self.lenses[0], 0, 0, half, self.height, f"{what}the left lens's")
        check_lens_in_frame(self.lenses[1], half, 0, self.width, self.height,
                            f"{what}the right lens's")

    def _lens_index(self, px):
        return (np.asarray(px) >= self.width / 2).astype(int)

    def pixel_to_direction(self, px, py):
        idx = self._lens_index(px)
        d = np.zeros(np.shape(px) + (3,))
        valid = np.zeros(np.shape(px), bool)
        for i, lens in enumerate(self.lenses):
            theta, psi = lens.angles(px, py)
            sel = idx == i
            d = np.where(sel[..., None], lens.to_world(theta, psi), d)
            valid |= sel & (theta <= lens.theta_max)
        return d, valid

    def jacobian(self, px, py):
        idx = self._lens_index(px)
        js = [lens.jacobian(px, py) for lens in self.lenses]
        if js[0] is None:
            return None
        return np.where(idx == 0, js[0], js[1])

    def node_factor(self, px, py, directions):
        idx = self._lens_index(px)
        s = [np.maximum(lens.theta_max - lens.theta_of(directions), 0.0) for lens in self.lenses]
        total = s[0] + s[1]
        own = np.where(idx == 0, s[0], s[1])
        return np.where(total > 0, own / np.where(total > 0, total, 1.0), 0.0)

    def scaled(self, factor: int) -> "DualFisheye":
        p = DualFisheye.__new__(DualFisheye)
        Projection.__init__(p, self.width // factor, self.height // factor)
        p.lenses = tuple(lens.scaled(factor) for lens in self.lenses)
        p._check_lenses(f"after --downsample {factor}, ")
        p.lens_name, p.front, p._yaw = self.lens_name, self.front, self._yaw
        return p

    def describe(self):
        return {**super().describe(), "lens": self.lens_name, "front": self.front}


class CubeMap(Projection):
    """Six square faces side by side (6:1), in OpenGL order +X, −X, +Y, −Y, +Z, −Z and
    OpenGL orientation (the layout ``glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + i)``
    expects, first row of each face at t = 0)."""

    name = "cubemap"

    def __init__(self, width, height):
        super().__init__(width, height)
        if width != 6 * height:
            raise ProjectionError(
                f"a cube map is six square faces side by side (6:1); got {width}×{height}")
        if height < 2:
            raise ProjectionError(f"cube map faces of {height} px are too small to integrate "
                                  "(at least 2 px)")
        self.face = height

    def pixel_to_direction(self, px, py):
        px = np.asarray(px, np.float64)
        py = np.asarray(py, np.float64)
        f = np.clip(np.floor(px / self.face), 0, 5).astype(int)
        a = 2 * (px - f * self.face) / self.face - 1
        b = 2 * py / self.face - 1
        one = np.ones_like(a)
        faces = [
            (one, -b, -a), (-one, -b, a), (a, one, b),
            (a, -one, -b), (a, -b, one), (-a, -b, -one),
        ]
        d = np.zeros(px.shape + (3,))
        for i, (x, y, z) in enumerate(faces):
            d = np.where((f == i)[..., None], np.stack([x, y, z], -1), d)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return d, np.ones(px.shape, bool)

    def _compute_weights(self):
        # Finite differences must not straddle two faces: integrate each face separately.
        out = np.zeros((self.height, self.width, 10))
        nodes, gw = _gauss_legendre(self.nodes_per_axis)
        n = self.face
        for f in range(6):
            for ny, wy in zip(nodes, gw):
                for nx, wx in zip(nodes, gw):
                    py, px = np.meshgrid(np.arange(n) + ny, np.arange(n) + nx, indexing="ij")
                    a = 2 * px / n - 1
                    b = 2 * py / n - 1
                    d, _ = self.pixel_to_direction(px + f * n, py)
                    # Exact texel Jacobian of a cube face: (2/n)² / (1 + a² + b²)^{3/2}.
                    jac = (2.0 / n) ** 2 / (1 + a * a + b * b) ** 1.5 * wx * wy
                    out[:, f * n:(f + 1) * n, :9] += sh.sh_basis(d) * jac[..., None]
                    out[:, f * n:(f + 1) * n, 9] += jac
            if self.progress is not None:
                self.progress((f + 1) / 6)
        return out

    def scaled(self, factor):
        h = max(1, self.height // factor)
        return CubeMap(6 * h, h)

    def scaled_source_size(self, factor):
        return (self.width, self.height)


PROJECTIONS = {"equirect": Equirect, "fisheye": Fisheye, "dual-fisheye": DualFisheye,
               "cubemap": CubeMap}


def make_projection(name: str, width: int, height: int, **options) -> Projection:
    """Build a projection by name ("equirect", "fisheye", "dual-fisheye", "cubemap")."""
    try:
        cls = PROJECTIONS[name]
    except KeyError:
        raise ProjectionError(
            f"unknown projection {name!r}; choose from {', '.join(PROJECTIONS)}") from None
    try:
        return cls(width, height, **options)
    except TypeError as exc:
        raise ProjectionError(f"bad options for projection {name!r}: {exc}") from None
