"""OpenEXR's environment-map directions written again from ImfEnvmap.cpp, for the EXR tests:
each pixel's direction as OpenEXR defines it, independent of provider/."""
import numpy as np


def latlong_directions(w, h):
    """ImfEnvmap.cpp LatLongMap::direction at every pixel centre (x, y) of a w × h window."""
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    lat = -np.pi * (y / (h - 1) - 0.5)
    lon = -2 * np.pi * (x / (w - 1) - 0.5)
    return np.stack([np.sin(lon) * np.cos(lat), np.sin(lat), np.cos(lon) * np.cos(lat)], -1)


def cube_directions(n):
    """ImfEnvmap.cpp CubeMap::direction at the file pixel that CubeMap::pixelPosition gives
    each positionInFace, for the six faces stacked vertically (+X −X +Y −Y +Z −Z)."""
    out = np.zeros((6 * n, n, 3))
    py, px = np.mgrid[0:n, 0:n].astype(np.float64)     # positionInFace (x = px, y = py)
    a, b = px / (n - 1) * 2 - 1, py / (n - 1) * 2 - 1
    one = np.ones_like(a)
    dirs = [(one, a, b), (-one, a, b), (a, one, b), (a, -one, b), (a, b, one), (a, b, -one)]
    for face, (dx, dy, dz) in enumerate(dirs):
        top, last = face * n, n - 1
        pos = {0: (px * 0 + py, top + last - px), 1: (last - py, top + last - px),
               2: (px, top + last - py), 3: (px, top + py),
               4: (last - px, top + last - py), 5: (px, top + last - py)}[face]
        fx, fy = pos[0].astype(int), pos[1].astype(int)
        out[fy, fx] = np.stack([dx, dy, dz], -1)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)
