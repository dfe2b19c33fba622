// SH9 ambient plus directional lights (docs/contract.md §10):
//     E(n) = ñᵀ A ñ + Σ_k I_k · max(0, n · d_k)
// Include into any HLSL program (Unity built-in, URP, or plain D3D); it includes
// sh9_irradiance.hlsl (same folder) for _SHIrradianceR/G/B and SHIrradianceUnclamped.
//
// Globals, from the wire message:
//   _SHIrradianceR/G/B     the "ambient_matrices" (A), not "matrices"
//   _SHLightCount          "lights" (k, at most SH_MAX_LIGHTS)
//   _SHLightDirection[i]   (light_directions[3i..3i+2], 0): unit vector toward light i
//   _SHLightIrradiance[i]  (light_irradiance[3i..3i+2], 0): RGB irradiance on a surface
//                          facing light i (the units of E)
// Everything must be in the frame of the normals: a Unity client converts the wire frame
// (right-handed, +Y up) to Unity's left-handed one (z -> -z on the matrices and on each
// direction) and applies the probe's orientation to both. With "lights": 0 the message's
// ambient is the full SH9, so this equals SHIrradiance(n). A Lambertian surface of albedo ρ
// shows radiance ρ·E/π.
#ifndef SH9_LIGHTS_INCLUDED
#define SH9_LIGHTS_INCLUDED

#include "sh9_irradiance.hlsl"

#ifndef SH_MAX_LIGHTS
#define SH_MAX_LIGHTS 4
#endif

float4 _SHLightDirection[SH_MAX_LIGHTS];
float4 _SHLightIrradiance[SH_MAX_LIGHTS];
int _SHLightCount;

// Σ_k I_k · max(0, n · d_k): what the directional lights add at unit normal n.
float3 SHLightsIrradiance(float3 n)
{
    float3 e = 0.0;
    [unroll]
    for (int i = 0; i < SH_MAX_LIGHTS; ++i)
    {
        if (i < _SHLightCount)
            e += _SHLightIrradiance[i].rgb * max(dot(n, _SHLightDirection[i].xyz), 0.0);
    }
    return e;
}

// Ambient + lights before clamping (the ambient alone can ring below zero).
float3 SHIrradianceWithLightsUnclamped(float3 n)
{
    return SHIrradianceUnclamped(n) + SHLightsIrradiance(n);
}

// Irradiance at unit normal n from the ambient and the lights, clamped at zero.
float3 SHIrradianceWithLights(float3 n)
{
    return max(SHIrradianceWithLightsUnclamped(n), 0.0);
}

// The SH9 ambient's radiance toward unit d, from its irradiance matrix alone: with
// A = [[B, m], [mᵀ, M33]], (4 dᵀBd + 3 m·d + M33 − tr B) / π (each SH band of E over its
// cosine-lobe factor π, 2π/3, π/4); not clamped. A is symmetric, so row or column order
// does not matter.
float SHRadianceFromMatrix(float4x4 A, float3 d)
{
    float3 m = float3(A[0][3], A[1][3], A[2][3]);
    float traceB = A[0][0] + A[1][1] + A[2][2];
    return (4.0 * dot(d, mul((float3x3)A, d)) + 3.0 * dot(m, d) + A[3][3] - traceB)
           / 3.14159265358979;
}

// ∫ over a cap of half-angle α of max(0, n·ω) dω, cosToCap = n·d to its axis, sinHalfAngle = sin α (≥ 1: the
// receiver inside, counts as 1): π sin²α n·d wholly above the horizon, the exact horizon-cut value when the cap
// straddles it (Snyder 1996), 0 below (provider/core/lights/shadows.py cap_projected_solid_angle).
float SHCapProjectedSolidAngle(float cosToCap, float sinHalfAngle)
{
    float s = saturate(sinHalfAngle);
    float s2 = s * s;
    float h = clamp(cosToCap, -1.0, 1.0);
    if (h * h >= s2)
        return 3.14159265358979 * s2 * max(h, 0.0);
    float sinT = sqrt(max(1.0 - h * h, 0.0));
    float x = sqrt(max(1.0 - s2, 0.0)) / max(s, 1e-30);   // cot α
    float y = clamp(-x * h / max(sinT, 1e-30), -1.0, 1.0);
    float sy = sqrt(max((s - h) * (s + h), 0.0)) / s;   // sinT·sqrt(1 − y²), accurate
    return max((h * acos(y) - x * sy) * s2 + atan2(sy, x), 0.0);
}

