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

// The SH9 ambient's radiance toward unit d, from its irradiance matrix alone: with
// A = [[B, m], [mᵀ, M33]], (4 dᵀBd + 3 m·d + M33 − tr B) / π (each SH band of E over its
// cosine-lobe factor π, 2π/3, π/4); not clamped.
float shRadianceFromMatrix(mat4 A, vec3 d) {
    vec3 m = A[3].xyz;
    float traceB = A[0][0] + A[1][1] + A[2][2];
    return (4.0 * dot(d, mat3(A) * d) + 3.0 * dot(m, d) + A[3][3] - traceB) / 3.14159265358979;
}

// The ambient irradiance an occluding sphere hides from a receiver (docs/contract.md §10,
// provider/core/lights/shadows.py occluded_ambient): n the receiver's unit normal,
// toOccluder = (c − p)/|c − p| toward the sphere's centre c, sinHalfAngle = R/|c − p| (R its
// radius; ≥ 1, the receiver inside, counts as 1). Per colour: the ambient's radiance toward
// the sphere (clamped at 0) times the projected solid angle of the sphere's cap: π sin²α n·d
// wholly above the receiver's horizon, the exact horizon-cut value when it straddles it
// (Snyder 1996), 0 below. Everything in the frame of n and the matrices.
vec3 shOccludedAmbient(vec3 n, vec3 toOccluder, float sinHalfAngle) {
    float s = clamp(sinHalfAngle, 0.0, 1.0);
    float s2 = s * s;
    float h = clamp(dot(n, toOccluder), -1.0, 1.0);
    float cap;
    if (h * h >= s2) {
        cap = 3.14159265358979 * s2 * max(h, 0.0);
    } else {
        float sinT = sqrt(max(1.0 - h * h, 0.0));
        float x = sqrt(max(1.0 - s2, 0.0)) / max(s, 1e-30);   // cot α
        float y = clamp(-x * h / max(sinT, 1e-30), -1.0, 1.0);
        float sy = sqrt(max((s - h) * (s + h), 0.0)) / s;   // sinT·sqrt(1 − y²), accurate
        cap = max((h * acos(y) - x * sy) * s2 + atan(sy, x), 0.0);
    }
    vec3 radiance = vec3(shRadianceFromMatrix(shIrradianceR, toOccluder),
                         shRadianceFromMatrix(shIrradianceG, toOccluder),
                         shRadianceFromMatrix(shIrradianceB, toOccluder));
    return max(radiance, vec3(0.0)) * cap;
}

// shOccludedAmbient for a receiver at point p and an occluding sphere (xyz: centre, w: radius,
// in p's frame, e.g. world space; w <= 0: no occluder, 0 returned). A receiver at the centre
// counts as inside (the hemisphere about n).
vec3 shOccludedAmbientOfSphere(vec3 n, vec3 p, vec4 sphere) {
    if (sphere.w <= 0.0) return vec3(0.0);
    vec3 toCentre = sphere.xyz - p;
    float dist = length(toCentre);
    vec3 d = dist > 0.0 ? toCentre / dist : n;
    return shOccludedAmbient(n, d, sphere.w / max(dist, 1e-30));
}

// shShadowRatio with the occluder's ambient occlusion: occludedAmbient (≥ 0, normally
// shOccludedAmbient(n, ...)) is taken off the ambient in the numerator, never below zero:
//     ratio = (max(E_a(n) − O, 0) + Σ_k V_k I_k max(0, n·d_k)) / (E_a(n) + Σ_k I_k max(0, n·d_k))
// 1 where the denominator is <= 0; always in [0, 1].
vec3 shShadowRatioOccluded(vec3 n, vec4 visibility, vec3 occludedAmbient) {
    vec4 v = clamp(visibility, 0.0, 1.0);
    vec3 ambient = max(shIrradianceUnclamped(n), vec3(0.0));
    vec3 lit = max(ambient - max(occludedAmbient, vec3(0.0)), vec3(0.0));
    vec3 open = ambient;
    for (int i = 0; i < SH_MAX_LIGHTS; ++i) {
        if (i >= shLightCount) break;
        vec3 e = shLightIrradiance[i].rgb * max(dot(n, shLightDirection[i].xyz), 0.0);
        lit += (i < 4 ? v[min(i, 3)] : 1.0) * e;
        open += e;
    }
    return mix(vec3(1.0), lit / max(open, vec3(1e-30)), greaterThan(open, vec3(0.0)));
}

// The shadow a receiver sees (docs/contract.md §10, provider/core/lights/shadows.py): the
// factor a shadow catcher multiplies the camera image by, per colour,
//     ratio = (E_a(n) + Σ_k V_k I_k max(0, n·d_k)) / (E_a(n) + Σ_k I_k max(0, n·d_k)),
// E_a(n) = max(ñᵀAñ, 0) (the ambient, unoccluded), V_k = visibility[k] in [0, 1] (the
// engine's shadow map: 0 shadowed, 1 in the open; clamped to [0, 1]) for lights 0..3;
// lights beyond the fourth, if SH_MAX_LIGHTS is raised, count as visible. 1 where the
// denominator is <= 0 (no light to block), so the result is always in [0, 1].
vec3 shShadowRatio(vec3 n, vec4 visibility) {
    return shShadowRatioOccluded(n, visibility, vec3(0.0));   // nothing occluded: E_a stays
}
