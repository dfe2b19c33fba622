"""Lights of one frame (docs/contract.md §10): the results and the per-frame evaluator of light sets.

Maths only (numpy; no I/O). :class:`~provider.core.lights.extractor.LightExtractor` builds an
:class:`Analysis` per frame: the candidate lights, the brute-force irradiance ("truth") at a
fixed set of normals, and Gram matrices that score *any* set of candidates in microseconds.
The per-frame greedy choice (:meth:`Analysis.greedy`) and the tracker with hysteresis
(:class:`~provider.core.lights.tracking.LightTracker`) both choose through it.

Conventions (docs/contract.md §1-2, §10): directions are unit vectors *toward* the light in the
right-handed +Y-up frame; a light's ``irradiance`` is the RGB irradiance on a surface facing
it (the units of E(n): radiance × sr); the model is
``E(n) = ñᵀAñ + Σ_k I_k · max(0, n·d_k)`` with the ambient A = full SH9 − Σ_k I_k Y(d_k)
(the SH9 projection of a directional light is I·Y(d)), so ambient + the lights' projection
is exactly the full SH9. Errors are fractions (0.01 = 1 %).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..geometry import sh
from ..radiometry.photometry import LUMINANCE_WEIGHTS

#: Rec. 709 luminance weights (linear RGB).
LUMA = LUMINANCE_WEIGHTS


# ---------------------------------------------------------------------------------------------
# Results
# ---------------------------------------------------------------------------------------------

@dataclass
class Light:
    """One directional light.

    direction : (3,) float64 unit vector toward the light, world frame (rh, +Y up).
    irradiance : (3,) float64 RGB irradiance on a surface facing the light (units of the
        frame's radiance × sr, like E(n)).
    flux : (3,) excess flux ∫ (L − tμ)⁺ dω of the source region (same units);
        ``irradiance <= flux`` (equal for a point source).
    spread_deg : flux-weighted RMS angular radius of the region, degrees.
    level : the detection threshold (× mean luminance) of the region it came from.
    key : identity across frames (set by :class:`LightTracker`; -1 without one).
    source : index of its candidate in the frame's :class:`Analysis` (used by ``refine``).
    angular_radius_deg : radius (degrees) of the uniform disc that stands for the source as
        a shadow caster (:func:`angular_radius_deg`): ``sqrt(2 · m2)`` where m2 is the
        excess-flux-weighted mean squared angle of its pixels about ``direction`` less the
        pixels' own footprint (a uniform disc of radius a has m2 = a²/2). 0 for a source
        smaller than its pixels can tell (a point light) and for lights from elsewhere
        that did not say (an old relay upstream).
    chain : how many lights its source became: 1, the whole source; m > 1, this light is
        one of m segments of an elongated source (:func:`split_chain`), which share its
        ``key``, ``source`` and ``level`` and whose fluxes add up to the source's.
    """

    direction: np.ndarray
    irradiance: np.ndarray
    flux: np.ndarray
    spread_deg: float
    level: float
    key: int = -1
    source: int = -1
    angular_radius_deg: float = 0.0
    chain: int = 1


@dataclass
class Segment:
    """One segment of an elongated candidate (:func:`split_chain`): what becomes one light.

    direction : (3,) unit vector, its pixels' excess-flux-weighted mean direction.
    irradiance : (3,) RGB ``Σ excess ω (d_i · direction)`` over its pixels (as a light's).
    flux : (3,) RGB ``Σ excess ω`` over its pixels.
    spread_deg, angular_radius_deg : as a :class:`Light`'s, from its own pixels.
    """

    direction: np.ndarray
    irradiance: np.ndarray
    flux: np.ndarray
    spread_deg: float
    angular_radius_deg: float


@dataclass
class Candidate:
    """A compact bright region of one frame (a possible light).

    direction : (3,) unit vector, world frame (excess-flux-weighted mean direction).
    flux : (3,) RGB excess flux Σ excess ω (radiance × sr).
    moment : (3,) RGB irradiance of a light in ``direction``: ``Σ excess ω (d_i · d)``.
    spread_deg, radius_deg : RMS / max angular radius of the region about ``direction``.
    angular_radius_deg : the radius of its shadow-casting disc (:func:`angular_radius_deg`).
    level : index into ``LightExtractor.thresholds``; group : its component id at that level.
    pixels : flat indices into the mid copy; excess : (n, 3) radiance taken from them;
    local : the same pixels as indices into the frame's list of pixels above the lowest level.
    gain : error reduction (fraction: 0.05 = 5 points) when it is the only light; set by
        :meth:`Analysis.rank`.
    most_segments : how many lights it may become (:func:`chain_count`): 1 for a round
        region; :meth:`segments` gives its chain of m ≤ ``most_segments``.
    position : (n,) for an elongated region (``most_segments`` > 1), each of its pixels'
        coordinate along its major axis (radians, :func:`elongation`), else None.
    """

    direction: np.ndarray
    flux: np.ndarray
    moment: np.ndarray
    spread_deg: float
    radius_deg: float
    level: int
    group: int
    pixels: np.ndarray
    excess: np.ndarray
    local: np.ndarray | None = None
    gain: float = 0.0
    angular_radius_deg: float = 0.0
    most_segments: int = 1
    position: np.ndarray | None = field(default=None, repr=False)
    _chains: dict = field(default_factory=dict, repr=False)

    def segments(self, count: int, extractor) -> list:
        """Its chain of ``count`` (2 ≤ count ≤ ``most_segments``) :class:`Segment` s, made
        once (:func:`split_chain`); ``extractor`` the
        :class:`~provider.core.lights.extractor.LightExtractor` that found it (its pixels'
        directions, solid angles and footprints)."""
        if count not in self._chains:
            pix = self.pixels
            self._chains[count] = split_chain(
                extractor._dirs[pix], self.excess, extractor._omega[pix],
                extractor._footprint2[pix], self.position, count)
        return self._chains[count]


@dataclass
class LightsResult:
    """Lights of one frame.

    lights : kept lights (see :class:`Light`), in a stable order (tracker key order).
    ambient : (9, 3) SH9 of everything the lights did not take: full − Σ_k I_k Y(d_k).
    light_error : relative RMS irradiance error (fraction) of ambient + lights against brute
        force on the coarse copy (with bright regions at mid resolution).
    sh9_error : the same for the full SH9 alone, on the same copy.
    candidates : every candidate of the frame with its solo gain (stats, debugging).
    """

    lights: list
    ambient: np.ndarray
    light_error: float
    sh9_error: float
    candidates: list = field(default_factory=list)

    def irradiance(self, normals: np.ndarray) -> np.ndarray:
        """E(n) of the ambient + lights model at unit normals (..., 3) -> (..., 3):
        ``ñᵀAñ + Σ_k I_k max(0, n·d_k)`` (not clamped)."""
        return model_irradiance(self.ambient, self.lights, normals)

    def transformed(self, scale: float = 1.0, rotation=None, sh_rotation=None,
                    colour=None) -> "LightsResult":
        """The same lights in other units and another frame, as the engine treats its
        coefficients: radiance × ``scale`` (exposure), then the sensor ``rotation`` (3×3,
        camera → world) with ``sh_rotation`` its 9×9 SH matrix (:func:`sh.sh_rotation`);
        ``colour``: a 3×3 colour matrix (camera RGB → Rec. 709) applied to every RGB."""
        R = None if rotation is None else np.asarray(rotation, np.float64)
        M = np.eye(3) if colour is None else np.asarray(colour, np.float64)
        lights = [replace(light, irradiance=M @ light.irradiance * scale,
                          flux=M @ light.flux * scale,
                          direction=light.direction if R is None else R @ light.direction)
                  for light in self.lights]
        ambient = self.ambient @ M.T * scale
        if sh_rotation is not None:
            ambient = sh_rotation @ ambient
        return replace(self, lights=lights, ambient=ambient)


def angular_radius_deg(weights, angles, footprint2) -> float:
    """Radius (degrees) of the uniform disc that casts the shadows of a source seen in pixels.

    ``weights`` (n,): each pixel's share of the source's flux (its excess luminance × solid
    angle); ``angles`` (n,): each pixel centre's angle from the source's direction, radians;
    ``footprint2`` (n,): each pixel's own mean squared angular offset about its centre,
    rad² (``(w² + h²)/12`` for a w × h pixel, w and h its sides as angles).

    A pixel records the source's light *at its centre*, which adds the footprint's second
    moment to every point of the source (on average over where the pixel grid falls), so
    ``m2 = Σ w (angle² − footprint²) / Σ w`` is the source's own flux-weighted mean squared
    angle; a uniform disc of radius a has m2 = a²/2, hence ``a = sqrt(2 · m2)``. A source
    within one pixel gives m2 ≤ 0: it is reported as 0 (a point light), the honest answer
    when its pixels cannot tell its size. The radius is at most 90° by definition (the
    wire's range): a disc wider than a hemisphere is no shadow caster (never reached by
    the extractor's compact regions; the nine panoramas give at most 27°).
    """
    w = np.asarray(weights, np.float64)
    m2w = float(w @ (np.asarray(angles, np.float64) ** 2 - np.asarray(footprint2, np.float64)))
    return _disc_radius_deg(m2w, float(w.sum()))


def _disc_radius_deg(m2w: float, total: float) -> float:
    """:func:`angular_radius_deg` from its sums: ``m2w`` = Σ w (angle² − footprint²) (rad²
    × flux), ``total`` = Σ w; 0 for no flux."""
    if not total > 0:
        return 0.0
    return min(90.0, math.degrees(math.sqrt(2.0 * max(m2w / total, 0.0))))


def measure(directions, excess, omega, footprint2, part=None, count: int = 1):
    """Measure pixels as lights: one :class:`Segment` per part (a candidate's region, or
    each segment of a chain), as the extractor measures a light.

    ``directions`` (n, 3) pixel centres, ``excess`` (n, 3) RGB excess radiance, ``omega``
    (n,) solid angles (sr), ``footprint2`` (n,) rad²; ``part`` (n,) each pixel's part in
    [0, ``count``) (None: all in one). Per part: direction = its excess-luminance-flux
    centroid d; irradiance = ``max(0, Σ excess ω (d_i · d))`` (a light's first moment);
    flux = ``Σ excess ω``; spread_deg = the flux-weighted RMS angle about d;
    angular_radius_deg as :func:`angular_radius_deg`.

    Returns ``(segments, angles)``: the segments of the parts that hold flux, in part
    order, and (n,) each pixel's angle (radians) from its part's direction.
    """
    dirs = np.asarray(directions, np.float64)
    ex, om = np.asarray(excess, np.float64), np.asarray(omega, np.float64)
    w = (ex @ LUMA) * om                                              # excess luminance flux
    if part is None:           # one part (every candidate, every frame): plain sums
        v = w @ dirs
        d = (v / max(float(np.linalg.norm(v)), 1e-300))[None]
        cos = np.clip(dirs @ d[0], -1.0, 1.0)
        ang = np.arccos(cos)
        ang2 = ang * ang
        exom = ex * om[:, None]
        wa = w * ang2
        total = np.array([w.sum()])
        sums = np.concatenate([cos @ exom, exom.sum(axis=0),
                               [wa.sum(), wa.sum() - w @ np.asarray(footprint2, np.float64)]])
        return _segments(d, total, sums[None]), ang
    # Per-part sums as products with the (count, n) membership matrix (a few parts).
    P = (np.ones((1, len(w))) if part is None
         else (np.arange(count)[:, None] == np.asarray(part)[None, :]).astype(np.float64))
    part = np.zeros(len(w), np.intp) if part is None else np.asarray(part)
    first = P @ np.column_stack([w, w[:, None] * dirs])               # (count, 4)
    total, v = first[:, 0], first[:, 1:]
    d = v / np.maximum(np.linalg.norm(v, axis=1, keepdims=True), 1e-300)
    cos = np.clip(np.einsum("ij,ij->i", dirs, np.take(d, part, axis=0)), -1.0, 1.0)
    ang = np.arccos(cos)
    ang2 = ang * ang
    exom = ex * om[:, None]
    sums = P @ np.column_stack([exom * cos[:, None], exom, w * ang2,
                                w * (ang2 - np.asarray(footprint2, np.float64))])  # (count, 8)
    return _segments(d, total, sums), ang


def _segments(d, total, sums) -> list:
    """:func:`measure`'s segments from each part's direction, flux and sums (count, 8)."""
    return [Segment(d[s], np.maximum(sums[s, 0:3], 0.0), sums[s, 3:6],
                    math.degrees(math.sqrt(sums[s, 6] / total[s])),
                    _disc_radius_deg(sums[s, 7], total[s]))
            for s in range(len(total)) if total[s] > 0]


#: A region whose flux-weighted RMS extent along its major axis is at least this many times
#: its extent across (both in the tangent plane at its direction, pixels' footprint
#: included) is split into a chain of discs (docs/shadows.md, "Elongated lights").
ELONGATION = 4.0
#: Each segment of a chain spans at least this many detection pixels along the major axis.
MIN_SEGMENT_PIXELS = 2.0


def elongation(directions, weights, direction) -> tuple[float, float, np.ndarray]:
    """How elongated a region is, from its flux-weighted second moments about its direction.

    ``directions`` (n, 3) its pixel centres, ``weights`` (n,) their excess luminance flux,
    ``direction`` (3,) its flux-weighted mean direction. The pixels are projected on the
    plane tangent at ``direction`` (orthographically: exact for the few tens of degrees a
    region spans) and their weighted 2 × 2 covariance is diagonalised.

    Returns ``(ratio, major_rad, position)``: ``ratio`` = RMS extent along the major axis /
    across it (1 for a disc; L/W for a uniform L × W strip; ``inf`` for a line one pixel
    centre wide), ``major_rad`` the RMS extent along it (L/√12 for a uniform strip of length
    L, radians) and ``position`` (n,) each pixel's coordinate along it (radians, mean 0),
    increasing toward increasing azimuth (counter-clockwise about +Y seen from above), or
    upward for an axis more than 60° from east-west: segments keep their order across
    frames.
    """
    d = np.asarray(direction, np.float64)
    dirs, w = np.asarray(directions, np.float64), np.asarray(weights, np.float64)
    e1 = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 -= (e1 @ d) * d
    e1 /= math.sqrt(float(e1 @ e1))
    e2 = np.array([d[1] * e1[2] - d[2] * e1[1], d[2] * e1[0] - d[0] * e1[2],
                   d[0] * e1[1] - d[1] * e1[0]])                        # d × e1
    xy = dirs @ np.stack([e1, e2], 1)
    total = float(w.sum())
    if not total > 0 or len(w) < 2:
        return 1.0, 0.0, np.zeros(len(w))
    xy -= (w @ xy) / total
    (a, b), (_, c) = (xy * w[:, None]).T @ xy / total
    # the 2 × 2 covariance's eigenvalues and major axis in closed form (a region's few
    # pixels: numpy's eigh would cost more than the moments)
    half, mean = math.hypot(0.5 * (a - c), b), 0.5 * (a + c)
    major, minor = mean + half, max(mean - half, 0.0)
    theta = 0.5 * math.atan2(2 * b, a - c)
    axis = math.cos(theta) * e1 + math.sin(theta) * e2                  # world frame
    # A fixed sense along the axis, so that a chain's segments keep their order (their wire
    # slots) from frame to frame: toward increasing azimuth (Y × d, counter-clockwise seen
    # from above), or upward for an axis more than 60° from east-west.
    east = np.array([d[2], 0.0, -d[0]])
    east_norm = math.hypot(d[0], d[2])
    along_east = float(axis @ east) / east_norm if east_norm > 1e-9 else float(axis[0])
    sense = (1.0 if along_east > 0 else -1.0) if abs(along_east) >= 0.5 else \
        (1.0 if axis[1] >= 0 else -1.0)
    ratio = math.sqrt(major / minor) if minor > 0 else (math.inf if major > 0 else 1.0)
    return ratio, math.sqrt(major), xy @ (sense * np.array([math.cos(theta), math.sin(theta)]))


def chain_count(ratio: float, major_rad: float, pixel_rad: float, most: int) -> int:
    """How many lights (segments) a region of this :func:`elongation` becomes: 1 (kept
    whole) unless ``ratio`` ≥ :data:`ELONGATION`; else about its length over its width
    (``round(ratio)``), at most ``most`` (the lights the frame may hold) and at most as many
    segments as its length L = √12 · ``major_rad`` holds :data:`MIN_SEGMENT_PIXELS` pixels
    of ``pixel_rad`` (a segment shorter than that is a round blob of pixels)."""
    if not ratio >= ELONGATION or most < 2 or not pixel_rad > 0:
        return 1
    fits = math.floor(math.sqrt(12.0) * major_rad / (MIN_SEGMENT_PIXELS * pixel_rad))
    return int(max(1, min(most, round(min(ratio, 1e6)), fits)))


def split_chain(directions, excess, omega, footprint2, position, count: int) -> list:
    """An elongated region as ``count`` :class:`Segment` s of equal luminance flux along its
    major axis (``position``, from :func:`elongation`): a chain of discs.

    ``directions`` (n, 3), ``excess`` (n, 3) RGB excess radiance, ``omega`` (n,) solid
    angles (sr), ``footprint2`` (n,) rad² of the region's pixels. Each pixel goes to the
    segment holding the middle of its flux in the running sum along the axis, so the
    segments partition the pixels (fluxes add up to the region's exactly). Each segment
    is measured as a light is (:func:`measure`): direction = its flux centroid, irradiance
    = ``Σ excess ω (d_i · d)`` (the irradiance of every normal that sees the whole segment,
    hence at least the whole region's about its single centroid), radius from its own
    pixels.
    """
    ex, om = np.asarray(excess, np.float64), np.asarray(omega, np.float64)
    w = (ex @ LUMA) * om
    order = np.argsort(position, kind="stable")
    run = np.cumsum(w[order]) - 0.5 * w[order]
    part = np.empty(len(w), np.intp)
    part[order] = np.minimum((run * count / max(float(w.sum()), 1e-300)).astype(np.intp),
                             count - 1)
    return measure(directions, ex, om, footprint2, part, count)[0]


def model_irradiance(ambient, lights, normals) -> np.ndarray:
    """``ñᵀAñ + Σ_k I_k max(0, n·d_k)`` at unit normals (..., 3) -> (..., 3), not clamped.

    ``ambient`` (9, 3) radiance SH; ``lights`` a list of :class:`Light` (or of objects with
    ``direction`` and ``irradiance``).
    """
    n = np.asarray(normals, np.float64)
    E = sh.irradiance(ambient, n)
    for light in lights:
        E = E + np.maximum(n @ np.asarray(light.direction, np.float64), 0.0)[..., None] \
            * np.asarray(light.irradiance, np.float64)
    return E


# ---------------------------------------------------------------------------------------------
# Per-frame analysis: candidates, truth, and a cheap evaluator of any set of lights
# ---------------------------------------------------------------------------------------------

class Analysis:
    """What one frame offers: candidates, the brute-force truth and the SH9-only error.

    :meth:`evaluate` scores any set of candidates in microseconds (Gram matrices of the
    lights' residual shapes are precomputed), so a tracker can ask for the error of the set
    it prefers, not only of the greedy one. Two candidates *conflict* when one region
    contains the other (one source found at two threshold levels): a valid set never holds
    both (its error is ``inf``).

    ``extractor`` is the :class:`~provider.core.lights.extractor.LightExtractor` that found them.
    Attributes: ``coefficients`` (9, 3) full SH9; ``candidates``; ``truth`` (N, 3) brute-force
    irradiance at ``extractor.normals``; ``sh9_error`` (fraction).
    """

    def __init__(self, extractor, coefficients, candidates, truth,
                 groups, mu=0.0):
        self.x = extractor
        self.mu = float(mu)             # mean luminance of the frame (radiance units)
        self.coefficients = np.asarray(coefficients, np.float64)
        self.candidates = candidates
        self.truth = truth
        self.E_sh = extractor._irr_basis @ self.coefficients            # (N, 3)
        R = truth - self.E_sh
        self._TT = float(np.sum(truth * truth)) or 1.0
        self._RR = np.sum(R * R, axis=0)                                 # (3,)
        self.sh9_error = math.sqrt(max(float(self._RR.sum()), 0.0) / self._TT)
        nc = len(candidates)
        # Each candidate's irradiance M and residual shape G: a chain (the most segments it
        # may become) is Σ_s I_s g(d_s) = M · Σ_s (Y(I_s)/Y(M)) g(d_s), exact for segments of
        # one colour (the frame's result measures the lights it serves exactly).
        self._M = np.zeros((nc, 3))
        cols = []
        for j, c in enumerate(candidates):
            segs = c.segments(c.most_segments, extractor) if c.most_segments > 1 else None
            self._M[j] = c.moment if segs is None else np.sum([g.irradiance for g in segs], 0)
            y = float(self._M[j] @ LUMA)
            if segs is None or not y > 0:
                cols.append(extractor._residual(c.direction))
            else:
                share = np.array([g.irradiance @ LUMA for g in segs]) / y
                D = np.array([g.direction for g in segs])                 # (m, 3)
                cols.append(extractor._residual(D) @ share)               # Σ_s share_s g(d_s)
        if nc:
            G = np.stack(cols, axis=1)
            self._G = G                                                  # (N, nc)
            self._GtG = G.T @ G
            self._GtR = G.T @ R                                          # (nc, 3)
        # Nested candidates conflict: b (higher level) lies in a's group at a's level.
        self.conflict = np.zeros((nc, nc), bool)
        where = {(c.level, c.group): i for i, c in enumerate(candidates)}
        for j, b in enumerate(candidates):
            for lv in range(b.level):
                i = where.get((lv, int(groups[lv][b.local[0]])))
                if i is not None:
                    self.conflict[i, j] = self.conflict[j, i] = True
        if nc:
            # err²(S) = RR + Σ_{j∈S} a_j + Σ_{j≠k∈S} Q_jk  (vectorised greedy steps)
            M = self._M                                                  # (nc, 3)
            self._Q = self._GtG * (M @ M.T)
            self._a = -2 * np.sum(M * self._GtR, axis=1) + np.diag(self._Q)
        self._cache: dict = {}

    def valid(self, indices) -> bool:
        idx = list(indices)
        return not self.conflict[np.ix_(idx, idx)].any() if len(idx) > 1 else True

    def irradiances(self, indices) -> np.ndarray:
        """(k, 3) RGB irradiance of each light of the set: each candidate's first moment
        ``Σ excess ω (d_i·d)`` (physical, no fit; within 0.1 points of a least-squares fit
        on the real panoramas, measured when this module was designed); for a chain the
        sum of its segments' own."""
        idx = list(indices)
        return self._M[idx].reshape(len(idx), 3)

    def _error(self, idx, I) -> float:
        A = self._GtG[np.ix_(idx, idx)]
        B = self._GtR[idx]
        err2 = float(self._RR.sum() - 2 * np.sum(I * B) + np.einsum("jc,jk,kc->", I, A, I))
        return math.sqrt(max(err2, 0.0) / self._TT)

    def evaluate(self, indices) -> float:
        """Relative RMS error (fraction) of ambient + these candidates as lights against the
        truth; ``inf`` for a set holding two nested candidates."""
        key = tuple(sorted(int(i) for i in indices))
        if key not in self._cache:
            if not key:
                self._cache[key] = self.sh9_error
            elif not self.valid(key):
                self._cache[key] = math.inf
            else:
                self._cache[key] = self._error(list(key), self.irradiances(key))
        return self._cache[key]

    def error_of(self, model: np.ndarray) -> float:
        """Relative RMS error (fraction) of any irradiance (N, 3) at the extractor's normals
        against this frame's truth (e.g. a model whose ambient was windowed or truncated)."""
        d = np.asarray(model, np.float64) - self.truth
        return math.sqrt(float(np.sum(d * d)) / self._TT)

    def model(self, indices) -> np.ndarray:
        """Model irradiance (N, 3) at the extractor's normals for these candidates."""
        idx = list(indices)
        if not idx:
            return self.E_sh.copy()
        return self.E_sh + self._G[:, idx] @ self.irradiances(idx)

    def errors_adding(self, indices) -> np.ndarray:
        """(nc,) error of the set plus each candidate (inf where invalid or already in)."""
        idx = [int(i) for i in indices]
        nc = len(self.candidates)
        if not nc:
            return np.zeros(0)
        Qs = self._Q[np.ix_(idx, idx)]
        err2 = (self._RR.sum() + self._a[idx].sum() + Qs.sum() - np.trace(Qs)
                + self._a + 2 * self._Q[:, idx].sum(axis=1))
        out = np.sqrt(np.maximum(err2, 0.0) / self._TT)
        if idx:
            out[idx] = math.inf
            out[self.conflict[idx].any(axis=0)] = math.inf
        return out

    def rank(self) -> None:
        """Set each candidate's solo gain (SH9 error − error with it as the only light)."""
        if self.candidates:
            gains = self.sh9_error - self.errors_adding([])
            for c, g in zip(self.candidates, gains):
                c.gain = float(g)

    def accepts(self, before: float, after: float) -> bool:
        """The acceptance test of a light: error lowered by min_gain and min_rel_gain."""
        return before - after >= max(self.x.min_gain, self.x.min_rel_gain * before)

    def greedy(self, max_lights: int | None = None, start=()) -> list:
        """Indices chosen greedily by measured error, starting from ``start``."""
        k = self.x.max_lights if max_lights is None else max_lights
        chosen = [int(i) for i in start]
        err = self.evaluate(chosen)
        while len(chosen) < k and self.candidates:
            errs = self.errors_adding(chosen)
            best = int(np.argmin(errs))
            if not self.accepts(err, float(errs[best])):
                break
            chosen.append(best)
            err = float(errs[best])
        return chosen

    def chain_counts(self, indices, max_lights: int | None = None) -> list:
        """How many lights each candidate of the set becomes: 1, or for an elongated one
        (``most_segments`` > 1) as many segments as it may be while the set holds at most
        ``max_lights`` lights (default the extractor's); the lights left free go to the
        chains in order of flux, largest first."""
        idx = [int(i) for i in indices]
        free = (self.x.max_lights if max_lights is None else max_lights) - len(idx)
        counts = [1] * len(idx)
        for j in sorted(range(len(idx)), key=lambda j: -float(self.candidates[idx[j]].flux @ LUMA)):
            counts[j] = min(self.candidates[idx[j]].most_segments, 1 + max(free, 0))
            free -= counts[j] - 1
        return counts

    def result(self, indices, keys=None, max_lights: int | None = None) -> LightsResult:
        """The :class:`LightsResult` for these candidates (in this order); an elongated one
        becomes its chain of segments (:meth:`chain_counts`), one light each, in place."""
        idx = [int(i) for i in indices]
        lights = []
        ambient = self.coefficients.copy()
        for j, (i, m) in enumerate(zip(idx, self.chain_counts(idx, max_lights))):
            c = self.candidates[i]
            key, level = -1 if keys is None else keys[j], self.x.thresholds[c.level]
            parts = ([Segment(c.direction, c.moment, c.flux, c.spread_deg,
                              c.angular_radius_deg)] if m == 1 else c.segments(m, self.x))
            for g in parts:
                ambient -= sh.sh_basis(g.direction)[:, None] * g.irradiance[None, :]
                lights.append(Light(g.direction.copy(), g.irradiance.copy(), g.flux.copy(),
                                    g.spread_deg, level, key, i, g.angular_radius_deg, m))
        return LightsResult(lights, ambient, self.error_of(self.served_model(lights)),
                            self.sh9_error, self.candidates)

    def served_model(self, lights) -> np.ndarray:
        """Model irradiance (N, 3) at the extractor's normals of the lights a frame serves
        (any :class:`Light` s from :meth:`result`, possibly refined): the precomputed
        :meth:`model` of their candidates when none is elongated, else :meth:`lights_model`
        of the lights themselves: an elongated candidate's precomputed shape is its chain of
        the most segments in one colour, not what was served (fewer segments, or the whole
        region when no light was left free)."""
        if all(light.source >= 0 and self.candidates[light.source].most_segments == 1
               for light in lights):
            return self.model([light.source for light in lights])
        return self.lights_model(lights)

    def lights_model(self, lights) -> np.ndarray:
        """Model irradiance (N, 3) at the extractor's normals of the full SH9 with these
        lights taken out of it as directional lights (any :class:`Light` s)."""
        if not lights:
            return self.E_sh.copy()
        D = np.array([light.direction for light in lights], np.float64)          # (k, 3)
        I = np.array([light.irradiance for light in lights], np.float64)         # (k, 3)
        return self.E_sh + self.x._residual(D) @ I

