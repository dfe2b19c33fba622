"""Contract test vectors: coefficients in; matrices and E(n) out, in both frames.

``shaders/contract_vectors.json`` is written by :func:`write_contract_vectors` (``shlight
validate-shaders --write-vectors shaders/contract_vectors.json``; every number at
:data:`DIGITS` significant digits, so that writing it again changes nothing) and read by the shader harness and by the C# tests of the
Unity package. Format (version 1; every array flat, numbers only, so Unity's JsonUtility and
any small parser read it)::

    {"version": 1, "frame": "rh-y-up", "unity_frame": "unity-lh-y-up: (x, y, z) -> (x, y, -z)",
     "description": "...",
     "cases": [{"name", "coefficients" (27, wire order L00.r, L00.g, L00.b, L1-1.r, ...),
                "matrices" (48: M_r, M_g, M_b row-major, right-handed),
                "normals" (3N, unit, right-handed), "irradiance" (3N: E(n) RGB, not clamped),
                "unity_matrices" (48: S M S, S = diag(1, 1, -1, 1)),
                "unity_normals" (3N: (x, y, -z)),
                and in rotation cases "rotation" (9, row-major, right-handed),
                "rotated_matrices" (48: R̃ M R̃ᵀ), "unity_rotated_matrices" (48),
                and in lights cases (docs/contract.md §10) the wire fields "lights" (k),
                "light_directions" (3k), "light_irradiance" (3k), "ambient_coefficients"
                (27), "ambient_matrices" (48), then "irradiance_with_lights" (3N: ñᵀAñ +
                Σ_k I_k max(0, n·d_k), not clamped), "unity_ambient_matrices" (48: S A S),
                "unity_light_directions" (3k: (x, y, -z))}],
     "exports_description": "...", "exports": [golden vectors of every `shlight export`
     format: see provider/verify/export_vectors.py]}

In a lights case "coefficients"/"matrices" are the full SH9 (ambient + the lights' SH9
projection I_k·Y(d_k)) and "irradiance" is still ñᵀMñ of those: the SH9-only checks hold for
every case, and a reader that ignores lights keys loses nothing.

"irradiance" is ñᵀMñ evaluated in float64 from "matrices" (what every shader computes); it
differs from Σ Â_l L_lm Y_lm(n) by the 6-digit constants of docs/contract.md §2 (< 1e-6 of the scale).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from ..core.geometry import sh
from .export_vectors import DESCRIPTION as EXPORTS_DESCRIPTION, export_vectors
from .render import SHADER_DIR

VECTORS_PATH = SHADER_DIR / "contract_vectors.json"
#: Significant digits of every number written: far below every check's tolerance (1e-12 of an
#: array's scale for the derived arrays, tests/shaders/test_shaders.py), and above float64's last
#: bits, which the same formulas may set apart across numpy builds and CPUs (their SIMD sine
#: and cosine), so that writing the file again changes nothing. The panorama cases' inputs
#: come from the engine's float32 sums with BLAS on one thread (provider.core.blas):
#: reproduced on one machine; on another CPU they may differ by ~1e-7, which the tests allow.
DIGITS = 14
#: Panoramas the real-scene cases come from (CC0, shipped with the package; the tests' too).
HDRI_DIR = Path(__file__).resolve().parents[1] / "data" / "hdri"

S3 = np.diag([1.0, 1.0, -1.0])          # right-handed -> Unity (left-handed): z -> -z
S4 = np.diag([1.0, 1.0, -1.0, 1.0])

ONE_SIDED_COLOUR = np.array([1.0, 0.5, 0.25])
RANDOM_SEED = 4


# -- coefficient sets with known answers (shared with the shader harness) ------------------------

def furnace_coefficients(radiance: float = 1.0) -> np.ndarray:
    """Uniform radiance from every direction: L00 = ∫ Y00 dω = 4π·0.282095; E = π·radiance."""
    c = np.zeros((9, 3))
    c[0] = radiance * 4 * math.pi * sh.C0
    return c


def one_sided_coefficients(colour=ONE_SIDED_COLOUR) -> np.ndarray:
    """Radiance ``colour`` from the +X half of the sphere only, 0 from the -X half.

    Exactly L00 = 2π·C0 and L11 = π·C1 (every other integral over the half sphere vanishes),
    so E(n) = (π/2)(1 + x)·colour: π at +X, exactly 0 at -X. A sign slip on x shows at once.
    """
    c = np.zeros((9, 3))
    c[0] = 2 * math.pi * sh.C0 * np.asarray(colour, np.float64)
    c[3] = math.pi * sh.C1 * np.asarray(colour, np.float64)
    return c


def one_sided_irradiance(normals, colour=ONE_SIDED_COLOUR) -> np.ndarray:
    """Analytic E(n) = (π/2)(1 + x)·colour of :func:`one_sided_coefficients` (no SH)."""
    x = np.asarray(normals, np.float64)[..., 0]
    return (math.pi / 2) * (1 + x)[..., None] * np.asarray(colour, np.float64)


def random_coefficients(seed: int = RANDOM_SEED) -> np.ndarray:
    """Gaussian coefficients with a dominant positive L00 (deterministic for a seed)."""
    c = np.random.default_rng(seed).normal(size=(9, 3))
    c[0] = np.abs(c[0]) + 3.0
    return c


def panorama_coefficients(name: str, hdri_dir: Path = HDRI_DIR) -> np.ndarray:
    """Exact (un-windowed) SH9 of a bundled panorama, through the product's engine."""
    from ..core.sh9.engine import compute_sh9
    return compute_sh9(Path(hdri_dir) / f"{name}.exr", error_estimate=False).coefficients