// The radiance of _SHIrradianceR/G/B toward unit d, per colour (SHRadianceFromMatrix; not clamped).
float3 SHAmbientRadiance(float3 d)
{
    return float3(SHRadianceFromMatrix(_SHIrradianceR, d), SHRadianceFromMatrix(_SHIrradianceG, d),
                  SHRadianceFromMatrix(_SHIrradianceB, d));
}

// An occluding sphere (xyz: centre, w: radius, p's frame) seen from point p: the unit direction
// toward its centre (n for p at the centre: inside, the hemisphere about n) and, in sinHalfAngle,
// R/|c − p| (≥ 1 inside).
float3 SHTowardSphere(float3 n, float3 p, float4 sphere, out float sinHalfAngle)
{
    float3 toCentre = sphere.xyz - p;
    float dist = length(toCentre);
    sinHalfAngle = sphere.w / max(dist, 1e-30);
    return dist > 0.0 ? toCentre / dist : n;
}

// The ambient irradiance an occluding sphere hides from a receiver (docs/contract.md §10,
// provider/core/lights/shadows.py occluded_ambient): n the receiver's unit normal,
// toOccluder = (c − p)/|c − p| toward the sphere's centre c, sinHalfAngle = R/|c − p| (R its
// radius; ≥ 1, the receiver inside, counts as 1). Per colour: the ambient's radiance toward
// the sphere (clamped at 0) times the projected solid angle of the sphere's cap: π sin²α n·d
// wholly above the receiver's horizon, the exact horizon-cut value when it straddles it
// (Snyder 1996), 0 below. Everything in the frame of n and the matrices.
float3 SHOccludedAmbient(float3 n, float3 toOccluder, float sinHalfAngle)
{
    return max(SHAmbientRadiance(toOccluder), 0.0) * SHCapProjectedSolidAngle(dot(n, toOccluder), sinHalfAngle);
}

// SHOccludedAmbient for a receiver at point p and an occluding sphere (xyz: centre, w: radius,
// in p's frame, e.g. world space; w <= 0: no occluder, 0 returned). A receiver at the centre
// counts as inside (the hemisphere about n).
float3 SHOccludedAmbientOfSphere(float3 n, float3 p, float4 sphere)
{
    if (sphere.w <= 0.0)
        return 0.0;
    float sinHalfAngle;
    float3 d = SHTowardSphere(n, p, sphere, sinHalfAngle);
    return SHOccludedAmbient(n, d, sinHalfAngle);
}

// SHShadowRatioOccluded with the ambient E_a(n) (≥ 0, per colour) given instead of read from the globals.
float3 SHShadowRatioOfAmbient(float3 n, float3 ambient, float4 visibility, float3 occludedAmbient)
{
    float4 v = saturate(visibility);
    float3 lit = max(ambient - max(occludedAmbient, 0.0), 0.0);
    float3 open = ambient;
    [unroll]
    for (int i = 0; i < SH_MAX_LIGHTS; ++i)
    {
        if (i < _SHLightCount)
        {
            float3 e = _SHLightIrradiance[i].rgb * max(dot(n, _SHLightDirection[i].xyz), 0.0);
            lit += (i < 4 ? v[min(i, 3)] : 1.0) * e;
            open += e;
        }
    }
    float3 lightFalls = (float3)(open > 0.0);
    return lerp((float3)1.0, lit / max(open, 1e-30), lightFalls);
}

// SHShadowRatio with the occluder's ambient occlusion: occludedAmbient (≥ 0, normally
// SHOccludedAmbient(n, ...)) is taken off the ambient in the numerator, never below zero:
//     ratio = (max(E_a(n) − O, 0) + Σ_k V_k I_k max(0, n·d_k)) / (E_a(n) + Σ_k I_k max(0, n·d_k))
// 1 where the denominator is <= 0; always in [0, 1].
float3 SHShadowRatioOccluded(float3 n, float4 visibility, float3 occludedAmbient)
{
    return SHShadowRatioOfAmbient(n, max(SHIrradianceUnclamped(n), 0.0), visibility, occludedAmbient);
}

