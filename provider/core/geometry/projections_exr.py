"""OpenEXR's own environment maps (the ``envmap`` header attribute), in OpenEXR's conventions.

OpenEXR (``src/lib/OpenEXR/ImfEnvmap.cpp``, https://github.com/AcademySoftwareFoundation/openexr)
defines two layouts; its pixel positions are pixel *centres* (integers), and both layouts put
the centres of the outermost pixels exactly on the map's edges:

* **latlong** (``ENVMAP_LATLONG``): for a data window of W × H pixels, the centre of pixel
  (x, y) looks along ``(sin λ cos φ, sin φ, cos λ cos φ)`` with latitude
  ``φ = −π (y/(H−1) − ½)`` (the top row looks straight up) and longitude
  ``λ = −2π (x/(W−1) − ½)`` (the centre column looks along +Z, the first and last columns both
  along −Z). Not shlight's equirect, whose centre looks along −Z and whose pixels are cells.
* **cube** (``ENVMAP_CUBE``): six square faces of N × N stacked vertically, +X −X +Y −Y +Z −Z;
  in face f, ``positionInFace`` (px, py) ∈ [0, N−1]² maps to ``a = px/(N−1)·2 − 1``,
  ``b = py/(N−1)·2 − 1`` and the direction (±1, a, b), (a, ±1, b), (a, b, ±1); the file pixel
  of a position is face-dependent (``CubeMap::pixelPosition``: +X (x, y) = (py, N−1−px), …).

Directions are taken as they are, in shlight's frame (+Y up, docs/contract.md §1). Pixel
``(i, j)`` of shlight covers ``[i, i+1) × [j, j+1)``, so OpenEXR's position is ``p − ½``: the
outer half of every edge pixel lies beyond the map and is not counted (even Gauss-Legendre
nodes split each pixel in two exactly), and the sphere is covered once.
"""
from __future__ import annotations

import numpy as np

from .projections import PROJECTIONS, Projection, ProjectionError, _gauss_legendre

#: The ``envmap`` attribute's values (ImfEnvmap.h: ENVMAP_LATLONG = 0, ENVMAP_CUBE = 1).
ENVMAP_NAMES = {0: "exr-latlong", 1: "exr-cube"}


class ExrLatLong(Projection):
    """An OpenEXR latlong environment map (``envmap`` = LATLONG), any W × H ≥ 2 × 2."""

    name = "exr-latlong"
    nodes_per_axis = 2      # even: the half of an edge pixel beyond the map is split off exactly

    def __init__(self, width, height):
        super().__init__(width, height)
        if width < 2 or height < 2:
            raise ProjectionError(f"an OpenEXR latlong map needs at least 2×2 pixels; got "
                                  f"{width}×{height}")
        self.full, self.factor = (width, height), 1   # the file's size; pixels per pixel

    def pixel_to_direction(self, px, py):
        (w, h), k = self.full, self.factor
        lat = -np.pi * ((np.asarray(py, np.float64) * k - 0.5) / (h - 1) - 0.5)
        lon = -2 * np.pi * ((np.asarray(px, np.float64) * k - 0.5) / (w - 1) - 0.5)
        d = np.stack([np.sin(lon) * np.cos(lat), np.sin(lat), np.cos(lon) * np.cos(lat)], -1)
        valid = (np.abs(lat) <= np.pi / 2) & (np.abs(lon) <= np.pi)
        return d, valid

    def scaled(self, factor):
        return _scaled(self, factor)

    def quadrature(self):
        return _file_pixel_quadrature(self)


