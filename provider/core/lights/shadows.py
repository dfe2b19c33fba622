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
and is 1 where the receiver gets no light at all (nothing to darken). Shipped as
``shShadowRatio(vec3 n, vec4 visibility)`` (shaders/sh9_lights.glsl) and
``SHShadowRatio(float3 n, float4 visibility)`` (shaders/sh9_lights.hlsl) for lights 0..3
(SH_MAX_LIGHTS = 4); `shlight validate-shaders` checks both against :func:`shadow_ratio`.

**The occluder's ambient occlusion.** The occluder (the hologram's bounding sphere, centre c
and radius R in the receiver's frame) also hides a cap of the ambient: seen from a receiver
at p it is the cap of half-angle α about d = (c − p)/|c − p|, sin α = R/|c − p|. The ambient
irradiance it hides is

    O(n) = L_a(d) · P(n·d, sin α),     L_a(d) = max(0, (4 dᵀBd + 3 m·d + M₃₃ − tr B) / π)

with P the cap's projected solid angle ∫_cap max(0, n·ω) dω: π sin²α (n·d) while the cap lies
wholly above the receiver's horizon (n·d ≥ sin α), 0 once it lies wholly below
(n·d ≤ −sin α), and the exact formula for a sphere cut by the horizon in between (Snyder
1996, as in Lagarde & de Rousiers, "Moving Frostbite to PBR", 2014). L_a(d) is the SH9
ambient's own radiance toward the occluder, recovered exactly from the irradiance matrix
A = [[B, m], [mᵀ, M₃₃]]: E = ñᵀAñ splits into bands 0, 1, 2 as (M₃₃ + tr B/3) + 2 m·n +
(nᵀBn − tr B/3), and radiance is each band over its Â_l (π, 2π/3, π/4). Chosen over
E_a(d)/π (the cosine-weighted mean around d, smoother) by the bench's numbers
(docs/shadows.md): no new uniforms are needed for either. With it

    ratio(n, V, O) = (max(0, E_a(n) − O(n)) + Σ_k V_k I_k max(0, n·d_k)) / E_lit(n, 1)

(:func:`shadow_ratio` with ``occluded_ambient``), still in [0, 1]; the lights' own occlusion
stays in V_k (the ambient holds only what the lights did not take). Shipped as
``shOccludedAmbient`` / ``shShadowRatioOccluded`` (GLSL) and ``SHOccludedAmbient`` /
``SHShadowRatioOccluded`` (HLSL).

**Each light's visibility past the occluder.** Light k is a uniform disc, the cap of angular
radius a about d_k; the sphere, seen from p, the cap of half-angle α about d. The fraction of
the light's disc that reaches p is

    V_k = 1 − Ω(cap_a ∩ cap_α) / Ω(cap_a),     Ω(cap_x) = 4π sin²(x/2),