// The shadow a receiver sees (docs/contract.md §10, provider/core/lights/shadows.py): the
// factor a shadow catcher multiplies the camera image by, per colour,
//     ratio = (E_a(n) + Σ_k V_k I_k max(0, n·d_k)) / (E_a(n) + Σ_k I_k max(0, n·d_k)),
// E_a(n) = max(ñᵀAñ, 0) (the ambient, unoccluded), V_k = visibility[k] in [0, 1] (the
// engine's shadow map: 0 shadowed, 1 in the open; saturated) for lights 0..3; lights beyond
// the fourth, if SH_MAX_LIGHTS is raised, count as visible. 1 where the denominator is
// <= 0 (no light to block), so the result is always in [0, 1].
float3 SHShadowRatio(float3 n, float4 visibility)
{
    return SHShadowRatioOccluded(n, visibility, (float3)0.0);   // nothing occluded: E_a stays
}

// Each light's visibility past an occluding sphere (docs/contract.md §10,
// provider/core/lights/shadows.py sphere_light_visibility). Angular radius of lights 0..3, in
// radians (the wire's light_angular_radius_deg × π/180; 0: a point light):
float4 _SHLightAngularRadius;

// The segment of a cap of half-angle x cut off by a great circle whose chord subtends c at the
// cap's axis, in units of sin²(x/2): the sector 2c less the isosceles spherical triangle.
// Below c = 0.5 the two nearly cancel (a sun's sliver of a wide sphere), and a GPU's atan is
// good to ~1e-4 only: there their difference's series, (1 − s2)(1 − 2 s2) c³ (1/3 −
// (1 − 12q) c²/60 + (1 − 60q + 360q²) c⁴/2520), q = s2(1 − s2), next term < 2e-5 of it.
float SHCapSegment(float x, float c)
{
    float s2 = sin(0.5 * x);
    s2 *= s2;
    if (c < 0.5)
    {
        float q = s2 * (1.0 - s2), cc = c * c;
        return (1.0 - s2) * (1.0 - 2.0 * s2) * cc * c * (1.0 / 3.0 - (1.0 - 12.0 * q) * cc / 60.0
               + (1.0 - 60.0 * q + 360.0 * q * q) * cc * cc / 2520.0);
    }
    float tri = s2 > 0.0 ? atan2(s2 * sin(c), (1.0 - s2) + s2 * cos(c)) / max(s2, 1e-30) : sin(c);
    return 2.0 * c - 2.0 * tri;
}

// The half-angle at the axis of a cap of radius x between the other cap's axis (radius y,
// axes g apart, gx = g − x given apart) and a point where the rims cross, from half-angle
// sines (a 0.27° sun keeps its digits in float32).
float SHCapHalfChord(float x, float y, float g, float gx)
{
    float den = sin(x) * sin(g);
    float c = 1.0 + 2.0 * sin(0.5 * (gx + y)) * sin(0.5 * (gx - y)) / (den > 0.0 ? den : 1.0);
    return acos(clamp(c, -1.0, 1.0));
}

// The share of a light's disc (cap of angular radius a, radians) that a cap of half-angle
// alpha whose axis is g away covers: Ω(cap_a ∩ cap_α) / Ω(cap_a) (Mazonka 2012), in [0, 1].
// delta = g − alpha, computed by the caller without subtracting the two (a sun's disc is
// 0.0047 rad wide; a GPU's asin and atan are good to ~1e-4 of the angle only).
float SHCapOverlapFraction(float a, float alpha, float g, float delta)
{
    if (a <= 0.0) return delta < 0.0 ? 1.0 : 0.0;         // a point light
    if (delta >= a) return 0.0;                            // apart
    if (delta <= -a) return 1.0;                           // the disc inside the sphere
    float sa = sin(0.5 * a), sal = sin(0.5 * alpha);
    float areaRatio = (sal * sal) / (sa * sa);             // Ω(cap_α) / Ω(cap_a)
    if (g <= a - alpha) return min(areaRatio, 1.0);        // the sphere inside the disc
    float lens = SHCapSegment(a, 2.0 * SHCapHalfChord(a, alpha, g, delta + alpha - a))
               + areaRatio * SHCapSegment(alpha, 2.0 * SHCapHalfChord(alpha, a, g, delta));
    return saturate(lens / (4.0 * 3.14159265358979));
}

