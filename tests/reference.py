"""Float64 brute-force references, written independently of provider/ (tests only)."""
import math

import numpy as np

# Real SH basis, docs/contract.md §1, written out again so a slip in provider.core.geometry.sh cannot cancel out.
def basis(d):
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    return np.stack([
        np.full_like(x, 0.282095), 0.488603 * y, 0.488603 * z, 0.488603 * x,
        1.092548 * x * y, 1.092548 * y * z, 0.315392 * (3 * z * z - 1),
        1.092548 * x * z, 0.546274 * (x * x - y * y)], axis=-1)


A_HAT = np.array([math.pi] + [2 * math.pi / 3] * 3 + [math.pi / 4] * 5)


def equirect_directions(width, height):
    v = (np.arange(height) + 0.5) / height
    u = (np.arange(width) + 0.5) / width
    theta = np.pi * v[:, None]
    phi = 2 * np.pi * (u[None, :] - 0.5)
    return np.stack(np.broadcast_arrays(np.sin(phi) * np.sin(theta), np.cos(theta),
                                        -np.cos(phi) * np.sin(theta)), axis=-1)


def equirect_solid_angle(width, height):
    """Exact per-pixel solid angle: Δφ (cos θ_top − cos θ_bottom)."""
    edges = np.pi * np.arange(height + 1) / height
    rows = (2 * np.pi / width) * (np.cos(edges[:-1]) - np.cos(edges[1:]))
    return np.repeat(rows[:, None], width, axis=1)


def project_equirect(image):
    """Σ_pixels L · Y(centre) · dω with negative and non-finite samples set to 0."""
    img = np.asarray(image, np.float64)
    img = np.where(np.isfinite(img) & (img > 0), img, 0.0)
    h, w = img.shape[:2]
    yw = basis(equirect_directions(w, h)) * equirect_solid_angle(w, h)[..., None]
    return np.einsum("hwk,hwc->kc", yw, img)


def fibonacci(n):
    i = np.arange(n) + 0.5
    y = 1 - 2 * i / n
    r = np.sqrt(1 - y * y)
    phi = math.pi * (3 - math.sqrt(5)) * i
    return np.stack([r * np.cos(phi), y, r * np.sin(phi)], -1)


NORMALS = fibonacci(1000)


def sh_irradiance(coeffs, normals=NORMALS):
    return basis(normals) @ (A_HAT[:, None] * np.asarray(coeffs, np.float64))


def brute_irradiance(image, normals=NORMALS):
    """E(n) = Σ_pixels L max(0, n·ω) dω, straight from the pixels (no SH at all)."""
    img = np.asarray(image, np.float64)
    img = np.where(np.isfinite(img) & (img > 0), img, 0.0)
    h, w = img.shape[:2]
    d = equirect_directions(w, h).reshape(-1, 3)
    dw = equirect_solid_angle(w, h).reshape(-1)
    return (np.maximum(normals @ d.T, 0) * dw) @ img.reshape(-1, 3)


def rel_rms(a, b):
    return float(np.sqrt(np.mean((np.asarray(a) - b) ** 2)) / np.sqrt(np.mean(np.asarray(b) ** 2)))


def render_equirect(env, width, height, supersample=1):
    """Render env(directions (...,3)) -> (..., 3) radiance into an equirect image,
    averaging supersample² samples per pixel."""
    s = supersample
    d = equirect_directions(width * s, height * s)
    img = env(d)
    return img.reshape(height, s, width, s, -1).mean(axis=(1, 3))