# -- the vectors -------------------------------------------------------------------------------------

def _numbers(a) -> list:
    # + 0.0 turns -0.0 into 0.0: the same value, and simpler for hand-written parsers.
    return [float(v) + 0.0 for v in np.asarray(a, np.float64).reshape(-1)]


def case_normals(coefficients: np.ndarray, count: int = 64) -> np.ndarray:
    """±X, ±Y, ±Z, a Fibonacci set, and the normal of least irradiance (where ringing shows)."""
    E = sh.sphere_irradiance(coefficients).min(axis=1)
    darkest = sh.SPHERE_NORMALS[int(np.argmin(E))]
    return np.vstack([np.eye(3), -np.eye(3), sh.fibonacci_sphere(count - 7), darkest])


def lights_vector_case(name: str, ambient, directions, irradiance) -> dict:
    """A lights case: the full SH9 (ambient + Σ I_k Y(d_k)) as an ordinary case, plus the
    docs/contract.md §10 fields and E of ambient + lights at its normals (which include ±d_k)."""
    A = np.asarray(ambient, np.float64)
    d = np.asarray(directions, np.float64).reshape(-1, 3)
    irr = np.asarray(irradiance, np.float64).reshape(-1, 3)
    full = A + sum((np.outer(sh.sh_basis(dk), Ik) for dk, Ik in zip(d, irr)), np.zeros((9, 3)))
    n = np.vstack([case_normals(full), d, -d])
    case = vector_case(name, full, normals=n)
    MA = sh.irradiance_matrices(A)
    E = sh.irradiance_from_matrices(MA, n) + np.maximum(n @ d.T, 0.0) @ irr
    case.update(lights=len(d), light_directions=_numbers(d), light_irradiance=_numbers(irr),
                ambient_coefficients=_numbers(A), ambient_matrices=_numbers(MA),
                irradiance_with_lights=_numbers(E), unity_ambient_matrices=_numbers(S4 @ MA @ S4),
                unity_light_directions=_numbers(d @ S3))
    return case


def panorama_lights(name: str, hdri_dir: Path = HDRI_DIR):
    """(ambient (9, 3), directions (k, 3), irradiance (k, 3)) of a bundled panorama from the
    engine with ``lights="auto"``."""
    from ..core.sh9.engine import compute_sh9
    r = compute_sh9(Path(hdri_dir) / f"{name}.exr", error_estimate=False, lights="auto")
    return (r.ambient, np.array([light.direction for light in r.lights]).reshape(-1, 3),
            np.array([light.irradiance for light in r.lights]).reshape(-1, 3))


