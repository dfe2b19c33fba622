"""Golden vectors of every export format (the ``exports`` part of contract_vectors.json).

Each case is lighting with a known answer: radiance (1, 0.5, 0.25) from one half of the sphere
only (+X, +Y or −Z), the same from +Y plus a directional light from an oblique direction, and
a real panorama. Per case::

    {"name", "coefficients" (27, wire order), "lights" (k), "light_directions" (3k, toward the
     light, rh-y-up), "light_irradiance" (3k), "light_axis" (3, one-sided cases: where the
     light comes from), "normals" (3N, unit, rh-y-up: ±X, ±Y, ±Z first),
     "white" (3N: what a white Lambertian surface must show, E/π, with the lights exact),
     "white_sh9" (3N, light cases: E/π of the SH9 of everything, the lights included in it),
     and one object per format: what provider.core.conventions.formats.export returns, without its
     prose (layout, usage, description, sources and the *_note fields, the same in every
     case: `shlight export --to FORMAT` prints them)}

For a one-sided light, E/π = (1 + a·n)/2 × colour: the colour facing the light, half of it
sideways, exactly 0 opposite. tests/test_export*.py evaluate every format the way its consumer
does (three.js's own code in node, Unity's ShadeSH9 in C# under Mono, the cited sources
re-implemented) and compare with "white".
"""
from __future__ import annotations

import math

import numpy as np

from ..core.conventions import formats as conventions
from ..core.geometry import sh

ONE_SIDED_COLOUR = np.array([1.0, 0.5, 0.25])
AXES = {"+x": np.array([1.0, 0.0, 0.0]), "+y": np.array([0.0, 1.0, 0.0]),
        "-z": np.array([0.0, 0.0, -1.0])}
#: The light of the light case: unit, every component non-zero, so any sign slip shows.
OBLIQUE_LIGHT = (np.array([1.0, 2.0, -2.0]) / 3.0, np.array([3.0, 2.0, 1.0]))
#: Fields of an export that are the same prose in every case (left out of the vectors).
PROSE = ("basis_note", "frame_note", "units_note", "layout", "usage", "description", "sources")

DESCRIPTION = (
    "Golden vectors of `shlight export --to FORMAT` (provider/core/conventions/formats.py; written by "
    "provider/verify/export_vectors.py with the contract vectors). Per case: coefficients in "
    "(27, wire order, radiance, rh-y-up) with lights (docs/contract.md section 10) where given; "
    "'white' = E/pi a white Lambertian surface must show at 'normals' (rh-y-up), the lights "
    "exact; 'white_sh9' = the same from the SH9 of everything. One object per format: the "
    "export without its prose. One-sided cases: radiance (1, 0.5, 0.25) from the half "
    "sphere toward 'light_axis' only, so E/pi = (1 + a.n)/2 x colour: the colour facing the "
    "light, 0 opposite. Each consumer's own evaluation of its object must give 'white' "
    "(Unity: at the normals (x, y, -z); glTF in Babylon's default left-handed scene: at the "
    "glTF normals, which Babylon sees as (-x, y, z)).")


def hemisphere_sh(axis, colour=ONE_SIDED_COLOUR) -> np.ndarray:
    """Analytic SH9 of radiance ``colour`` over the half sphere {ω: ω·axis > 0} (our basis).

    ∫ Y00 = 2π·C0; ∫ C1 (ω·a) = π·C1 along a; band 2 integrates to 0 over any half sphere.
    """
    a = np.asarray(axis, np.float64)
    L = np.zeros((9, 3))
    L[0] = sh.C0 * 2 * math.pi
    L[1], L[2], L[3] = sh.C1 * math.pi * a[1], sh.C1 * math.pi * a[2], sh.C1 * math.pi * a[0]
    return L * np.asarray(colour, np.float64)[None, :]


def white(ambient, lights, normals) -> np.ndarray:
    """E/π of ``ambient`` SH9 plus exact directional ``lights`` at ``normals`` (N, 3)."""
    out = sh.irradiance(ambient, normals) / math.pi
    for d, e in lights:
        out = out + np.maximum(0.0, normals @ d)[:, None] * np.asarray(e)[None, :] / math.pi
    return out


def export_normals(count: int = 16) -> np.ndarray:
    """±X, ±Y, ±Z, then a Fibonacci set."""
    return np.vstack([np.eye(3), -np.eye(3), sh.fibonacci_sphere(count - 6)])


def _numbers(a) -> list:
    return [float(v) + 0.0 for v in np.asarray(a, np.float64).reshape(-1)]


def export_case(name: str, coefficients, lights=(), *, ambient=None, light_axis=None) -> dict:
    """One case: inputs, the expected E/π, and every format's export (without prose)."""
    L = np.asarray(coefficients, np.float64)
    lights = [(np.asarray(d, np.float64), np.asarray(e, np.float64)) for d, e in lights]
    amb = L - sum((conventions.light_sh(d, e) for d, e in lights), np.zeros((9, 3))) \
        if ambient is None else np.asarray(ambient, np.float64)
    n = export_normals()
    case = {"name": name, "coefficients": _numbers(L), "lights": len(lights),
            "light_directions": _numbers([d for d, _ in lights]),
            "light_irradiance": _numbers([e for _, e in lights])}
    if light_axis is not None:
        case["light_axis"] = _numbers(light_axis)
    case["normals"] = _numbers(n)
    case["white"] = _numbers(white(amb, lights, n))
    if lights:
        case["white_sh9"] = _numbers(sh.irradiance(L, n) / math.pi)
    for fmt in conventions.FORMATS:
        ex = conventions.export(L, fmt, lights=lights)
        case[fmt] = {k: v for k, v in ex.items() if k not in PROSE}
    return case


def export_vectors(sky_coefficients) -> list[dict]:
    """The export cases; ``sky_coefficients``: the SH9 of the bundled sky panorama."""
    cases = [export_case(f"one_sided_{k}", hemisphere_sh(a), light_axis=a)
             for k, a in AXES.items()]
    amb = hemisphere_sh(AXES["+y"])
    d, e = OBLIQUE_LIGHT
    cases.append(export_case("one_sided_+y_and_light", amb + conventions.light_sh(d, e),
                             [(d, e)], ambient=amb))
    cases.append(export_case("panorama_sky", sky_coefficients))
    return cases
