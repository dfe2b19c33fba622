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

// Each light's visibility past an occluding sphere (docs/contract.md §10,
// provider/core/lights/shadows.py sphere_light_visibility). Angular radius of lights 0..3, in
// radians (the wire's light_angular_radius_deg × π/180; 0: a point light):
uniform vec4 shLightAngularRadius;

// The segment of a cap of half-angle x cut off by a great circle whose chord subtends c at the
// cap's axis, in units of sin²(x/2): the sector 2c less the isosceles spherical triangle.
// Below c = 0.5 the two nearly cancel (a sun's sliver of a wide sphere), and a GPU's atan is
// good to ~1e-4 only: there their difference's series, (1 − s2)(1 − 2 s2) c³ (1/3 −
// (1 − 12q) c²/60 + (1 − 60q + 360q²) c⁴/2520), q = s2(1 − s2), next term < 2e-5 of it.
float shCapSegment(float x, float c) {
    float s2 = sin(0.5 * x); s2 *= s2;
    if (c < 0.5) {
        float q = s2 * (1.0 - s2), cc = c * c;
        return (1.0 - s2) * (1.0 - 2.0 * s2) * cc * c * (1.0 / 3.0 - (1.0 - 12.0 * q) * cc / 60.0
               + (1.0 - 60.0 * q + 360.0 * q * q) * cc * cc / 2520.0);
    }
    float tri = s2 > 0.0 ? atan(s2 * sin(c), (1.0 - s2) + s2 * cos(c)) / s2 : sin(c);
    return 2.0 * c - 2.0 * tri;
}

// The half-angle at the axis of a cap of radius x between the other cap's axis (radius y,
// axes g apart, gx = g − x given apart) and a point where the rims cross, from half-angle
// sines (a 0.27° sun keeps its digits in float32).
float shCapHalfChord(float x, float y, float g, float gx) {
    float den = sin(x) * sin(g);
    float c = 1.0 + 2.0 * sin(0.5 * (gx + y)) * sin(0.5 * (gx - y)) / (den > 0.0 ? den : 1.0);
    return acos(clamp(c, -1.0, 1.0));
}

// The share of a light's disc (cap of angular radius a, radians) that a cap of half-angle
// alpha whose axis is g away covers: Ω(cap_a ∩ cap_α) / Ω(cap_a) (Mazonka 2012), in [0, 1].
// delta = g − alpha, computed by the caller without subtracting the two (a sun's disc is
// 0.0047 rad wide; a GPU's asin and atan are good to ~1e-4 of the angle only).
float shCapOverlapFraction(float a, float alpha, float g, float delta) {
    if (a <= 0.0) return delta < 0.0 ? 1.0 : 0.0;         // a point light
    if (delta >= a) return 0.0;                            // apart
    if (delta <= -a) return 1.0;                           // the disc inside the sphere
    float sa = sin(0.5 * a), sal = sin(0.5 * alpha);
    float areaRatio = (sal * sal) / (sa * sa);             // Ω(cap_α) / Ω(cap_a)
    if (g <= a - alpha) return min(areaRatio, 1.0);        // the sphere inside the disc
    float lens = shCapSegment(a, 2.0 * shCapHalfChord(a, alpha, g, delta + alpha - a))
               + areaRatio * shCapSegment(alpha, 2.0 * shCapHalfChord(alpha, a, g, delta));
    return clamp(lens / (4.0 * 3.14159265358979), 0.0, 1.0);
}

// The unoccluded fraction of a light's uniform disc (toward unit lightDirection, angular
// radius angularRadius in radians) seen from point p behind a sphere (xyz: centre, w: radius,
// p's frame): 1 − Ω(disc ∩ sphere's cap)/Ω(disc). sphere.w <= 0 (no occluder): 1; p inside
// the sphere (|c − p| <= R): 0.
float shSphereLightVisibility(vec3 p, vec4 sphere, vec3 lightDirection, float angularRadius) {
    if (sphere.w <= 0.0) return 1.0;
    vec3 toCentre = sphere.xyz - p;
    float dist = length(toCentre);
    if (dist <= sphere.w) return 0.0;
    vec3 d = toCentre / dist;
    float sinG = length(cross(d, lightDirection)), cosG = dot(d, lightDirection);
    float sinAlpha = sphere.w / dist, cosAlpha = sqrt((dist - sphere.w) * (dist + sphere.w)) / dist;
    float delta = atan(sinG * cosAlpha - cosG * sinAlpha, cosG * cosAlpha + sinG * sinAlpha);
    return 1.0 - shCapOverlapFraction(max(angularRadius, 0.0), atan(sinAlpha, cosAlpha),
                                       atan(sinG, cosG), delta);
}

// shSphereLightVisibility for lights 0..3 of the uniforms (shLightDirection,
// shLightAngularRadius); slots at or beyond shLightCount get 1. A visibility for
// shShadowRatio / shShadowRatioOccluded, e.g. with lights 1..3 from here and light 0 from
// the engine's shadow map.
vec4 shSphereLightsVisibility(vec3 p, vec4 sphere) {
    vec4 v = vec4(1.0);
    for (int i = 0; i < 4; ++i) {
        if (i >= shLightCount) break;
        v[i] = shSphereLightVisibility(p, sphere, shLightDirection[i].xyz, shLightAngularRadius[i]);
    }
    return v;
}
