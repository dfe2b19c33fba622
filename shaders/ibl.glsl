// Image-based lighting: SH9 diffuse plus specular reflections from the provider's
// GGX-prefiltered environment cube (docs/contract.md §12, "Shaders"). The same function names
// exist in shaders/ibl.hlsl.
// Paste after shaders/sh9_irradiance.glsl (it uses shIrradiance); no #version line here.
//
//     colour = albedo · E(N) / π  +  PF(R, roughness) · EnvBRDFApprox(F0, roughness, N·V)
//     R = reflect(−V, N),  lod = roughness · (mip_count − 1)
//
// E(N): the SH9 irradiance (shIrradianceR/G/B); PF: the prefiltered radiance, mip k of the cube
// prefiltered for perceptual roughness k / (mip_count − 1); EnvBRDFApprox: Karis's analytic
// split-sum DFG ("Physically Based Shading on Mobile", 2014). Result: outgoing radiance in the
// units of the coefficients and of the cube (the provider sends both in the same units).
//
// Uniforms:
//   shEnvironment          samplerCube: all the cube's mips (faces +X −X +Y −Y +Z −Z as
//                          GL_TEXTURE_CUBE_MAP_POSITIVE_X + f, row 0 first, no flips), RGBA16F
//                          or RGBA32F, GL_LINEAR_MIPMAP_LINEAR, GL_TEXTURE_MAX_LEVEL =
//                          mip_count − 1, and glEnable(GL_TEXTURE_CUBE_MAP_SEAMLESS) (WebGL 2
//                          and GLES 3 filter cube maps seamlessly already).
//   shEnvironmentMipCount  the message's mip count (the cube's levels, smallest 2×2).
// Frame: N, V and the cube in the wire frame (right-handed, +Y up). A renderer whose world
// frame differs defines SHLIGHT_ENVIRONMENT_DIRECTION(d) before this file to map a world
// direction to the wire frame (e.g. a probe's rotation); the default is d itself.
#ifndef SHLIGHT_ENVIRONMENT_DIRECTION
#define SHLIGHT_ENVIRONMENT_DIRECTION(d) (d)
#endif
uniform samplerCube shEnvironment;
uniform int shEnvironmentMipCount;

const float SHLIGHT_PI = 3.14159265358979;

// The mip level for a perceptual roughness (0 = mirror .. 1), as the provider prefilters.
float shlight_specular_lod(float roughness) {
    return clamp(roughness, 0.0, 1.0) * float(shEnvironmentMipCount - 1);
}

// PF(R): the prefiltered radiance toward unit direction R (trilinear: bilinear within a
// face, linear between the two nearest mips).
vec3 shlight_prefiltered_radiance(vec3 R, float roughness) {
    return textureLod(shEnvironment, SHLIGHT_ENVIRONMENT_DIRECTION(R),
                      shlight_specular_lod(roughness)).rgb;
}

// Karis's analytic DFG: (scale, bias) with EnvBRDF = F0 · scale + bias (roughness clamped
// to 0..1 like the lod).
vec2 shlight_env_brdf_scale_bias(float roughness, float NoV) {
    const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
    const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
    vec4 r = clamp(roughness, 0.0, 1.0) * c0 + c1;
    float a004 = min(r.x * r.x, exp2(-9.28 * NoV)) * r.x + r.y;
    return vec2(-1.04, 1.04) * a004 + r.zw;
}

// EnvBRDFApprox(F0, roughness, N·V): the split-sum's directional albedo of the specular lobe.
vec3 shlight_env_brdf_approx(vec3 F0, float roughness, float NoV) {
    vec2 ab = shlight_env_brdf_scale_bias(roughness, NoV);
    return F0 * ab.x + ab.y;
}

// Diffuse: a Lambertian surface of albedo ρ shows ρ·E(N)/π (E from SH9, clamped at zero).
vec3 shlight_ibl_diffuse(vec3 N, vec3 albedo) {
    return albedo * shIrradiance(N) / SHLIGHT_PI;
}

// Specular: PF(reflect(−V, N)) · EnvBRDFApprox(F0, roughness, max(N·V, 0)).
vec3 shlight_ibl_specular(vec3 N, vec3 V, vec3 F0, float roughness) {
    float NoV = max(dot(N, V), 0.0);
    vec3 R = reflect(-V, N);
    return shlight_prefiltered_radiance(R, roughness) * shlight_env_brdf_approx(F0, roughness, NoV);
}

// The whole image-based lighting at a surface point: unit normal N, unit direction to the
// viewer V, diffuse albedo, specular reflectance at normal incidence F0 (0.04 for dielectrics,
// the base colour for metals) and perceptual roughness 0..1.
vec3 shlight_ibl(vec3 N, vec3 V, vec3 albedo, vec3 F0, float roughness) {
    return shlight_ibl_diffuse(N, albedo) + shlight_ibl_specular(N, V, F0, roughness);
}
