// SH9 diffuse irradiance, E(n) = ñᵀ M ñ with ñ = (n, 1)  (docs/contract.md §2, Ramamoorthi & Hanrahan 2001).
// Include into any HLSL program (Unity built-in, URP, or plain D3D).
//
// _SHIrradianceR/G/B: the three symmetric 4×4 irradiance matrices. M is symmetric, so row- or
// column-major upload gives the same matrix. They must be in the same frame as the normals:
// the Unity client converts the wire frame (right-handed, +Y up) to Unity's left-handed frame
// (z -> -z) and applies the probe's orientation before setting them.
// A Lambertian surface of albedo ρ shows radiance ρ·E/π.
#ifndef SH9_IRRADIANCE_INCLUDED
#define SH9_IRRADIANCE_INCLUDED

float4x4 _SHIrradianceR;
float4x4 _SHIrradianceG;
float4x4 _SHIrradianceB;

// Irradiance before clamping (can be negative where order-2 SH rings).
float3 SHIrradianceUnclamped(float3 n)
{
    float4 nh = float4(n, 1.0);
    return float3(dot(nh, mul(_SHIrradianceR, nh)),
                  dot(nh, mul(_SHIrradianceG, nh)),
                  dot(nh, mul(_SHIrradianceB, nh)));
}

// Irradiance at unit normal n, clamped at zero (SH9 ringing must never make negative light).
float3 SHIrradiance(float3 n)
{
    return max(SHIrradianceUnclamped(n), 0.0);
}

#endif // SH9_IRRADIANCE_INCLUDED
