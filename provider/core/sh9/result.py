"""The lighting of one frame: what :class:`~.engine.SH9Projector` returns (no I/O)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..geometry import sh
from ..lights.analysis import model_irradiance


@dataclass
class SH9Result:
    """Lighting of one frame.

    Attributes
    ----------
    coefficients : (9, 3) float64
        Radiance SH coefficients L_lm per RGB channel, order L00, L1-1, L10, L11, L2-2,
        L2-1, L20, L21, L22, right-handed +Y-up frame.
    matrices : (3, 4, 4) float64
        Irradiance matrices M_r, M_g, M_b: E(n) = ñᵀ M ñ.
    stats : dict
        Per-frame statistics (see :meth:`SH9Projector.project`).
    lights : list of :class:`~provider.core.lights.analysis.Light`
        Directional lights (``lights="auto"``; empty otherwise): ``.direction`` unit vector
        toward the light (world frame), ``.irradiance`` RGB on a surface facing it.
    ambient_coefficients : (9, 3) float64 or None
        SH9 of everything the lights did not take (``lights="auto"``); None when lights are
        off. ``coefficients`` stay the full SH9 of everything (docs/contract.md §10).
    """

    coefficients: np.ndarray
    matrices: np.ndarray
    stats: dict = field(default_factory=dict)
    lights: list = field(default_factory=list)
    ambient_coefficients: np.ndarray | None = None

    def irradiance(self, normals):
        """E(n) (not clamped) at unit normals (..., 3) -> (..., 3)."""
        return sh.irradiance(self.coefficients, normals)

    @property
    def ambient(self) -> np.ndarray:
        """The ambient SH9 (9, 3): ``ambient_coefficients``, or the full SH9 without lights."""
        return self.coefficients if self.ambient_coefficients is None else self.ambient_coefficients

    @property
    def ambient_matrices(self) -> np.ndarray:
        """(3, 4, 4) irradiance matrices of :attr:`ambient`."""
        if self.ambient_coefficients is None:
            return self.matrices
        return sh.irradiance_matrices(self.ambient_coefficients)

    def irradiance_with_lights(self, normals):
        """E(n) = ñᵀAñ + Σ_k I_k max(0, n·d_k) (not clamped) at unit normals (..., 3)."""
        return model_irradiance(self.ambient, self.lights, normals)