// The unoccluded fraction of a light's uniform disc (toward unit lightDirection, angular
// radius angularRadius in radians) seen from point p behind a sphere (xyz: centre, w: radius,
// p's frame): 1 − Ω(disc ∩ sphere's cap)/Ω(disc). sphere.w <= 0 (no occluder): 1; p inside
// the sphere (|c − p| <= R): 0.
float SHSphereLightVisibility(float3 p, float4 sphere, float3 lightDirection, float angularRadius)
{
    if (sphere.w <= 0.0) return 1.0;
    float3 toCentre = sphere.xyz - p;
    float dist = length(toCentre);
    if (dist <= sphere.w) return 0.0;
    float3 d = toCentre / dist;
    float sinG = length(cross(d, lightDirection)), cosG = dot(d, lightDirection);
    float sinAlpha = sphere.w / dist, cosAlpha = sqrt((dist - sphere.w) * (dist + sphere.w)) / dist;
    float delta = atan2(sinG * cosAlpha - cosG * sinAlpha, cosG * cosAlpha + sinG * sinAlpha);
    return 1.0 - SHCapOverlapFraction(max(angularRadius, 0.0), atan2(sinAlpha, cosAlpha),
                                       atan2(sinG, cosG), delta);
}

// SHSphereLightVisibility for lights 0..3 of the globals (_SHLightDirection,
// _SHLightAngularRadius); slots at or beyond _SHLightCount get 1. A visibility for
// SHShadowRatio / SHShadowRatioOccluded, e.g. with lights 1..3 from here and light 0 from
// the engine's shadow map.
float4 SHSphereLightsVisibility(float3 p, float4 sphere)
{
    float4 v = 1.0;
    [unroll]
    for (int i = 0; i < 4; ++i)
    {
        if (i < _SHLightCount)
            v[i] = SHSphereLightVisibility(p, sphere, _SHLightDirection[i].xyz, _SHLightAngularRadius[i]);
    }
    return v;
}

// Light i's SH9 projection E_i·Y(d_i) (what Unity's SH9LightingClient folds into _SHIrradianceR/G/B for every light
// but the drawn one, so that Unity's ambient probe keeps it): its irradiance at unit n, E_i (1/4 + x/2 + 5(3x² − 1)/32),
// and its radiance toward unit d, E_i (1 + 3x + 5(3x² − 1)/2) / (4π), x the cosine to d_i (bands 0..2 of a delta
// light: (2l + 1)/(4π) P_l(x), the irradiance each times its cosine-lobe factor π, 2π/3, π/4).
float3 SHFoldedLightIrradiance(float3 n, int i)
{
    float x = dot(n, _SHLightDirection[i].xyz);
    return _SHLightIrradiance[i].rgb * (0.25 + 0.5 * x + 0.15625 * (3.0 * x * x - 1.0));
}

float3 SHFoldedLightRadiance(float3 d, int i)
{
    float x = dot(d, _SHLightDirection[i].xyz);
    return _SHLightIrradiance[i].rgb * (1.0 + 3.0 * x + 2.5 * (3.0 * x * x - 1.0)) / (4.0 * 3.14159265358979);
}

// What a shadow catcher multiplies the camera image by under an occluder sphere (xyz: centre, w: radius, p's frame;
// w <= 0: none) for a receiver of unit normal n at point p (docs/contract.md §10; the CPU's shadow_ratio(n, V,
// occluded_ambient) with V from sphere_light_visibility): light 0 seen by keyVisibility (the engine's shadow map,
// which has the hologram's real shape), lights 1..3 by SHSphereLightVisibility, the ambient less what the sphere
// hides of it; strength in [0, 1] scales every blocked part (1: as measured). Lights 1.._SHLightCount − 1 are also
// in _SHIrradianceR/G/B as their SH9 projections (Unity's SH9LightingClient folds them there for the ambient probe);
// they are taken out first, so the ambient is the message's.
float3 SHShadowRatioOfSphere(float3 n, float3 p, float4 sphere, float keyVisibility, float strength)
{
    float sinHalfAngle;
    float3 d = SHTowardSphere(n, p, sphere, sinHalfAngle);
    float3 ambient = SHIrradianceUnclamped(n);
    float3 radiance = SHAmbientRadiance(d);
    [unroll]
    for (int i = 1; i < 4; ++i)
    {
        if (i < _SHLightCount)
        {
            ambient -= SHFoldedLightIrradiance(n, i);
            radiance -= SHFoldedLightRadiance(d, i);
        }
    }
    float3 occluded = sphere.w > 0.0
        ? max(radiance, 0.0) * SHCapProjectedSolidAngle(dot(n, d), sinHalfAngle) : (float3)0.0;
    float4 v = SHSphereLightsVisibility(p, sphere);
    v.x = keyVisibility;
    return SHShadowRatioOfAmbient(n, max(ambient, 0.0), lerp((float4)1.0, v, saturate(strength)),
                                  occluded * saturate(strength));
}

#endif // SH9_LIGHTS_INCLUDED
