"""The reflection cube as glTF ``EXT_lights_image_based`` images, read the way Babylon.js
reads them (no file I/O: PNG bytes in memory; docs/contract.md §12 "Consumers").

Citations are ``repository path:lines`` at the revisions of
:data:`provider.core.conventions.notes.REVISIONS`:

* **What the extension stores**: ``specularImages`` is an N×6 array of glTF image indices,
  mip-major, faces ``+X −X +Y −Y +Z −Z``; ``specularImageSize`` is the edge of mip 0
  (glTF extensions/2.0/Vendor/EXT_lights_image_based/README.md:30-49, 55, 57-63, 126-127);
  each image flipped to glTF's texture space (:70); a 4-channel PNG holds RGBD (:83-97,
  Babylon's encoding); scenes pick the light by index (:104-116).
* **How Babylon reads it** (loaders EXT_lights_image_based.pure.ts:92-148): every face's
  bytes, then ``RawCubeTexture.updateRGBDAsync(imageData, sphericalPolynomial,
  lodGenerationScale = (mips − 1) / log2(specularImageSize))`` (:147-148). Each PNG is
  decoded as a texture with ``invertY`` true (core environmentTextureTools.pure.ts:610-621,
  or :809-810 without float render targets), so its BOTTOM row becomes the face's storage row
  0 (t = 0 of the OpenGL cube-map table); ``fromRGBD`` gives ``pow(rgb, 2.2) / a``
  (helperFunctions.ts:105, rgbdDecode.fragment.ts:10). Levels beyond those given are black
  (environmentTextureTools.pure.ts:903-927).
* **Which direction a texel is**: the PBR shader looks the cube up with the world reflection
  vector (pbrBlockReflection.ts:37-43), z negated in a right-handed scene
  (materialHelper.functions.ts:931, ``REFLECTIONMAP_OPPOSITEZ``). A default, left-handed
  scene loads the glTF asset under a root node that maps glTF (x, y, z) to (−x, y, z)
  (glTFLoader.pure.ts:762-768). So the texel that Babylon looks up toward ``r`` must hold our
  radiance toward ``M r``: M = diag(−1, 1, 1) (left-handed scene), diag(1, 1, −1)
  (right-handed): the same mirrors, and the same half turn about +Y between the two, as the
  SH9 part (:mod:`provider.core.conventions.formats`).
* **Which roughness a mip is**: the shader's LOD is
  ``log2(size · α) · lodGenerationScale + lodGenerationOffset`` with α = roughness² (+5e-4)
  (pbrIBLFunctions.ts:5, pbrBlockReflection.ts:92-95, pbrHelperFunctions.ts:4, 9-10;
  materialHelper.functions.ts:353 passes size, scale, offset), and Babylon's own prefilter
  writes mip k ≥ 1 at α = 2^(k / scale) / size and mip 0 unfiltered (hdrFiltering.ts:127-130).
  With the loader's scale, mip k of K is GGX-prefiltered at α_k = size^(k/(K−1) − 1):
  :func:`babylon_roughness`. (The extension's README says the mips "evenly map to roughness
  values from 0 to 1" (:53); Babylon, its only reader, does not; this follows Babylon.)

RGBD covers 0 … 255 in the cube's units with ``intensity`` 1 (Babylon multiplies the SH by
``intensity`` twice, once in the loader (:141) and once as the texture level, so any other
value would make its diffuse disagree with the extension's own reading); brighter texels are
clipped and counted (``specular_clipped_texels``).
"""
from __future__ import annotations

import base64
import math

import cv2
import numpy as np

from ..geometry import cubemap
from ..errors import InputError

#: Babylon's RGBD range (helperFunctions.ts:104 ``rgbdMaxRange``) and gamma (:5).
RGBD_MAX_RANGE = 255.0
GAMMA = 2.2
#: The mirror between a direction Babylon looks the cube up with and ours, per scene handedness.
LOOKUP_TO_OURS = {"left": np.array([-1.0, 1.0, 1.0]), "right": np.array([1.0, 1.0, -1.0])}


def babylon_roughness(size: int, mips: int | None = None) -> list:
    """Perceptual roughness Babylon.js reads mip k of a ``size``² EXT_lights_image_based cube
    of ``mips`` levels at (default: down to 2×2): 0 for mip 0 (unfiltered, as Babylon's own
    prefilter writes it), sqrt(size^(k/(mips−1) − 1)) for k ≥ 1 (module docstring).

    Size 32, 5 mips: 0, 0.273, 0.420, 0.648, 1."""
    size = cubemap.check_size(size)
    mips = len(cubemap.mip_sizes(size)) if mips is None else int(mips)
    if mips < 2:
        raise InputError("an EXT_lights_image_based cube needs at least 2 mips")
    return [0.0] + [math.sqrt(size ** (k / (mips - 1) - 1.0)) for k in range(1, mips)]


