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

// The ambient irradiance an occluding sphere hides from a receiver (docs/contract.md §10,
// provider/core/lights/shadows.py occluded_ambient): n the receiver's unit normal,
// toOccluder = (c − p)/|c − p| toward the sphere's centre c, sinHalfAngle = R/|c − p| (R its
// radius; ≥ 1, the receiver inside, counts as 1). Per colour: the ambient's radiance toward
// the sphere (clamped at 0) times the projected solid angle of the sphere's cap: π sin²α n·d
// wholly above the receiver's horizon, the exact horizon-cut value when it straddles it
// (Snyder 1996), 0 below. Everything in the frame of n and the matrices.
float3 SHOccludedAmbient(float3 n, float3 toOccluder, float sinHalfAngle)
{
    float s = saturate(sinHalfAngle);
    float s2 = s * s;
    float h = clamp(dot(n, toOccluder), -1.0, 1.0);
    float cap;
    if (h * h >= s2)
    {
        cap = 3.14159265358979 * s2 * max(h, 0.0);
    }
    else
    {
        float sinT = sqrt(max(1.0 - h * h, 0.0));
        float x = sqrt(max(1.0 - s2, 0.0)) / max(s, 1e-30);   // cot α
        float y = clamp(-x * h / max(sinT, 1e-30), -1.0, 1.0);
        float sy = sqrt(max((s - h) * (s + h), 0.0)) / s;   // sinT·sqrt(1 − y²), accurate
        cap = max((h * acos(y) - x * sy) * s2 + atan2(sy, x), 0.0);
    }
    float3 radiance = float3(SHRadianceFromMatrix(_SHIrradianceR, toOccluder),
                             SHRadianceFromMatrix(_SHIrradianceG, toOccluder),
                             SHRadianceFromMatrix(_SHIrradianceB, toOccluder));
    return max(radiance, 0.0) * cap;
}

// SHOccludedAmbient for a receiver at point p and an occluding sphere (xyz: centre, w: radius,
// in p's frame, e.g. world space; w <= 0: no occluder, 0 returned). A receiver at the centre
// counts as inside (the hemisphere about n).
float3 SHOccludedAmbientOfSphere(float3 n, float3 p, float4 sphere)
{
    if (sphere.w <= 0.0)
        return 0.0;
    float3 toCentre = sphere.xyz - p;
    float dist = length(toCentre);
    float3 d = dist > 0.0 ? toCentre / dist : n;
    return SHOccludedAmbient(n, d, sphere.w / max(dist, 1e-30));
}

// SHShadowRatio with the occluder's ambient occlusion: occludedAmbient (≥ 0, normally
// SHOccludedAmbient(n, ...)) is taken off the ambient in the numerator, never below zero:
//     ratio = (max(E_a(n) − O, 0) + Σ_k V_k I_k max(0, n·d_k)) / (E_a(n) + Σ_k I_k max(0, n·d_k))
// 1 where the denominator is <= 0; always in [0, 1].
float3 SHShadowRatioOccluded(float3 n, float4 visibility, float3 occludedAmbient)
{
    float4 v = saturate(visibility);
    float3 ambient = max(SHIrradianceUnclamped(n), 0.0);
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

#endif // SH9_LIGHTS_INCLUDED