class ExrCube(Projection):
    """An OpenEXR cube environment map (``envmap`` = CUBE): six N × N faces stacked
    vertically (N × 6N), +X −X +Y −Y +Z −Z."""

    name = "exr-cube"
    nodes_per_axis = 2

    def __init__(self, width, height):
        super().__init__(width, height)
        if height != 6 * width or width < 2:
            raise ProjectionError(f"an OpenEXR cube map is six square faces stacked vertically "
                                  f"(height = 6 × width, faces of at least 2 px); got "
                                  f"{width}×{height}")
        self.face, self.factor = width, 1

    def pixel_to_direction(self, px, py):
        # (central differences never straddle two faces: the nodes sit at 0.21 and 0.79 of a
        # pixel, faces meet at whole rows)
        n, k = self.face, self.factor
        x = np.asarray(px, np.float64) * k - 0.5
        y_all = np.asarray(py, np.float64) * k - 0.5
        f = np.clip(np.floor(np.asarray(py, np.float64) * k / n), 0, 5).astype(int)
        y = y_all - f * n                      # file row inside the face, 0 … N−1
        last = n - 1.0
        # positionInFace from the file pixel: the inverse of CubeMap::pixelPosition
        pif = [(last - y, x), (last - y, last - x), (x, last - y), (x, y),
               (last - x, last - y), (x, last - y)]
        d = np.zeros(x.shape + (3,))
        valid = np.zeros(x.shape, bool)
        for i, (u, v) in enumerate(pif):
            a, b = u / last * 2 - 1, v / last * 2 - 1
            one = np.ones_like(a)
            sign = 1.0 if i % 2 == 0 else -1.0
            vec = [np.stack([sign * one, a, b], -1), np.stack([a, sign * one, b], -1),
                   np.stack([a, b, sign * one], -1)][i // 2]
            sel = f == i
            d = np.where(sel[..., None], vec, d)
            valid |= sel & (np.abs(a) <= 1) & (np.abs(b) <= 1)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        return d, valid

    def scaled(self, factor):
        return _scaled(self, factor)

    def quadrature(self):
        return _file_pixel_quadrature(self)


def _file_pixel_quadrature(p):
    """The quadrature of a map area-averaged by ``p.factor`` = k: the small pixel split where
    the map's edges can fall in it (half a file pixel from either side: the centres of the
    map's outermost pixels), so the outer half of an edge pixel, beyond the map, is split
    off exactly at every --downsample as at full size (one set of nodes per small pixel
    counted it as seen: a 64² cube at --downsample 4 came to 12.8 sr). One node in each
    half-pixel sliver, two Gauss-Legendre nodes between: 4 a side."""
    nodes, gw = _gauss_legendre(p.nodes_per_axis)
    k = p.factor
    if k == 1:
        return nodes, gw
    edge, middle = 0.5 / k, 1 - 1 / k
    return (np.concatenate([[edge / 2], edge + nodes * middle, [1 - edge / 2]]),
            np.concatenate([[edge], gw * middle, [edge]]))


def whole_face_factor(p, factor: int) -> int:
    """The largest area-averaging factor up to ``factor`` whose blocks never straddle two
    faces of an OpenEXR cube ``p`` (faces stacked +X above −X look opposite ways); any
    other projection: ``factor``."""
    if isinstance(p, ExrCube):
        while factor > 1 and p.face % (p.factor * factor):
            factor -= 1
    return factor


def check_cube_downsample(cube: ExrCube, factor: int) -> None:
    """``--downsample factor`` of an OpenEXR cube: refused (ProjectionError) unless it divides
    the faces' side, since a downsampled pixel would average two faces, pixels that look
    90° apart, and the rows and columns beyond the last whole block would be dropped."""
    if factor > 1 and cube.face % factor:
        divisors = [k for k in range(2, min(cube.face, 64) + 1) if cube.face % k == 0][:6]
        hint = (f"give one that divides {cube.face} ({', '.join(map(str, divisors))}, …)"
                if divisors else "leave --downsample out")
        raise ProjectionError(f"--downsample {factor} does not divide the OpenEXR cube's "
                              f"{cube.face}-pixel faces: its pixels would average two faces "
                              f"together; {hint}")


def _scaled(p, factor: int):
    """The same map area-averaged by ``factor`` (the engine's --downsample and its error
    estimate): each pixel covers factor × factor pixels of the file."""
    if p.width // factor < 1 or p.height // factor < 1:
        raise ProjectionError(f"--downsample {factor} is larger than the OpenEXR map")
    q = p.__class__.__new__(p.__class__)
    Projection.__init__(q, p.width // factor, p.height // factor)
    q.__dict__.update({k: v for k, v in p.__dict__.items()
                       if k in ("full", "face")}, factor=p.factor * factor)
    return q


EXR_PROJECTIONS = {"exr-latlong": ExrLatLong, "exr-cube": ExrCube}
PROJECTIONS.update(EXR_PROJECTIONS)