with the exact solid angle of two intersecting caps whose axes are γ apart (Mazonka 2012,
"Solid angle of conical surfaces, polyhedral cones, and intersecting spherical caps"): the
great circle through the two points where the caps' rims cross cuts the lens into one segment
of each cap, and a segment of a cap of radius x whose chord subtends 2φ at its axis is the
sector 2φ·2 sin²(x/2) less the isosceles spherical triangle (axis, chord), of area
2 atan(t² sin 2φ / (1 + t² cos 2φ)), t = tan(x/2) (negative for 2φ > π: then the segment holds
the axis). cos φ comes from the triangle (axis_a, axis_α, a crossing point) written with
half-angle sines, 1 + 2 sin((γ − a + α)/2) sin((γ − a − α)/2) / (sin a sin γ), so that a
sun's 0.27° disc keeps its digits in float32. Limits: disjoint caps (γ ≥ a + α) V = 1; the
light's disc inside the sphere's (γ ≤ α − a) V = 0; the sphere inside the disc
(γ ≤ a − α) V = 1 − sin²(α/2)/sin²(a/2); a point light (a = 0) V = 0 for γ < α, else 1. A
receiver inside the sphere (|c − p| ≤ R) sees nothing of any light: V = 0, by definition.
Shipped as ``shSphereLightVisibility`` / ``SHSphereLightVisibility`` (one light) and
``shSphereLightsVisibility`` / ``SHSphereLightsVisibility`` (lights 0..3 of the uniforms).
"""
from __future__ import annotations

import numpy as np

from ..geometry import sh

__all__ = ["shadow_ratio", "lit_irradiance", "occluded_ambient", "ambient_radiance",
           "cap_projected_solid_angle", "sphere_occluder", "sphere_light_visibility",
           "cap_overlap_fraction"]


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
                 visibility, occluded_ambient=None) -> np.ndarray:
    """ratio(n, V) = E_lit(n, V) / E_lit(n, 1) per colour, (..., 3) float64 in [0, 1]; 1 where
    E_lit(n, 1) ≤ 0 (no light to block). Arguments as :func:`lit_irradiance`;
    ``occluded_ambient`` (..., 3) or (3,), ≥ 0 (:func:`occluded_ambient`): the ambient
    irradiance the occluder hides, taken off the ambient (never below 0) in the numerator;
    None: the ambient is unoccluded (as before)."""
    num = lit_irradiance(normals, ambient_matrices, light_directions, light_irradiance,
                         visibility)
    if occluded_ambient is not None:
        o = np.asarray(occluded_ambient, np.float64)
        if not (np.all(np.isfinite(o)) and np.all(o >= 0)):
            raise ValueError("the occluded ambient is an irradiance: finite and >= 0")
        ambient = np.maximum(sh.irradiance_from_matrices(
            np.asarray(ambient_matrices, np.float64), np.asarray(normals, np.float64)), 0.0)
        num = num - np.minimum(o, ambient)
    den = lit_irradiance(normals, ambient_matrices, light_directions, light_irradiance,
                         np.ones(len(np.asarray(light_directions).reshape(-1, 3))))
    safe = np.where(den > 0, den, 1.0)
    return np.where(den > 0, num / safe, 1.0)


def ambient_radiance(ambient_matrices, directions) -> np.ndarray:
    """The SH9 ambient's radiance toward ``directions`` (..., 3) unit, (..., 3) float64, from
    its irradiance matrices alone (module docstring): (4 dᵀBd + 3 m·d + M₃₃ − tr B) / π, not
    clamped (order-2 SH can ring below 0). Equals Σ L_lm Y_lm(d) of the coefficients the
    matrices were built from."""
    A = np.asarray(ambient_matrices, np.float64).reshape(-1, 4, 4)
    d = np.asarray(directions, np.float64)
    B, m = A[:, :3, :3], A[:, :3, 3]
    quad = np.einsum("...i,cij,...j->...c", d, B, d)
    return (4 * quad + 3 * d @ m.T + A[:, 3, 3] - np.trace(B, axis1=1, axis2=2)) / np.pi


def cap_projected_solid_angle(cos_to_cap, sin_half_angle) -> np.ndarray:
    """∫ over a cap of half-angle α of max(0, n·ω) dω, for the cap's axis at cos θ = n·d from
    the normal: π sin²α cos θ above the horizon (cos θ ≥ sin α), 0 below (cos θ ≤ −sin α),
    and the exact horizon-cut value between (Snyder 1996). sin α ≥ 1 (the receiver inside the
    occluder) is a hemisphere about d: π (1 + cos θ) / 2."""
    h = np.clip(np.asarray(cos_to_cap, np.float64), -1.0, 1.0)
    s = np.clip(np.asarray(sin_half_angle, np.float64), 0.0, 1.0)
    s2 = s * s
    above = np.pi * s2 * np.maximum(h, 0.0)
    sin_t = np.sqrt(np.maximum(1.0 - h * h, 0.0))
    x = np.sqrt(np.maximum(1.0 - s2, 0.0)) / np.maximum(s, 1e-30)   # cot α
    y = np.clip(-x * h / np.maximum(sin_t, 1e-30), -1.0, 1.0)
    # sin θ·√(1 − y²) = √((s − h)(s + h)) / s: no 1 − y² near y = ±1 (float32 shaders)
    sy = np.sqrt(np.maximum((s - h) * (s + h), 0.0)) / np.maximum(s, 1e-30)
    cut = (h * np.arccos(y) - x * sy) * s2 + np.arctan2(sy, x)
    return np.where(h * h >= s2, above, np.maximum(cut, 0.0))


def occluded_ambient(normals, ambient_matrices, to_occluder, sin_half_angle) -> np.ndarray:
    """O(n) = max(0, L_a(d)) · P(n·d, sin α): the ambient irradiance a sphere hides from a
    receiver of unit normal ``normals`` (..., 3), (..., 3) float64 ≥ 0 (module docstring).

    ``to_occluder`` (..., 3) or (3,): unit d = (c − p)/|c − p| toward the sphere's centre;
    ``sin_half_angle`` (...,) or scalar: sin α = R/|c − p|, in [0, 1] (≥ 1 means the receiver
    is inside the sphere and is taken as 1; negative or NaN: ValueError). Frame: that of the
    normals and the matrices (the wire's, rh-y-up, unless the client re-oriented both).
    """
    n = np.asarray(normals, np.float64)
    d = np.broadcast_to(np.asarray(to_occluder, np.float64), n.shape)
    s = np.asarray(sin_half_angle, np.float64)
    if np.any(np.isnan(s)) or np.any(s < 0):
        raise ValueError("sin_half_angle = R/|c - p| is a number >= 0")
    radiance = np.maximum(ambient_radiance(ambient_matrices, d), 0.0)
    cap = cap_projected_solid_angle(np.sum(n * d, axis=-1), np.minimum(s, 1.0))
    return radiance * cap[..., None]


def sphere_occluder(points, centre, radius) -> tuple[np.ndarray, np.ndarray]:
    """(to_occluder (..., 3) unit, sin_half_angle (...,)) of a sphere of ``centre`` (3,) and
    ``radius`` (same length unit as the points, > 0) seen from receivers at ``points``
    (..., 3): d = (c − p)/|c − p|, sin α = R/|c − p| (≥ 1 inside). A receiver at the centre
    gets d = +Y and sin α = inf (inside). The arguments of :func:`occluded_ambient`."""
    p = np.asarray(points, np.float64)
    to_c = np.asarray(centre, np.float64) - p
    dist = np.linalg.norm(to_c, axis=-1)
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError("the occluder's radius is a length > 0")
    safe = np.where(dist > 0, dist, 1.0)
    d = np.where((dist > 0)[..., None], to_c / safe[..., None], [0.0, 1.0, 0.0])
    with np.errstate(divide="ignore"):
        s = np.where(dist > 0, float(radius) / safe, np.inf)
    return d, s


def _segment(half_angle, chord_angle):
    """The segment of a cap of ``half_angle`` x cut off by a great circle whose chord subtends
    ``chord_angle`` C ∈ [0, 2π] at the cap's axis, in units of sin²(x/2): the sector 2C less the
    triangle 2 atan(t² sin C / (1 + t² cos C)) / sin²(x/2), t² = sin²(x/2) / cos²(x/2), written
    as an atan2 that never divides by a small t²."""
    s2 = np.sin(0.5 * half_angle) ** 2
    tri = np.arctan2(s2 * np.sin(chord_angle), (1.0 - s2) + s2 * np.cos(chord_angle))
    return 2.0 * chord_angle - 2.0 * np.where(s2 > 0, tri / np.where(s2 > 0, s2, 1.0),
                                              np.sin(chord_angle))


def cap_overlap_fraction(light_radius, occluder_radius, separation) -> np.ndarray:
    """Ω(cap_a ∩ cap_α) / Ω(cap_a): the share of a cap of angular radius ``light_radius`` a
    (radians, [0, π/2]) inside one of ``occluder_radius`` α (radians, [0, π/2]) whose axis is
    ``separation`` γ (radians, [0, π]) from its own; broadcast, float64 in [0, 1]. a = 0 (a
    point): 1 where γ < α, else 0 (module docstring)."""
    a, al, g = np.broadcast_arrays(*(np.asarray(x, np.float64)
                                     for x in (light_radius, occluder_radius, separation)))

    def half_chord(x, y):   # φ at the axis of cap x (radius x) toward the rims' crossing
        den = np.sin(x) * np.sin(g)
        cos_phi = 1.0 + 2.0 * np.sin(0.5 * (g - x + y)) * np.sin(0.5 * (g - x - y)) \
            / np.where(den > 0, den, 1.0)
        return np.arccos(np.clip(cos_phi, -1.0, 1.0))
    sin2_a, sin2_al = np.sin(0.5 * a) ** 2, np.sin(0.5 * al) ** 2
    area_ratio = sin2_al / np.where(sin2_a > 0, sin2_a, 1.0)       # Ω(cap_α) / Ω(cap_a)
    lens = (_segment(a, 2 * half_chord(a, al))
            + area_ratio * _segment(al, 2 * half_chord(al, a))) / (4 * np.pi)
    out = np.clip(lens, 0.0, 1.0)
    out = np.where(g >= a + al, 0.0, out)                          # disjoint
    out = np.where(g <= a - al, np.minimum(area_ratio, 1.0), out)  # the sphere inside the disc
    out = np.where(g <= al - a, 1.0, out)                          # the disc inside the sphere
    return np.where(a <= 0, (g < al).astype(np.float64), out)


def sphere_light_visibility(points, centre, radius, light_directions,
                            angular_radius_deg) -> np.ndarray:
    """V_k: the unoccluded fraction of each light's uniform disc seen from receivers at
    ``points`` (..., 3) behind a sphere of ``centre`` (3,) and ``radius`` (> 0, the points'
    length unit), (..., k) float64 in [0, 1] (module docstring). ``light_directions`` (k, 3)
    unit, toward each light; ``angular_radius_deg`` (k,) in [0, 90] (the wire's
    ``light_angular_radius_deg``; 0: a point light). A receiver inside the sphere
    (|c − p| ≤ R) gets 0 for every light. Frame: any, the same for all of them; the lights
    are directional (at infinity), so only the direction from p to c matters."""
    d = np.asarray(light_directions, np.float64).reshape(-1, 3)
    r = np.asarray(angular_radius_deg, np.float64).reshape(-1)
    if len(r) != len(d):
        raise ValueError(f"{len(d)} light directions but {len(r)} angular radii")
    if not np.all((r >= 0) & (r <= 90)):
        raise ValueError("a light's angular radius is in [0, 90] degrees")
    to_c, s = sphere_occluder(points, centre, radius)
    inside = s >= 1.0
    alpha = np.arcsin(np.minimum(s, 1.0))
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    cos_g = to_c @ dn.T                                                  # (..., k)
    sin_g = np.linalg.norm(np.cross(to_c[..., None, :], dn), axis=-1)
    gamma = np.arctan2(sin_g, cos_g)
    covered = cap_overlap_fraction(np.radians(r), np.minimum(alpha, np.pi / 2)[..., None],
                                   gamma)
    return np.where(inside[..., None], 0.0, 1.0 - covered)
