"""Fisheye lens curves and the Ricoh Theta lens profiles (no I/O).

A :class:`LensCurve` is a monotone radial map of a fisheye lens: the angle θ from the optical
axis (radians) to an image height ``p(θ)`` in units of the lens's ``focal`` (pixels), an odd
polynomial ``p(θ) = c₁θ + c₃θ³ + c₅θ⁵ + …`` (Kannala-Brandt's form; the equidistant lens is
``p(θ) = θ``). :class:`~.projections.FisheyeLens` holds one: pixel radius ``r = focal·p(θ)``,
its inverse for pixel → angle, and its derivative for the exact solid angle of a pixel,
``dω/dA = sin θ / (r · dr/dθ)``.

The Theta profiles are Ricoh's published design tables (half angle of view → image height,
theta-api-specs ``theta-lens/README.md``, https://github.com/ricohapi/theta-api-specs, commit
bf3b75e5, "They are just design value"): THETA V (and S/SC/SC2, "also use same lens unit"),
Z1 and X/A1, at 1° steps from 0 to 100°. Each table is fitted by an odd 13th-degree
polynomial (worst residual 0.16 px (V, Z1) and 0.87 px (X 11K) at the stills' size, below
0.034 % of the 90° radius; lower degrees miss the tables' bend near 90° by up to 5 px),
scaled so that
``p(90°) = π/2``: ``focal`` keeps its meaning "90° ring radius / (π/2)" for every lens, and a
per-unit calibration of the ring (``focal``) or the centres overrides the profile's numbers
while keeping its curve.

Sizes (:data:`PROFILES`): the S/SC/SC2 USB live stream at 1280×720 and 1920×1080 with the 90°
ring that public calibrations of a real Theta S measure (287.0–289.7 px at 1280×720,
RobInLab/ricoh_camera, Apache-2.0: 288.5 px used); the V, Z1 and X dual-fisheye stills at the
sizes their tables' pixel columns are for (pixel pitch 1.55, 2.4, 0.8/1.6 µm). Other sizes of
the same aspect ratio are scaled from the first native size.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .checks import ProjectionError

#: Ricoh's design tables: image height (mm) at half angles 0, 1, …, 100°.
RICOH_TABLES_MM = {
    "V": (
        0.0000, 0.0230, 0.0459, 0.0689, 0.0919, 0.1148, 0.1378, 0.1608, 0.1837, 0.2067, 0.2296,
        0.2526, 0.2755, 0.2984, 0.3213, 0.3442, 0.3671, 0.3900, 0.4129, 0.4357, 0.4586, 0.4814,
        0.5042, 0.5270, 0.5498, 0.5725, 0.5953, 0.6180, 0.6407, 0.6633, 0.6860, 0.7086, 0.7312,
        0.7538, 0.7764, 0.7990, 0.8215, 0.8440, 0.8665, 0.8890, 0.9115, 0.9340, 0.9564, 0.9789,
        1.0013, 1.0237, 1.0461, 1.0685, 1.0909, 1.1133, 1.1357, 1.1580, 1.1804, 1.2027, 1.2250,
        1.2473, 1.2695, 1.2917, 1.3139, 1.3361, 1.3582, 1.3803, 1.4023, 1.4242, 1.4461, 1.4680,
        1.4897, 1.5114, 1.5329, 1.5544, 1.5758, 1.5970, 1.6181, 1.6390, 1.6598, 1.6804, 1.7009,
        1.7211, 1.7411, 1.7609, 1.7804, 1.7996, 1.8186, 1.8372, 1.8556, 1.8736, 1.8912, 1.9084,
        1.9253, 1.9417, 1.9575, 1.9733, 1.9884, 2.0030, 2.0172, 2.0308, 2.0440, 2.0566, 2.0688,
        2.0804, 2.0915),
    "Z1": (
        0.0000, 0.0451, 0.0902, 0.1354, 0.1806, 0.2259, 0.2714, 0.3169, 0.3626, 0.4085, 0.4546,
        0.5009, 0.5474, 0.5941, 0.6411, 0.6884, 0.7359, 0.7837, 0.8317, 0.8801, 0.9287, 0.9776,
        1.0268, 1.0762, 1.1259, 1.1758, 1.2259, 1.2762, 1.3266, 1.3772, 1.4279, 1.4787, 1.5295,
        1.5804, 1.6313, 1.6822, 1.7330, 1.7838, 1.8344, 1.8850, 1.9354, 1.9857, 2.0358, 2.0857,
        2.1354, 2.1848, 2.2341, 2.2831, 2.3319, 2.3804, 2.4287, 2.4767, 2.5244, 2.5719, 2.6191,
        2.6660, 2.7126, 2.7590, 2.8051, 2.8509, 2.8964, 2.9417, 2.9867, 3.0315, 3.0760, 3.1202,
        3.1641, 3.2078, 3.2512, 3.2944, 3.3372, 3.3798, 3.4220, 3.4639, 3.5055, 3.5467, 3.5875,
        3.6279, 3.6679, 3.7074, 3.7463, 3.7848, 3.8226, 3.8599, 3.8965, 3.9325, 3.9678, 4.0024,
        4.0362, 4.0692, 4.1011, 4.1329, 4.1635, 4.1932, 4.2221, 4.2501, 4.2772, 4.3034, 4.3288,
        4.3533, 4.3768),
    "X": (
        0.0000, 0.0244, 0.0489, 0.0733, 0.0977, 0.1221, 0.1465, 0.1709, 0.1952, 0.2196, 0.2439,
        0.2683, 0.2926, 0.3169, 0.3412, 0.3655, 0.3897, 0.4140, 0.4383, 0.4626, 0.4869, 0.5113,
        0.5356, 0.5600, 0.5844, 0.6088, 0.6332, 0.6577, 0.6823, 0.7068, 0.7314, 0.7561, 0.7808,
        0.8055, 0.8303, 0.8551, 0.8799, 0.9048, 0.9298, 0.9548, 0.9798, 1.0048, 1.0299, 1.0550,
        1.0802, 1.1053, 1.1305, 1.1556, 1.1808, 1.2060, 1.2311, 1.2562, 1.2813, 1.3064, 1.3314,
        1.3563, 1.3812, 1.4059, 1.4306, 1.4552, 1.4797, 1.5040, 1.5282, 1.5522, 1.5760, 1.5997,
        1.6232, 1.6465, 1.6695, 1.6924, 1.7149, 1.7373, 1.7593, 1.7811, 1.8025, 1.8237, 1.8445,
        1.8650, 1.8851, 1.9049, 1.9243, 1.9433, 1.9619, 1.9800, 1.9978, 2.0151, 2.0319, 2.0483,
        2.0642, 2.0796, 2.0942, 2.1089, 2.1228, 2.1362, 2.1490, 2.1613, 2.1730, 2.1842, 2.1948,
        2.2048, 2.2142),
}
#: Ricoh's pixel pitch of each table's pixel column (mm per pixel).
RICOH_PITCH_MM = {"V": 0.00155, "Z1": 0.0024, "X": 0.0008}


class LensCurve:
    """Image height ``p(θ) = Σ c_k θ^(2k+1)`` (units of the lens's focal length) for
    θ in [0, ``theta_limit``] radians, where it must rise; its inverse and derivative.

    ``coefficients``: (c₁, c₃, c₅, …). ``name``: where it comes from (shown in descriptions).
    """

    GRID = 4097

    def __init__(self, coefficients, theta_limit: float, name: str = "curve"):
        c = np.asarray(coefficients, np.float64).ravel()
        if c.size < 1 or not np.all(np.isfinite(c)) or c[0] <= 0:
            raise ProjectionError(f"lens curve {name}: coefficients must be finite numbers, "
                                  f"the first (dr/dθ at the axis) positive; got {list(c)}")
        if not (math.isfinite(theta_limit) and 0 < theta_limit <= math.pi):
            raise ProjectionError(f"lens curve {name}: its limit must be in (0°, 180°]")
        self.coefficients, self.theta_limit, self.name = c, float(theta_limit), name
        grid = np.linspace(0.0, self.theta_limit, self.GRID)
        if not np.all(self.slope(grid) > 0):
            bad = grid[np.argmax(self.slope(grid) <= 0)]
            raise ProjectionError(f"lens curve {name} stops rising at θ = "
                                  f"{math.degrees(bad):.1f}° (before its limit "
                                  f"{math.degrees(self.theta_limit):.1f}°): not a lens")
        self._grid, self._height = grid, self.radius(grid)
        self._end_slope = float(self.slope(grid[-1]))

    def radius(self, theta):
        """Image height p(θ) in focal lengths."""
        t = np.asarray(theta, np.float64)
        t2, acc = t * t, np.zeros_like(t)
        for ck in self.coefficients[::-1]:
            acc = acc * t2 + ck
        return acc * t

    def slope(self, theta):
        """dp/dθ."""
        t = np.asarray(theta, np.float64)
        t2, acc = t * t, np.zeros_like(t)
        for k in range(len(self.coefficients) - 1, -1, -1):
            acc = acc * t2 + (2 * k + 1) * self.coefficients[k]
        return acc

    def theta(self, height):
        """θ (radians) of image heights (focal lengths): a table, then one Newton step;
        beyond the limit, continued along the last tangent (only ever unseen pixels)."""
        h = np.asarray(height, np.float64)
        t = np.interp(h, self._height, self._grid)
        inside = h <= self._height[-1]
        t = t - np.where(inside, (self.radius(t) - h) / self.slope(t), 0.0)
        return np.where(inside, t, self._grid[-1] + (h - self._height[-1]) / self._end_slope)

    def check_covers(self, theta_max: float, what: str, calibrated: bool = False) -> None:
        """Refuse a field of view beyond the curve's limit, or a curve beside an OpenCV
        calibration K, D (``calibrated``)."""
        if calibrated:
            raise ProjectionError(f"{what} has a lens curve or an OpenCV calibration K, D: "
                                  "not both")
        if theta_max > self.theta_limit + 1e-9:
            raise ProjectionError(
                f"{what}: the lens curve {self.name} is known up to "
                f"{math.degrees(self.theta_limit):g}° from the axis, the field of view asks "
                f"{math.degrees(theta_max):g}° (--fov at most {2 * math.degrees(self.theta_limit):g})")

    def describe(self) -> dict:
        return {"name": self.name, "coefficients": [float(v) for v in self.coefficients],
                "theta_limit_deg": math.degrees(self.theta_limit)}


def fit_table(theta_deg, height, degree: int = 13, name: str = "table") -> LensCurve:
    """The odd polynomial of ``degree`` through a table of half angles (degrees) and image
    heights (any unit), normalised to ``p(90°) = π/2`` (least squares)."""
    t = np.radians(np.asarray(theta_deg, np.float64))
    h = np.asarray(height, np.float64)
    h90 = float(np.interp(math.pi / 2, t, h))
    powers = np.stack([t ** (2 * k + 1) for k in range((degree + 1) // 2)], axis=1)
    coef, *_ = np.linalg.lstsq(powers, h / h90 * (math.pi / 2), rcond=None)
    t90 = (math.pi / 2) ** (2 * np.arange(coef.size) + 1)
    coef *= (math.pi / 2) / float(coef @ t90)       # exactly p(90°) = π/2
    return LensCurve(coef, float(t.max()), name)


_CURVES: dict = {}


def ricoh_curve(model: str) -> LensCurve:
    """Ricoh's design curve of ``model`` ("V", "Z1", "X"), fitted once."""
    if model not in _CURVES:
        table = RICOH_TABLES_MM[model]
        _CURVES[model] = fit_table(range(len(table)), table, name=f"ricoh-{model}")
    return _CURVES[model]


@dataclass(frozen=True)
class LensProfile:
    """A dual-fisheye camera: Ricoh's table (``model``, None: equidistant), the 90° ring
    radius (px) at each native frame size, where the circle centres are, which circle is the
    front (the stitched panorama's centre, −Z), and the field of view (degrees)."""

    name: str
    model: str | None
    rings: tuple          # ((width, height, ring90_px), …): the first one scales other sizes
    centres: str          # "live-s": (319.5, 319.5)·w/1280 each half; "halves": (w/4, h/2)
    front: str = "right"
    fov_deg: float = 200.0
    mode: str = ""
    fitted: LensCurve | None = None      # a per-unit curve (a lens file) instead of a table
    centre: tuple | None = None          # a per-unit centre (px at the first native size)

    def curve(self):
        if self.fitted is not None:
            return self.fitted
        return None if self.model is None else ricoh_curve(self.model)

    def geometry(self, width: int, height: int):
        """(centres (px), focal (px: 90° ring / p(90°)), the native size it is scaled from)
        for a frame of ``width``×``height``."""
        native = next(((w, h, r) for w, h, r in self.rings if (w, h) == (width, height)), None)
        if native is None and self.curve() is None:     # today's model: any size
            native = self.rings[0]
        if native is None:
            native = next(((w, h, r) for w, h, r in self.rings
                           if abs(w / h - width / height) <= 0.01 * w / h), None)
        if native is None:
            sizes = " or ".join(f"{a}×{b}" for a, b, _ in self.rings)
            raise ProjectionError(
                f"lens {self.name} is for {self.mode} frames of {sizes} (or that shape), not "
                f"{width}×{height}: check --lens, or give --lens equidistant")
        w, h, ring = native
        ring = ring * width / w
        if self.centres == "live-s":
            s = width / 1280
            cs = ((319.5 * s, 319.5 * s), (959.5 * s, 319.5 * s))
        else:
            cs = ((width / 4, height / 2), (3 * width / 4, height / 2))
        if self.centre is not None:     # the calibrated lens's centre, in its own half
            c = (self.centre[0] * width / w, self.centre[1] * width / w)
            cs = (c, cs[1]) if c[0] < width / 2 else (cs[0], c)
        curve = self.curve()
        return cs, ring / float(math.pi / 2 if curve is None else curve.radius(math.pi / 2)), (w, h)


def _ring(model: str, mm_per_px: float) -> float:
    return RICOH_TABLES_MM[model][90] / mm_per_px


#: 90° ring of the Theta S/SC live stream at 1280×720 (public calibrations: 287.0–289.7 px).
THETA_S_RING_1280 = 288.5
_S_RINGS = ((1280, 720, THETA_S_RING_1280), (1920, 1080, THETA_S_RING_1280 * 1.5))

#: Profiles by name (the ``lens`` option of ``projection="dual-fisheye"``).
PROFILES = {
    "equidistant": LensProfile("equidistant", None, ((1280, 720, 284.0),), "live-s",
                               mode="any (today's model, r = f·θ)"),
    "theta-s": LensProfile("theta-s", "V", _S_RINGS, "live-s", mode="USB live stream"),
    "theta-sc": LensProfile("theta-sc", "V", _S_RINGS, "live-s", mode="USB live stream"),
    "theta-sc2": LensProfile("theta-sc2", "V", _S_RINGS, "live-s", mode="dual-fisheye video"),
    "theta-v": LensProfile("theta-v", "V", ((5792, 2896, _ring("V", 0.00155)),
                                            (5376, 2688, _ring("V", 0.00155))), "halves",
                           mode="dual-fisheye still"),
    "theta-z1": LensProfile("theta-z1", "Z1", ((7296, 3648, _ring("Z1", 0.0024)),
                                               (6720, 3360, _ring("Z1", 0.0024))), "halves",
                            mode="dual-fisheye still"),
    "theta-x": LensProfile("theta-x", "X", ((11008, 5504, _ring("X", 0.0008)),
                                            (5504, 2752, _ring("X", 0.0016))), "halves",
                           mode="dual-fisheye still"),
}


def lens_profile(name) -> LensProfile:
    """The profile called ``name`` (ProjectionError naming the choices otherwise)."""
    if isinstance(name, LensProfile):
        return name
    try:
        return PROFILES[name]
    except (KeyError, TypeError):
        raise ProjectionError(f"unknown lens {name!r}; choose from {', '.join(PROFILES)} "
                              "(or a lens file from shlight calibrate-lens)") from None
