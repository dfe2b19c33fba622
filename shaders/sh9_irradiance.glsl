// SH9 diffuse irradiance, E(n) = ñᵀ M ñ with ñ = (n, 1)  (docs/contract.md §2, Ramamoorthi & Hanrahan 2001).
// Include after your #version line; this file has none on purpose.
//
// shIrradianceR/G/B: the three symmetric 4×4 irradiance matrices from the wire message
// ("matrices": 48 numbers, M_red, M_green, M_blue). M is symmetric, so uploading it row- or
// column-major gives the same matrix. Frame: right-handed, +Y up (the wire frame).
// A Lambertian surface of albedo ρ shows radiance ρ·E/π.
uniform mat4 shIrradianceR;
uniform mat4 shIrradianceG;
uniform mat4 shIrradianceB;

// Irradiance before clamping (can be negative where order-2 SH rings).
vec3 shIrradianceUnclamped(vec3 n) {
    vec4 nh = vec4(n, 1.0);
    return vec3(dot(nh, shIrradianceR * nh),
                dot(nh, shIrradianceG * nh),
                dot(nh, shIrradianceB * nh));
}

// Irradiance at unit normal n, clamped at zero (SH9 ringing must never make negative light).
vec3 shIrradiance(vec3 n) {
    return max(shIrradianceUnclamped(n), vec3(0.0));
}
