// Image-based lighting: SH9 diffuse plus specular reflections from the provider's
// GGX-prefiltered environment cube (docs/contract.md §12, "Shaders"). The same function names
// exist in shaders/ibl.glsl. Include into any HLSL program (Unity built-in, URP, or plain D3D);
// it includes sh9_irradiance.hlsl (same folder).
//
//     colour = albedo · E(N) / π  +  PF(R, roughness) · EnvBRDFApprox(F0, roughness, N·V)
//     R = reflect(−V, N),  lod = roughness · (mip_count − 1)
//
// E(N): the SH9 irradiance (_SHIrradianceR/G/B); PF: the prefiltered radiance, mip k of the
// cube prefiltered for perceptual roughness k / (mip_count − 1); EnvBRDFApprox: Karis's
// analytic split-sum DFG ("Physically Based Shading on Mobile", 2014). Result: outgoing
// radiance in the units of the coefficients and of the cube.
//
// Globals:
//   _SHEnvironment, sampler_SHEnvironment  the cube with all its mips (faces +X −X +Y −Y +Z −Z,
//                          row 0 first, as the provider sends them), trilinear filtering (D3D
//                          filters cube maps seamlessly).
//   _SHEnvironmentMipCount the message's mip count (the cube's levels, smallest 2×2).
// Frame: the cube is in the wire frame (right-handed, +Y up). Define
// SHLIGHT_ENVIRONMENT_DIRECTION(d) before the include to map a direction of your world frame to
// it: a Unity client whose matrices and normals are in Unity's left-handed frame (z -> -z)
// defines it as float3((d).x, (d).y, -(d).z) (times the probe's rotation where it has one).
#ifndef SHLIGHT_IBL_INCLUDED
#define SHLIGHT_IBL_INCLUDED

#include "sh9_irradiance.hlsl"

#ifndef SHLIGHT_ENVIRONMENT_DIRECTION
#define SHLIGHT_ENVIRONMENT_DIRECTION(d) (d)
#endif

TextureCube<float4> _SHEnvironment;
SamplerState sampler_SHEnvironment;
int _SHEnvironmentMipCount;

static const float SHLIGHT_PI = 3.14159265358979;

// The mip level for a perceptual roughness (0 = mirror .. 1), as the provider prefilters.
float shlight_specular_lod(float roughness)
{
    return saturate(roughness) * float(_SHEnvironmentMipCount - 1);
}

// PF(R): the prefiltered radiance toward unit direction R (trilinear).
float3 shlight_prefiltered_radiance(float3 R, float roughness)
{
    return _SHEnvironment.SampleLevel(sampler_SHEnvironment, SHLIGHT_ENVIRONMENT_DIRECTION(R),
                                      shlight_specular_lod(roughness)).rgb;
}

// Karis's analytic DFG: (scale, bias) with EnvBRDF = F0 · scale + bias (roughness clamped
// to 0..1 like the lod).
float2 shlight_env_brdf_scale_bias(float roughness, float NoV)
{
    const float4 c0 = float4(-1.0, -0.0275, -0.572, 0.022);
    const float4 c1 = float4(1.0, 0.0425, 1.04, -0.04);
    float4 r = saturate(roughness) * c0 + c1;
    float a004 = min(r.x * r.x, exp2(-9.28 * NoV)) * r.x + r.y;
    return float2(-1.04, 1.04) * a004 + r.zw;
}

// EnvBRDFApprox(F0, roughness, N·V): the split-sum's directional albedo of the specular lobe.
float3 shlight_env_brdf_approx(float3 F0, float roughness, float NoV)
{
    float2 ab = shlight_env_brdf_scale_bias(roughness, NoV);
    return F0 * ab.x + ab.y;
}

// Diffuse: a Lambertian surface of albedo ρ shows ρ·E(N)/π (E from SH9, clamped at zero).
float3 shlight_ibl_diffuse(float3 N, float3 albedo)
{
    return albedo * SHIrradiance(N) / SHLIGHT_PI;
}

// Specular: PF(reflect(−V, N)) · EnvBRDFApprox(F0, roughness, max(N·V, 0)).
float3 shlight_ibl_specular(float3 N, float3 V, float3 F0, float roughness)
{
    float NoV = max(dot(N, V), 0.0);
    float3 R = reflect(-V, N);
    return shlight_prefiltered_radiance(R, roughness) * shlight_env_brdf_approx(F0, roughness, NoV);
}

// The whole image-based lighting at a surface point: unit normal N, unit direction to the
// viewer V, diffuse albedo, specular reflectance at normal incidence F0 (0.04 for dielectrics,
// the base colour for metals) and perceptual roughness 0..1.
float3 shlight_ibl(float3 N, float3 V, float3 albedo, float3 F0, float roughness)
{
    return shlight_ibl_diffuse(N, albedo) + shlight_ibl_specular(N, V, F0, roughness);
}

#endif // SHLIGHT_IBL_INCLUDED
