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

// The shadow a receiver sees (docs/contract.md §10, provider/core/lights/shadows.py): the
// factor a shadow catcher multiplies the camera image by, per colour,
//     ratio = (E_a(n) + Σ_k V_k I_k max(0, n·d_k)) / (E_a(n) + Σ_k I_k max(0, n·d_k)),
// E_a(n) = max(ñᵀAñ, 0) (the ambient, unoccluded), V_k = visibility[k] in [0, 1] (the
// engine's shadow map: 0 shadowed, 1 in the open; clamped to [0, 1]) for lights 0..3;
// lights beyond the fourth, if SH_MAX_LIGHTS is raised, count as visible. 1 where the
// denominator is <= 0 (no light to block), so the result is always in [0, 1].
vec3 shShadowRatio(vec3 n, vec4 visibility) {
    vec4 v = clamp(visibility, 0.0, 1.0);
    vec3 ambient = max(shIrradianceUnclamped(n), vec3(0.0));
    vec3 lit = ambient;
    vec3 open = ambient;
    for (int i = 0; i < SH_MAX_LIGHTS; ++i) {
        if (i >= shLightCount) break;
        vec3 e = shLightIrradiance[i].rgb * max(dot(n, shLightDirection[i].xyz), 0.0);
        lit += (i < 4 ? v[min(i, 3)] : 1.0) * e;
        open += e;
    }
    return mix(vec3(1.0), lit / max(open, vec3(1e-30)), greaterThan(open, vec3(0.0)));
}