#: The one-sided light of the lights cases: from (2, 1, -2)/3 (every axis, so a sign slip on
#: any of them shows), irradiance π·ONE_SIDED_COLOUR, over a uniform ambient of radiance 0.1.
ONE_SIDED_LIGHT = (np.array([2.0, 1.0, -2.0]) / 3.0, math.pi * ONE_SIDED_COLOUR)


def vector_case(name: str, coefficients, rotation=None, normals=None) -> dict:
    """One case of the vectors file (see the module docstring)."""
    L = np.asarray(coefficients, np.float64)
    n = case_normals(L) if normals is None else np.asarray(normals, np.float64)
    M = sh.irradiance_matrices(L)
    case = {"name": name,
            "coefficients": _numbers(L),
            "matrices": _numbers(M),
            "normals": _numbers(n),
            "irradiance": _numbers(sh.irradiance_from_matrices(M, n)),
            "unity_matrices": _numbers(S4 @ M @ S4),
            "unity_normals": _numbers(n @ S3)}
    if rotation is not None:
        R = np.asarray(rotation, np.float64)
        RM = sh.rotate_matrices(M, R)
        case.update(rotation=_numbers(R), rotated_matrices=_numbers(RM),
                    unity_rotated_matrices=_numbers(S4 @ RM @ S4))
    return case


DESCRIPTION = (
    "Contract test vectors for SH9 irradiance (docs/contract.md sections 1-2), written by "
    "`shlight validate-shaders --write-vectors PATH` (provider/verify/contract.py), every number at "
    f"{DIGITS} significant digits. Per case: radiance SH "
    "coefficients in; the irradiance matrices M (E(n) = n~^T M n~, n~ = (x, y, z, 1)) and E at "
    "the listed unit normals out, float64, NOT clamped at zero. Unity's frame: S M S with "
    "S = diag(1, 1, -1, 1) and normals (x, y, -z) give the same E. Rotation cases: "
    "M' = R~ M R~^T with R~ = diag(R, 1). Cases: furnace (uniform radiance 1, E = pi); "
    "one_sided_+x (radiance (1, 0.5, 0.25) from x > 0 only, E = (pi/2)(1 + x) per channel: "
    "0 at -X); random (seeded Gaussian); panorama_sky and panorama_lab (CC0 Poly Haven "
    "panoramas via @pmndrs/assets, tests/data/hdri; lab rings: E < 0 (blue) at its last normal, "
    "which a shader clamps to 0); rotation cases one_sided_+x_yaw90 (the light moves to -Z) "
    "and panorama_sky_rotated (yaw 30, pitch -20, roll 10); lights cases (docs/contract.md section 10: "
    "E(n) = n~^T A n~ + sum_k I_k max(0, n.d_k) with the ambient matrices A) lights_one_sided "
    "(uniform ambient 0.1 plus one light from (2, 1, -2)/3 of irradiance pi*(1, 0.5, 0.25): "
    "E = 0.1 pi at -d, 0.1 pi + I at d), lights_panorama_sky (the sun), lights_panorama_lab "
    "(two windows) and lights_none_city (no light: ambient = the full SH9).")


