// SH9 ambient plus directional lights (docs/contract.md §10):
//     E(n) = ñᵀ A ñ + Σ_k I_k · max(0, n · d_k)
// Paste after shaders/sh9_irradiance.glsl (it uses shIrradianceUnclamped); no #version line.
//
// Uniforms, from the wire message (right-handed, +Y up, like the matrices):
//   shIrradianceR/G/B     the "ambient_matrices" (A), not "matrices"
//   shLightCount          "lights" (k, at most SH_MAX_LIGHTS)
//   shLightDirection[i]   (light_directions[3i], [3i+1], [3i+2], 0): unit vector toward light i
//   shLightIrradiance[i]  (light_irradiance[3i], [3i+1], [3i+2], 0): RGB irradiance on a
//                         surface facing light i (the units of E)
// With "lights": 0 the message's ambient is the full SH9, so this equals shIrradiance(n): a
// client can always upload the ambient and the lights. A Lambertian surface of albedo ρ
// shows radiance ρ·E/π; the direction of light i is also the one to cast its shadow from.
#ifndef SH_MAX_LIGHTS
#define SH_MAX_LIGHTS 4
#endif
uniform vec4 shLightDirection[SH_MAX_LIGHTS];
uniform vec4 shLightIrradiance[SH_MAX_LIGHTS];
uniform int shLightCount;

// Σ_k I_k · max(0, n · d_k): what the directional lights add at unit normal n.
vec3 shLightsIrradiance(vec3 n) {
    vec3 e = vec3(0.0);
    for (int i = 0; i < SH_MAX_LIGHTS; ++i) {
        if (i >= shLightCount) break;
        e += shLightIrradiance[i].rgb * max(dot(n, shLightDirection[i].xyz), 0.0);
    }
    return e;
}

// Ambient + lights before clamping (the ambient alone can ring below zero).
vec3 shIrradianceWithLightsUnclamped(vec3 n) {
    return shIrradianceUnclamped(n) + shLightsIrradiance(n);
}

// Irradiance at unit normal n from the ambient and the lights, clamped at zero.
vec3 shIrradianceWithLights(vec3 n) {
    return max(shIrradianceWithLightsUnclamped(n), vec3(0.0));
}
