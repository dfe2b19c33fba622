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

// The shadow a receiver sees (docs/contract.md §10, provider/core/lights/shadows.py): the
// factor a shadow catcher multiplies the camera image by, per colour,
//     ratio = (E_a(n) + Σ_k V_k I_k max(0, n·d_k)) / (E_a(n) + Σ_k I_k max(0, n·d_k)),
// E_a(n) = max(ñᵀAñ, 0) (the ambient, unoccluded), V_k = visibility[k] in [0, 1] (the
// engine's shadow map: 0 shadowed, 1 in the open; saturated) for lights 0..3; lights beyond
// the fourth, if SH_MAX_LIGHTS is raised, count as visible. 1 where the denominator is
// <= 0 (no light to block), so the result is always in [0, 1].
float3 SHShadowRatio(float3 n, float4 visibility)
{
    float4 v = saturate(visibility);
    float3 ambient = max(SHIrradianceUnclamped(n), 0.0);
    float3 lit = ambient;
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

#endif // SH9_LIGHTS_INCLUDED