def remap_faces(cube: np.ndarray, handedness: str = "left") -> np.ndarray:
    """(6, n, n, C) in our layout → the same texels as Babylon looks them up: texel [f, i, j]
    of the result holds ours toward ``M · d(f, i, j)`` (module docstring). An exact
    permutation of texels (mirrors map texel centres onto texel centres)."""
    if handedness not in LOOKUP_TO_OURS:
        raise InputError(f"babylon_handedness must be 'left' or 'right', got {handedness!r}")
    n = cube.shape[1]
    dirs = cubemap.texel_directions(n) * LOOKUP_TO_OURS[handedness]
    face, i, j, _, _ = cubemap.direction_to_texel(dirs, n)
    return cube[face, i, j]


def rgbd_encode(rgb: np.ndarray) -> tuple[np.ndarray, int]:
    """(..., 3) linear radiance → (..., 4) uint8 RGBD as Babylon's ``toRGBD`` writes it
    (helperFunctions.ts:104): D = min(floor(255 / max(r, g, b)), 255) / 255 (at least 1/255),
    rgb = (colour · D)^(1/2.2); returns the bytes and how many texels were clipped (max > 255)."""
    c = np.maximum(np.asarray(rgb, np.float64), 0.0)
    peak = np.maximum(c.max(axis=-1), 1e-7)
    d = np.clip(np.floor(np.maximum(RGBD_MAX_RANGE / peak, 1.0)), 1.0, 255.0) / 255.0
    g = np.clip(c * d[..., None], 0.0, 1.0) ** (1.0 / GAMMA)
    out = np.empty(c.shape[:-1] + (4,), np.uint8)
    out[..., :3] = np.rint(g * 255.0)
    out[..., 3] = np.rint(d * 255.0)
    return out, int(np.count_nonzero(peak > RGBD_MAX_RANGE))


def face_png(face_rgbd: np.ndarray) -> bytes:
    """One (n, n, 4) RGBD face in storage order (row 0 = t = 0) as PNG bytes: the rows
    reversed, because Babylon decodes the image with invertY (module docstring)."""
    bgra = np.ascontiguousarray(face_rgbd[::-1][..., [2, 1, 0, 3]])
    ok, data = cv2.imencode(".png", bgra)
    if not ok:
        raise InputError("PNG encoding failed")
    return data.tobytes()


def specular_images(mips, handedness: str = "left") -> dict:
    """The ``specularImages`` of an EXT_lights_image_based light from a cube's mips (our
    layout, (6, n_k, n_k, 3) each, already prefiltered at :func:`babylon_roughness`).

    Returns ``images`` (glTF image objects: PNG data URIs, in mip-major, face order),
    ``specularImages`` (K×6 indices into ``images``), ``specularImageSize``, and
    ``specular_clipped_texels`` (texels above the RGBD range, clipped)."""
    if not mips:
        raise InputError("a cube needs at least one mip")
    size = int(np.shape(mips[0])[1])
    images, index, clipped = [], [], 0
    for k, mip in enumerate(mips):
        mip = np.asarray(mip)
        if mip.shape != (6, size >> k, size >> k, 3):
            raise InputError(f"mip {k} must have shape (6, {size >> k}, {size >> k}, 3), "
                             f"got {mip.shape}")
        rgbd, c = rgbd_encode(remap_faces(mip, handedness))
        clipped += c
        row = []
        for f in range(6):
            row.append(len(images))
            data = base64.b64encode(face_png(rgbd[f])).decode("ascii")
            images.append({"name": f"shlight-specular-{k}-{cubemap.FACE_NAMES[f]}",
                           "mimeType": "image/png", "uri": "data:image/png;base64," + data})
        index.append(row)
    return {"images": images, "specularImages": index, "specularImageSize": size,
            "specular_clipped_texels": clipped}


def document(light: dict, images: list) -> dict:
    """A complete glTF 2.0 asset holding only the image-based light (``light`` with its
    ``specularImages`` indexing ``images``): load it in Babylon.js and the scene's
    ``environmentTexture`` is the cube (EXT_lights_image_based.pure.ts:60-76)."""
    return {"asset": {"version": "2.0", "generator": "shlight export"},
            "extensionsUsed": ["EXT_lights_image_based"],
            "extensions": {"EXT_lights_image_based": {"lights": [light]}},
            "images": images, "scene": 0,
            "scenes": [{"nodes": [], "extensions": {"EXT_lights_image_based": {"light": 0}}}]}
