"""The docs pictures of each reflection consumer (README "Reflections", issue 20.7): a mirror, a
glossy and a rough sphere as the consumer shows them (top row) above the provider's own
reference for the same spheres (bottom row).

Every sphere is a white metal (F0 = 1) seen from our +Z by an orthographic camera (±1.05, as
tests/envtools.py SPHERE_VIEW's three.js camera): pixel (row i, column j) of a size² tile is
x = (j + ½)/size·2.1 − 1.05, y = 1.05 − (i + ½)/size·2.1, normal (x, y, √(1 − x² − y²)),
V = +Z, R = reflect(−V, N), all in the wire frame (right-handed, +Y up).

The reference: the prefiltered radiance PF(R, ρ) of the panorama, brute force at exactly ρ
(:func:`provider_reference`), which
is what a white metal with energy compensation (F0 = 1, single + multiple scattering = 1, as
three's MeshStandardMaterial) shows; the other consumers' pictures show the radiance they
read the same way. Display: linear →
sRGB, clipped at 1, no tone mapping (as the three.js pictures). Written to docs/ only when
SHLIGHT_DOCS_SCREENSHOT is set (tests/clients/three/test_three_environment.py's pattern).

"""
from __future__ import annotations

import os
from pathlib import Path

import cv2
import numpy as np

import reference_cube as ref
from provider.verify import cubemap
from provider.verify.render import srgb_encode

ROOT = Path(__file__).resolve().parent.parent
#: Perceptual roughness of the mirror, glossy and rough spheres (as docs/three_environment_*.png).
ROUGHNESS = (0.0, 0.35, 0.75)
#: Tile edge in pixels and the orthographic camera's half extent.
SIZE, EXTENT = 160, 1.05
LABEL_HEIGHT = 22
#: Face edge of the brute-force reference cube (texels of 3.75°).
REFERENCE_CUBE = 24


def wanted() -> bool:
    """Whether this run writes the docs pictures."""
    return bool(os.environ.get("SHLIGHT_DOCS_SCREENSHOT"))


def ortho_sphere(size: int = SIZE):
    """(normals (S, S, 3), mask (S, S)) of the unit sphere seen from +Z (module docstring)."""
    c = ((np.arange(size) + 0.5) / size * 2 - 1) * EXTENT
    y, x = np.meshgrid(-c, c, indexing="ij")
    r2 = x * x + y * y
    mask = r2 < 1.0
    n = np.stack([x, y, np.sqrt(np.maximum(1 - r2, 0))], -1)
    return n, mask


def reflections(normals) -> np.ndarray:
    """R = reflect(−V, N) with V = +Z, (…, 3)."""
    return 2 * normals[..., 2:3] * normals - np.array([0, 0, 1.0])


def provider_reference(panorama: np.ndarray, roughness: float, size: int = SIZE):
    """(linear image (S, S, 3), mask): PF(R, ρ) on the sphere. The mirror (ρ = 0): the
    provider's 64² mip 0 (its radiance, :class:`provider.core.reflections.environment.EnvironmentProjector`);
    ρ > 0: the brute-force GGX prefilter of the panorama (tests/reference_cube.py
    ``prefiltered``, every pixel of a 256×128 area-resampled copy) at the texel centres of a
    REFERENCE_CUBE² cube, read bilinear and seamless."""
    n, mask = ortho_sphere(size)
    if roughness == 0:
        from provider.core.reflections.environment import EnvironmentProjector
        h, w = panorama.shape[:2]
        mip = EnvironmentProjector(w, h, size=64).project(panorama).mips[0]
    else:
        small = cv2.resize(np.maximum(np.nan_to_num(panorama), 0), (256, 128),
                           interpolation=cv2.INTER_AREA)
        mip = ref.prefiltered(small, ref.cube_directions(REFERENCE_CUBE), roughness)
    img = np.zeros((size, size, 3))
    img[mask] = cubemap.sample([mip], reflections(n[mask]), 0.0)[:, :3]
    return img, mask


def srgb_tile(linear, mask) -> np.ndarray:
    """(S, S, 4) uint8 RGBA: sRGB, clipped, transparent outside the sphere."""
    rgb = np.round(srgb_encode(linear) * 255).astype(np.uint8)
    return np.dstack([rgb, np.where(mask, 255, 0).astype(np.uint8)])


def _strip(text: str, width: int) -> np.ndarray:
    strip = np.full((LABEL_HEIGHT, width, 4), 255, np.uint8)
    cv2.putText(strip, text, (6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (40, 40, 40, 255), 1,
                cv2.LINE_AA)
    return strip


def compose(rows) -> np.ndarray:
    """``rows``: [(label, [RGBA tile per roughness])] → one RGBA picture, each row under its label."""
    parts = []
    for label, tiles in rows:
        strip = np.hstack([np.asarray(t, np.uint8) for t in tiles])
        parts += [_strip(label, strip.shape[1]), strip]
    return np.vstack(parts)


def write(name: str, picture: np.ndarray) -> Path:
    """docs/NAME.png (RGBA on white, so the labels read on any page)."""
    rgb = picture[..., :3].astype(np.float64)
    a = picture[..., 3:].astype(np.float64) / 255
    flat = np.round(rgb * a + 255 * (1 - a)).astype(np.uint8)
    path = ROOT / "docs" / f"{name}.png"
    assert cv2.imwrite(str(path), cv2.cvtColor(flat, cv2.COLOR_RGB2BGR),
                       [cv2.IMWRITE_PNG_COMPRESSION, 9])
    return path


def relative_error(shown, reference, mask) -> np.ndarray:
    """Per sphere pixel: max over channels |shown − reference| / max(|reference|, 5 % of its
    largest value) (tests/clients/three/test_three_environment.py's measure)."""
    s, r = shown[mask], reference[mask]
    err = np.abs(s - r).max(axis=1)
    return err / np.maximum(np.abs(r).max(axis=1), 0.05 * np.abs(r).max())