def contract_vectors(hdri_dir: Path = HDRI_DIR) -> dict:
    """The whole vectors document (as :func:`dumps` writes it: the same on one machine, run
    after run; see :data:`DIGITS`)."""
    one_sided = one_sided_coefficients()
    sky = panorama_coefficients("sky", hdri_dir)
    cases = [vector_case("furnace", furnace_coefficients()),
             vector_case("one_sided_+x", one_sided),
             vector_case("random", random_coefficients()),
             vector_case("panorama_sky", sky),
             vector_case("panorama_lab_ringing", panorama_coefficients("lab", hdri_dir)),
             vector_case("one_sided_+x_yaw90", one_sided, rotation=sh.rotation_from_euler(90, 0, 0)),
             vector_case("panorama_sky_rotated", sky, rotation=sh.rotation_from_euler(30, -20, 10)),
             lights_vector_case("lights_one_sided", furnace_coefficients(0.1), *ONE_SIDED_LIGHT),
             lights_vector_case("lights_panorama_sky", *panorama_lights("sky", hdri_dir)),
             lights_vector_case("lights_panorama_lab", *panorama_lights("lab", hdri_dir)),
             lights_vector_case("lights_none_city", *panorama_lights("city", hdri_dir))]
    return {"version": 1, "frame": "rh-y-up",
            "unity_frame": "unity-lh-y-up: (x, y, z) -> (x, y, -z)",
            "description": DESCRIPTION, "cases": cases,
            "exports_description": EXPORTS_DESCRIPTION, "exports": export_vectors(sky)}


def rounded(v):
    """``v`` (numbers, lists and dicts of them) with every float at :data:`DIGITS`
    significant digits (-0.0 as 0.0)."""
    if isinstance(v, float):
        return float(f"{v:.{DIGITS}g}") + 0.0
    if isinstance(v, list):
        return [rounded(x) for x in v]
    if isinstance(v, dict):
        return {k: rounded(x) for k, x in v.items()}
    return v


def dumps(vectors: dict) -> str:
    """JSON text with one key per line and each array on one line (diffable, still plain
    JSON), every number at :data:`DIGITS` significant digits."""
    def value(v):
        return json.dumps(rounded(v), allow_nan=False)
    lines = ["{"]
    lists = [k for k in ("cases", "exports") if k in vectors]
    top = [k for k in vectors if k not in lists]
    for k in top:
        lines.append(f" {json.dumps(k)}: {value(vectors[k])},")
    for n, key in enumerate(lists):
        lines.append(f" {json.dumps(key)}: [")
        for i, case in enumerate(vectors[key]):
            items = [f"   {json.dumps(k)}: {value(v)}" for k, v in case.items()]
            lines.append("  {\n" + ",\n".join(items) + "\n  }" + ("," if i + 1 < len(vectors[key]) else ""))
        lines.append(" ]" + ("," if n + 1 < len(lists) else ""))
    lines.append("}")
    return "\n".join(lines) + "\n"


def write_contract_vectors(path: Path, hdri_dir: Path = HDRI_DIR) -> Path:
    """Write the vectors file at ``path`` (given: the package's own, :data:`VECTORS_PATH`,
    is the repository's tracked file, not a default); returns its path."""
    from ..core.errors import InputError
    missing = [n for n in ("sky", "lab", "city") if not (Path(hdri_dir) / f"{n}.exr").exists()]
    if missing:
        raise InputError(f"the contract vectors need {', '.join(m + '.exr' for m in missing)} "
                         f"in {hdri_dir}")
    path = Path(path)
    path.write_text(dumps(contract_vectors(hdri_dir)))
    return path


def load_contract_vectors(path: Path = VECTORS_PATH) -> dict:
    """Parse a vectors file into arrays: per case, (9, 3) coefficients, (3, 4, 4) matrices,
    (N, 3) normals and irradiance, and so on (keys as in the file)."""
    doc = json.loads(Path(path).read_text())
    shapes = {"coefficients": (9, 3), "matrices": (3, 4, 4), "unity_matrices": (3, 4, 4),
              "rotation": (3, 3), "rotated_matrices": (3, 4, 4),
              "unity_rotated_matrices": (3, 4, 4), "normals": (-1, 3), "irradiance": (-1, 3),
              "unity_normals": (-1, 3), "ambient_coefficients": (9, 3),
              "ambient_matrices": (3, 4, 4), "unity_ambient_matrices": (3, 4, 4),
              "light_directions": (-1, 3), "unity_light_directions": (-1, 3),
              "light_irradiance": (-1, 3), "irradiance_with_lights": (-1, 3)}
    for case in doc["cases"]:
        for k, shape in shapes.items():
            if k in case:
                case[k] = np.asarray(case[k], np.float64).reshape(shape)
    return doc
