#version 330 core
// Demo fragment shader with lights: a Lambertian surface of albedo ρ lit by the ambient SH9
// and the directional lights of docs/contract.md §10 shows radiance ρ·E(n)/π with
// E(n) = ñᵀAñ + Σ_k I_k max(0, n·d_k). Upload the message's "ambient_matrices" as
// shIrradianceR/G/B and its lights (see sh9_lights.glsl). Same outputs as lit_diffuse.frag.
#include "sh9_irradiance.glsl"
#include "sh9_lights.glsl"

uniform vec3 albedo;       // linear reflectance ρ per channel, 0..1
uniform float exposure;    // linear scale applied to the radiance before tone mapping
uniform int toneMap;       // 0: none (clip), 1: Reinhard x/(1+x), 2: ACES (Narkowicz 2015 fit)
uniform bool srgbOutput;   // true: encode sRGB for an 8-bit target without GL_FRAMEBUFFER_SRGB

in vec3 worldNormal;
out vec4 fragColor;

const float PI = 3.14159265358979;

vec3 toneMapped(vec3 x) {
    x = max(x, vec3(0.0));
    if (toneMap == 1) return x / (1.0 + x);
    if (toneMap == 2) return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
    return x;
}

vec3 srgbEncoded(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

void main() {
    vec3 n = normalize(worldNormal);
    vec3 radiance = albedo * shIrradianceWithLights(n) / PI;   // ρE/π
    vec3 c = toneMapped(radiance * exposure);
    fragColor = vec4(srgbOutput ? srgbEncoded(c) : c, 1.0);
}
