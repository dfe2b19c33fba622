"""The shadow a receiver sees (docs/contract.md §10): the ratio a shadow catcher multiplies
the camera image by.

Maths only (numpy). With the ambient A (``ambient_matrices``) and the lights (direction d_k
toward light k, irradiance I_k on a surface facing it) of a wire message, a receiver of
unit normal n whose view of light k is a fraction V_k (0: fully shadowed, 1: in the open;
what an engine's shadow map gives, the fraction of the light's disc that is unoccluded for
a soft shadow) receives

    E_lit(n, V) = E_a(n) + Σ_k V_k I_k max(0, n·d_k),   E_a(n) = max(0, ñᵀAñ) per colour

instead of E_lit(n, 1). The real floor's radiance scales by the same factor, so a shadow
catcher multiplies the camera image by

    ratio(n, V) = E_lit(n, V) / E_lit(n, 1)     (per colour; 1 where E_lit(n, 1) ≤ 0).

The ambient is clamped at 0 as the shaders clamp E (order-2 SH can ring below 0 under a
small bright source; negative light is no light), so ratio ∈ [0, 1] for every V in [0, 1]
and is 1 where the receiver gets no light at all (nothing to darken). The ambient is taken
as unoccluded: the occluder's own blocking of the sky is not in this ratio (docs/shadows.md
measures what that leaves out). Shipped as ``shShadowRatio(vec3 n, vec4 visibility)``
(shaders/sh9_lights.glsl) and ``SHShadowRatio(float3 n, float4 visibility)``
(shaders/sh9_lights.hlsl) for lights 0..3 (SH_MAX_LIGHTS = 4); `shlight validate-shaders`
checks both against :func:`shadow_ratio`.
"""
from __future__ import annotations

import numpy as np

from ..geometry import sh

__all__ = ["shadow_ratio", "lit_irradiance"]


def lit_irradiance(normals, ambient_matrices, light_directions, light_irradiance,
                   visibility) -> np.ndarray:
    """E_lit(n, V) = max(0, ñᵀAñ) + Σ_k V_k I_k max(0, n·d_k), (..., 3), float64.

    normals (..., 3) unit; ambient_matrices (3, 4, 4); light_directions (k, 3) unit, toward
    each light; light_irradiance (k, 3) RGB; visibility (..., k) or (k,), each in [0, 1]
    (ValueError otherwise: a visibility is a fraction of the light that arrives).
    """
    n = np.asarray(normals, np.float64)
    d = np.asarray(light_directions, np.float64).reshape(-1, 3)
    irr = np.asarray(light_irradiance, np.float64).reshape(-1, 3)
    if len(irr) != len(d):
        raise ValueError(f"{len(d)} light directions but {len(irr)} irradiances")
    v = np.broadcast_to(np.asarray(visibility, np.float64), n.shape[:-1] + (len(d),))
    if not (np.all(np.isfinite(v)) and np.all((v >= 0) & (v <= 1))):
        raise ValueError("a light's visibility is a fraction in [0, 1]")
    ambient = np.maximum(sh.irradiance_from_matrices(np.asarray(ambient_matrices, np.float64), n),
                         0.0)
    cos = np.maximum(n @ d.T, 0.0)                                    # (..., k)
    return ambient + (cos * v) @ irr


def shadow_ratio(normals, ambient_matrices, light_directions, light_irradiance,
                 visibility) -> np.ndarray:
    """ratio(n, V) = E_lit(n, V) / E_lit(n, 1) per colour, (..., 3) float64 in [0, 1]; 1 where
    E_lit(n, 1) ≤ 0 (no light to block). Arguments as :func:`lit_irradiance`."""
    num = lit_irradiance(normals, ambient_matrices, light_directions, light_irradiance,
                         visibility)
    den = lit_irradiance(normals, ambient_matrices, light_directions, light_irradiance,
                         np.ones(len(np.asarray(light_directions).reshape(-1, 3))))
    safe = np.where(den > 0, den, 1.0)
    return np.where(den > 0, num / safe, 1.0)
