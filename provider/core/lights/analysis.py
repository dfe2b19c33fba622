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
    """

    direction: np.ndarray
    irradiance: np.ndarray
    flux: np.ndarray
    spread_deg: float
    level: float
    key: int = -1
    source: int = -1
    angular_radius_deg: float = 0.0


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

    def transformed(self, scale: float = 1.0, rotation=None, sh_rotation=None) -> "LightsResult":
        """The same lights in other units and another frame, as the engine treats its
        coefficients: radiance × ``scale`` (exposure), then the sensor ``rotation`` (3×3,
        camera → world) with ``sh_rotation`` its 9×9 SH matrix (:func:`sh.sh_rotation`)."""
        R = None if rotation is None else np.asarray(rotation, np.float64)
        lights = [replace(light, irradiance=light.irradiance * scale, flux=light.flux * scale,
                          direction=light.direction if R is None else R @ light.direction)
                  for light in self.lights]
        ambient = self.ambient * scale
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
    total = float(w.sum())
    if not total > 0:
        return 0.0
    m2 = float(w @ (np.asarray(angles, np.float64) ** 2 - np.asarray(footprint2, np.float64)))
    return min(90.0, math.degrees(math.sqrt(2.0 * max(m2 / total, 0.0))))


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
        if nc:
            G = np.stack([extractor._residual(c.direction) for c in candidates], axis=1)
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
            M = np.array([c.moment for c in candidates])                 # (nc, 3)
            self._Q = self._GtG * (M @ M.T)
            self._a = -2 * np.sum(M * self._GtR, axis=1) + np.diag(self._Q)
        self._cache: dict = {}

    def valid(self, indices) -> bool:
        idx = list(indices)
        return not self.conflict[np.ix_(idx, idx)].any() if len(idx) > 1 else True

    def irradiances(self, indices) -> np.ndarray:
        """(k, 3) RGB irradiance of each light of the set: each candidate's first moment
        ``Σ excess ω (d_i·d)`` (physical, no fit; within 0.1 points of a least-squares fit
        on the real panoramas, measured when this module was designed)."""
        idx = list(indices)
        return np.array([self.candidates[i].moment for i in idx]).reshape(len(idx), 3)

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

    def result(self, indices, keys=None) -> LightsResult:
        """The :class:`LightsResult` for these candidates (in this order)."""
        idx = [int(i) for i in indices]
        I = self.irradiances(idx)
        lights = []
        ambient = self.coefficients.copy()
        for j, i in enumerate(idx):
            c = self.candidates[i]
            ambient -= sh.sh_basis(c.direction)[:, None] * I[j][None, :]
            lights.append(Light(c.direction.copy(), I[j].copy(), c.flux.copy(), c.spread_deg,
                                self.x.thresholds[c.level], -1 if keys is None else keys[j],
                                i, c.angular_radius_deg))
        return LightsResult(lights, ambient, self.evaluate(idx), self.sh9_error,
                            self.candidates)

