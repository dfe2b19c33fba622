"""Float64 brute-force references for the reflection cube, written independently of
provider/ (tests and the bench's error figures only): the cube layout of docs/contract.md §12
written out again, the texel means by super-sampling the panorama, and the GGX prefiltered
radiance PF (n = v = r) by direct summation over every panorama pixel."""
import math

import numpy as np

from reference import equirect_directions, equirect_solid_angle


def cube_directions(n):
    """(6, n, n, 3) texel centres: face order +X -X +Y -Y +Z -Z, texel [f, i, j] at
    s = (j+½)/n, t = (i+½)/n, OpenGL table (sc, tc, ma) read in our frame."""
    c = (np.arange(n) + 0.5) / n * 2 - 1
    tc, sc = np.meshgrid(c, c, indexing="ij")
    one = np.ones_like(sc)
    faces = [
        np.stack([one, -tc, -sc], -1),     # +X: sc = -z, tc = -y
        np.stack([-one, -tc, sc], -1),     # -X: sc = +z, tc = -y
        np.stack([sc, one, tc], -1),       # +Y: sc = +x, tc = +z
        np.stack([sc, -one, -tc], -1),     # -Y: sc = +x, tc = -z
        np.stack([sc, -tc, one], -1),      # +Z: sc = +x, tc = -y
        np.stack([-sc, -tc, -one], -1),    # -Z: sc = -x, tc = -y
    ]
    d = np.stack(faces)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def texel_of(d, n):
    """Flat texel index of directions (..., 3) on an n × n cube (same table)."""
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ax, ay, az = np.abs(x), np.abs(y), np.abs(z)
    face = np.where((ax >= ay) & (ax >= az), np.where(x > 0, 0, 1),
                    np.where(ay >= az, np.where(y > 0, 2, 3), np.where(z > 0, 4, 5)))
    sc = np.choose(face, [-z / ax, z / ax, x / ay, x / ay, x / az, -x / az])
    tc = np.choose(face, [-y / ax, -y / ax, z / ay, -z / ay, -y / az, -y / az])
    j = np.clip(((sc + 1) / 2 * n).astype(int), 0, n - 1)
    i = np.clip(((tc + 1) / 2 * n).astype(int), 0, n - 1)
    return (face * n + i) * n + j


def texel_means(image, n, supersample=8):
    """(6, n, n, 3): each texel's solid-angle-weighted mean radiance of an equirect image
    (constant over each pixel), by super-sampling every pixel s × s."""
    h, w = image.shape[:2]
    d = equirect_directions(w * supersample, h * supersample)
    omega = equirect_solid_angle(w * supersample, h * supersample)
    omega = np.broadcast_to(omega, d.shape[:2])
    rows = np.arange(h * supersample) // supersample
    cols = np.arange(w * supersample) // supersample
    px = image[rows][:, cols].reshape(-1, 3).astype(np.float64)
    t = texel_of(d, n).reshape(-1)
    om = omega.reshape(-1)
    area = np.bincount(t, weights=om, minlength=6 * n * n)
    out = np.stack([np.bincount(t, weights=om * px[:, c], minlength=6 * n * n)
                    for c in range(3)], -1) / area[:, None]
    return out.reshape(6, n, n, 3), area.reshape(6, n, n)


def ggx_kernel_explicit(r, l, roughness):
    """D(h) <r·l> with the half vector h = (r + l)/|r + l| formed explicitly, α = ρ²: the
    definition as written, to prove the shortcut :func:`prefiltered` takes."""
    a2 = roughness ** 4
    h = r + l
    nh = np.einsum("...k,...k->...", h, r) / np.linalg.norm(h, axis=-1)
    d = a2 / (math.pi * (nh * nh * (a2 - 1) + 1) ** 2)
    return d * np.maximum(np.einsum("...k,...k->...", r, l), 0)


def prefiltered(image, directions, roughness, chunk=8):
    """PF(r) = ∫ L D(h) <r·l> dl / ∫ D(h) <r·l> dl at unit directions (..., 3), α = ρ²,
    summed over every pixel of an equirect image (pixel centres, exact solid angles).

    With n = v = r, (r·h)² = (1 + r·l)/2 (|r + l|² = 2 + 2 r·l), so D's denominator is
    A + B r·l with A = (1 + α²)/2, B = (α² − 1)/2: one product r·l per pair, then a few
    float64 passes in chunks that stay in cache (tests/core/reflections/test_environment.py checks the
    shortcut against :func:`ggx_kernel_explicit`)."""
    h, w = image.shape[:2]
    lt = np.ascontiguousarray(equirect_directions(w, h).reshape(-1, 3).T)
    om = np.broadcast_to(equirect_solid_angle(w, h), (h, w)).reshape(-1)
    # the solid angles go into the right-hand side: Σ k ω L and Σ k ω in one product
    rhs = np.concatenate([image.reshape(-1, 3).astype(np.float64) * om[:, None],
                          om[:, None]], axis=1)
    a2 = roughness ** 4
    A, B = (1 + a2) / 2, (a2 - 1) / 2
    r = directions.reshape(-1, 3)
    out = np.empty((len(r), 3))
    for k in range(0, len(r), chunk):
        rl = r[k:k + chunk] @ lt
        den = A + B * rl
        den *= den
        np.maximum(rl, 0, out=rl)
        rl /= den                      # D(h) <r·l> up to the constant α²/π, which cancels
        s = rl @ rhs
        out[k:k + chunk] = s[:, :3] / s[:, 3:]
    return out.reshape(directions.shape[:-1] + (3,))


def rel_rms(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b ** 2)))
