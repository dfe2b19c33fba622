"""`shlight validate-shaders`: prove that the shipped GLSL and HLSL compute what the CPU computes.

Each shader path renders E(n) for a dense set of normals, one fragment per normal (the normal
is read from a float32 texture at the fragment's pixel), into two float32 render targets: the
clamped ``shIrradiance``/``SHIrradiance`` and the unclamped function. The result is compared
with ñᵀMñ evaluated in float64 on the CPU (provider.core.geometry.sh) for the same matrices.

* GLSL path: shaders/sh9_irradiance.glsl pasted after ``#version 330 core``.
* HLSL path: a pixel shader that #includes shaders/sh9_irradiance.hlsl, compiled by
  glslangValidator's HLSL front end to SPIR-V and turned into GLSL by spirv-cross
  (:mod:`provider.verify.hlsl`), then rendered by the same code. Skipped (never "passed") where the
  tools are missing.

Error measure. float32 evaluation of ñᵀMñ (a sum of 16 products) has a rounding error bounded
by about k·u·B(n), with u = 2⁻²⁴ the float32 unit roundoff, B(n) = |ñ|ᵀ|M||ñ| the sum of the
magnitudes of the terms, and k ≈ 10 (rounding M to float32, four products and three sums in
M·ñ, the same again in the dot product). The relative error ``|E_gpu − E_cpu| / B(n)`` is
therefore bounded independently of cancellation (E can be near 0 where B is not, in ringing
scenes), and the tolerance :data:`FLOAT32_TOLERANCE` = 32u ≈ 1.9e-6 leaves a factor ~3 for
drivers that round less carefully. Anything beyond it is a real slip (a wrong constant, a
transposed or mis-ordered uniform, a dropped term), not rounding. The RMS figure reported
beside it is the usual relative RMS over all normals and channels.

Independent checks, where an answer is known without the SH matrices: the furnace (E = π),
a light from the +X half of the sphere only (E = (π/2)(1 + x)), and a rotated probe
(R̃MR̃ᵀ uploaded, compared with the matrices of the panorama re-projected after rotating
the image: a yaw of 90° is an exact column roll of an equirect whose width divides by 4).
"""
from __future__ import annotations

import json
import math
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ..core.geometry import sh
from . import contract
from ..core.errors import InputError
from .render import (IRRADIANCE_UNIFORMS, NoOpenGL, create_context, set_irradiance_matrices,
                     shader_source)

#: Max |E_gpu − E_cpu| / (|ñ|ᵀ|M||ñ|): float32 rounding only (see the module docstring).
FLOAT32_TOLERANCE = 32 * 2.0 ** -24
#: The same measure against E from another route. Analytic answers (furnace, one-sided light)
#: differ from ñᵀMñ by the 6-digit constants of docs/contract.md §2 (8e-7 and 1.6e-6 of the scale);
#: the vectors file holds float64 ñᵀMñ at unrounded normals; re-projecting a rotated panorama
#: carries the engine's float32 sums. A sign or frame slip is an error of order 1.
INDEPENDENT_TOLERANCE = {"analytic": 5e-6, "vectors": FLOAT32_TOLERANCE, "reprojection": 1e-5}
#: Dense normals rendered per case (plus ±X, ±Y, ±Z).
DENSE_NORMALS = 65536
#: Width of the normals texture / render target; the height follows from the count.
TARGET_WIDTH = 256

VERTEX_SHADER = """#version 330 core
// One triangle covering the viewport: every pixel of the target gets exactly one fragment.
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
"""

def glsl_evaluator(function: str = "shIrradiance", *, args: str = "n", uniforms: str = "",
                   unclamped: bool = True) -> str:
    """The GLSL fragment program that writes ``function(args)`` and its unclamped variant
    (or, with ``unclamped=False``, the same value twice) for the normal ``n`` read at each
    pixel, pasted after the shipped GLSL that defines them; ``uniforms``: declarations the
    arguments need."""
    second = f"vec4({function}Unclamped({args}), 1.0)" if unclamped else "clampedOut"
    return f"""
uniform sampler2D normals;   // one unit normal per pixel (RGB32F)
{uniforms}
layout(location = 0) out vec4 clampedOut;
layout(location = 1) out vec4 unclampedOut;
void main() {{
    vec3 n = texelFetch(normals, ivec2(gl_FragCoord.xy), 0).xyz;
    clampedOut = vec4({function}({args}), 1.0);
    unclampedOut = {second};
}}
"""


def hlsl_evaluator(include: str = "sh9_irradiance.hlsl", function: str = "SHIrradiance", *,
                   args: str = "n", uniforms: str = "", unclamped: bool = True) -> str:
    """The HLSL pixel shader that does the same with the shipped HLSL ``include``."""
    second = f"float4({function}Unclamped({args}), 1.0)" if unclamped else "t.clamped"
    return f"""#include "{include}"
Texture2D<float4> _Normals;   // one unit normal per pixel
{uniforms}
struct Targets
{{
    float4 clamped : SV_Target0;
    float4 unclamped : SV_Target1;
}};
Targets main(float4 position : SV_Position)
{{
    float3 n = _Normals.Load(int3(position.xy, 0)).xyz;
    Targets t;
    t.clamped = float4({function}({args}), 1.0);
    t.unclamped = {second};
    return t;
}}
"""


GLSL_EVALUATOR = glsl_evaluator()
HLSL_EVALUATOR = hlsl_evaluator()

HLSL_GLOBALS = ("_SHIrradianceR", "_SHIrradianceG", "_SHIrradianceB")


# -- rendering E(n) ----------------------------------------------------------------------------------

class IrradianceEvaluator:
    """Renders E(n) through one shader path ("glsl" or "hlsl"), one fragment per normal.

    ``source`` replaces the evaluator program (:data:`GLSL_EVALUATOR`, pasted after the
    shipped GLSL, or the whole :data:`HLSL_EVALUATOR`); it must write the same two targets.
    Raises :class:`provider.verify.hlsl.HlslToolsMissing` for the HLSL path without its tools.
    """

    def __init__(self, ctx, path: str = "glsl", source: str | None = None):
        self.ctx, self.path = ctx, path
        self._ubo = self._block = None
        if path == "glsl":
            fragment = ("#version 330 core\n" + shader_source("sh9_irradiance.glsl")
                        + (source or GLSL_EVALUATOR))
            self.program = ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=fragment)
            self._uniforms = IRRADIANCE_UNIFORMS
        elif path == "hlsl":
            from .hlsl import HlslCompileError, hlsl_fragment_to_glsl
            compiled = hlsl_fragment_to_glsl(source or HLSL_EVALUATOR)
            self.glsl = compiled.glsl
            self.program = ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=compiled.glsl)
            self._uniforms = HLSL_GLOBALS
            if compiled.block:  # the HLSL globals live in spirv-cross's "_Global" block
                offsets = compiled.member_offsets()
                if not all(g in offsets for g in HLSL_GLOBALS):
                    raise HlslCompileError(f"HLSL globals {HLSL_GLOBALS} not found in uniform "
                                           f"block {compiled.block}: {compiled.members}")
                self._block = (compiled.block, offsets, {n: rm for n, _, rm in compiled.members})
                size = max(offsets.values()) + 64
                self._ubo = ctx.buffer(reserve=size)
                self.program[compiled.block].binding = 1
        else:
            raise ValueError(f"path must be 'glsl' or 'hlsl', got {path!r}")
        for name in self.program:  # the one sampler (its name is mangled on the HLSL path)
            if name in ("normals",) or "Normals" in name:
                self.program[name].value = 0
        self.vao = ctx.vertex_array(self.program, [])

    def set_matrices(self, matrices) -> None:
        m = np.asarray(matrices, np.float64).reshape(3, 4, 4)
        if self._block is None:
            set_irradiance_matrices(self.program, m, self._uniforms)
            return
        _, offsets, row_major = self._block
        data = bytearray(self._ubo.size)
        for name, mc in zip(HLSL_GLOBALS, m):
            # spirv-cross turns HLSL's mul(M, v) into v * G with G = Mᵀ; a row_major G holds
            # the columns of M one after the other (D3D's default column-major packing). E
            # only depends on the symmetric part of M, but the HLSL must see M itself.
            mem = mc.T if row_major[name] else mc
            data[offsets[name]:offsets[name] + 64] = np.ascontiguousarray(mem, np.float32).tobytes()
        self._ubo.write(bytes(data))

    def evaluate(self, matrices, normals) -> tuple[np.ndarray, np.ndarray]:
        """(clamped, unclamped) E at ``normals`` (N, 3), float32 arrays of shape (N, 3)."""
        n = np.asarray(normals, np.float32).reshape(-1, 3)
        count = len(n)
        w = min(TARGET_WIDTH, count)
        h = -(-count // w)
        padded = np.zeros((w * h, 3), np.float32)
        padded[:, 2] = 1.0
        padded[:count] = n
        ctx = self.ctx
        tex = ctx.texture((w, h), 3, padded.tobytes(), dtype="f4")
        tex.filter = (ctx.NEAREST, ctx.NEAREST)
        targets = [ctx.texture((w, h), 4, dtype="f4") for _ in range(2)]
        fbo = ctx.framebuffer(color_attachments=targets)
        try:
            self.set_matrices(matrices)
            if self._ubo is not None:
                self._ubo.bind_to_uniform_block(1)
            tex.use(0)
            fbo.use()
            fbo.viewport = (0, 0, w, h)
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            self.vao.render(mode=ctx.TRIANGLES, vertices=3)
            out = [np.frombuffer(fbo.read(components=4, attachment=i, dtype="f4"), np.float32)
                   .reshape(-1, 4)[:count, :3].copy() for i in range(2)]
        finally:
            for obj in (fbo, *targets, tex):
                obj.release()
        return out[0], out[1]


# -- cases and comparisons ---------------------------------------------------------------------------

def dense_normals(count: int = DENSE_NORMALS) -> np.ndarray:
    """±X, ±Y, ±Z and ``count`` nearly uniform unit normals (Fibonacci lattice)."""
    return np.vstack([np.eye(3), -np.eye(3), sh.fibonacci_sphere(count)])


@dataclass
class ShaderCase:
    """Matrices to upload, and optionally normals and an independently known E there."""
    name: str
    matrices: np.ndarray                       # (3, 4, 4), uploaded as they are
    normals: np.ndarray | None = None          # (N, 3) unit; None: :func:`dense_normals`
    independent: np.ndarray | None = None      # (N, 3) E from a route that avoids M
    independent_kind: str = ""                 # key of INDEPENDENT_TOLERANCE / the route
    note: str = ""


@dataclass
class Comparison:
    """One case through one shader path."""
    case: str
    path: str
    normals: int
    max_rel: float            # max |E_gpu − E_cpu| / (|ñ|ᵀ|M||ñ|), unclamped output
    rms_rel: float            # relative RMS of (E_gpu − E_cpu), unclamped output
    clamp_max_rel: float      # the same max for the clamped output against max(E_cpu, 0)
    negative_outputs: int     # clamped outputs below 0 (must be 0)
    ringing_normals: int      # normal×channel samples where E_cpu < 0 beyond the tolerance
    independent_max_rel: float | None
    independent_tolerance: float | None
    tolerance: float
    note: str = ""
    passed: bool = field(default=False)

    def line(self) -> str:
        ind = ("" if self.independent_max_rel is None else
               f"  indep {self.independent_max_rel:.1e}/{self.independent_tolerance:.0e}")
        ring = f"  clamps {self.ringing_normals}" if self.ringing_normals else ""
        return (f"{'PASS' if self.passed else 'FAIL'}  {self.path:4s}  {self.case:28s} "
                f"max {self.max_rel:.2e} (tolerance {self.tolerance:.1e})  "
                f"rms {self.rms_rel:.2e}  clamped {self.clamp_max_rel:.2e}{ring}{ind}")


def compare(case: ShaderCase, path: str, clamped, unclamped, normals,
            tolerance: float = FLOAT32_TOLERANCE) -> Comparison:
    """Compare rendered E with float64 ñᵀMñ (and the case's independent answer, if any)."""
    # The reference uses the float32-rounded normals the shader saw: their rounding is input,
    # not the shader's error.
    n = np.asarray(normals, np.float32).astype(np.float64)
    M = np.asarray(case.matrices, np.float64)
    exact = sh.irradiance_from_matrices(M, n)
    scale = sh.irradiance_from_matrices(np.abs(M), np.abs(n))   # |ñ|ᵀ|M||ñ| per channel
    return judge(case, path, clamped, unclamped, exact, scale, tolerance)


def judge(case, path: str, clamped, unclamped, exact, scale,
          tolerance: float = FLOAT32_TOLERANCE) -> Comparison:
    """The verdict on rendered E (``clamped``, ``unclamped``) against the float64 ``exact``
    with the error measure's ``scale`` (the sum of the magnitudes of the terms), and the
    case's independent answer when it has one."""
    safe = np.where(scale > 0, scale, 1.0)
    err = np.abs(unclamped - exact) / safe
    clamp_err = np.abs(clamped - np.maximum(exact, 0.0)) / safe
    ind_err = ind_tol = None
    if case.independent is not None:
        ind_tol = INDEPENDENT_TOLERANCE[case.independent_kind]
        ind_err = float(np.max(np.abs(unclamped - case.independent) / safe))
    result = Comparison(
        case=case.name, path=path, normals=len(exact), max_rel=float(err.max()),
        rms_rel=sh.relative_rms(unclamped, exact), clamp_max_rel=float(clamp_err.max()),
        negative_outputs=int(np.count_nonzero(clamped < 0)),
        ringing_normals=int(np.count_nonzero(exact < -tolerance * scale)),
        independent_max_rel=ind_err, independent_tolerance=ind_tol, tolerance=tolerance,
        note=case.note)
    result.passed = bool(result.max_rel <= tolerance and result.clamp_max_rel <= tolerance
                         and result.negative_outputs == 0
                         and (ind_err is None or ind_err <= ind_tol)
                         and np.all(np.isfinite(unclamped)))
    return result


def synthetic_cases(normals: np.ndarray) -> list[ShaderCase]:
    """Furnace, a light from +X only, and seeded random coefficients."""
    furnace = sh.irradiance_matrices(contract.furnace_coefficients())
    one_sided = sh.irradiance_matrices(contract.one_sided_coefficients())
    return [
        ShaderCase("furnace", furnace, independent=np.full((len(normals), 3), math.pi),
                   independent_kind="analytic", note="uniform radiance 1: E = pi"),
        ShaderCase("one_sided_+x", one_sided,
                   independent=contract.one_sided_irradiance(normals.astype(np.float32)),
                   independent_kind="analytic", note="light from x > 0 only: E = (pi/2)(1+x)"),
        ShaderCase("random", sh.irradiance_matrices(contract.random_coefficients())),
    ]


def panorama_cases(paths, normals: np.ndarray) -> list[ShaderCase]:
    """The un-windowed SH9 of each equirect panorama, and a rotated probe of the first one
    whose width divides by 4 (yaw 90°: R̃MR̃ᵀ against the re-projected, column-rolled image)."""
    from ..core.sh9.engine import compute_sh9
    from ..core.radiometry.images import read_image
    cases, rotated = [], None
    for path in paths:
        image = read_image(path)
        if image.shape[1] != 2 * image.shape[0]:
            raise InputError(f"{path}: not an equirect panorama (2:1), got "
                             f"{image.shape[1]}×{image.shape[0]}")
        result = compute_sh9(image, error_estimate=False)
        name = Path(path).stem
        ring = bool(np.any(sh.sphere_irradiance(result.coefficients) < 0))
        cases.append(ShaderCase(f"panorama:{name}", result.matrices,
                                note="rings: E < 0 somewhere" if ring else ""))
        if rotated is None and image.shape[1] % 4 == 0:
            rotated = (name, image, result.matrices)
    if rotated is not None:
        name, image, M = rotated
        cases.append(rotation_case(name, image, M, normals))
    return cases


def yaw90_rolled(image: np.ndarray) -> np.ndarray:
    """The equirect of the environment rotated by a yaw of +90° (about +Y, counter-clockwise
    seen from above): φ' = φ − 90°, a roll of the columns by −W/4 (exact, no resampling)."""
    return np.roll(image, -image.shape[1] // 4, axis=1)


def rotation_case(name: str, image: np.ndarray, matrices, normals) -> ShaderCase:
    from ..core.sh9.engine import compute_sh9
    R = sh.rotation_from_euler(90, 0, 0)
    rolled = compute_sh9(yaw90_rolled(image), error_estimate=False).matrices
    return ShaderCase(f"rotated_yaw90:{name}", sh.rotate_matrices(matrices, R),
                      independent=sh.irradiance_from_matrices(rolled, normals.astype(np.float32)),
                      independent_kind="reprojection",
                      note="R M R^T against the re-projected, rotated panorama")


def vector_cases(vectors: dict) -> list[ShaderCase]:
    """Each contract-vector case at its own normals, in both frames (same expected E)."""
    cases = []
    for c in vectors["cases"]:
        cases.append(ShaderCase(f"vectors:{c['name']}", c["matrices"], c["normals"],
                                c["irradiance"], "vectors", note="contract vectors"))
        cases.append(ShaderCase(f"vectors-unity:{c['name']}", c["unity_matrices"],
                                c["unity_normals"], c["irradiance"], "vectors",
                                note="contract vectors, Unity frame"))
    return cases


def run_cases(evaluator: IrradianceEvaluator, cases, normals,
              tolerance: float = FLOAT32_TOLERANCE) -> list[Comparison]:
    out = []
    for case in cases:
        n = normals if case.normals is None else np.asarray(case.normals, np.float64)
        clamped, unclamped = evaluator.evaluate(case.matrices, n)
        out.append(compare(case, evaluator.path, clamped, unclamped, n, tolerance))
    return out


# -- the demo program (shaders/lit_diffuse.*) -------------------------------------------------------

#: Max |shader − numpy| of lit_diffuse's output in [0, 1] display units: float32 pow/exp
#: in the sRGB curve, well below one 8-bit code (1/255 = 3.9e-3).
DISPLAY_TOLERANCE = 1e-5


@dataclass
class DemoCheck:
    """lit_diffuse.frag against its numpy twin (ρ·max(E, 0)/π, exposure, tone map, sRGB)."""
    name: str
    max_abs: float
    tolerance: float
    pixels: int
    passed: bool

    def line(self) -> str:
        return (f"{'PASS' if self.passed else 'FAIL'}  demo  {self.name:28s} "
                f"max |diff| {self.max_abs:.2e} over {self.pixels} pixels "
                f"(tolerance {self.tolerance:.0e})")


def lit_diffuse_checks(ctx, size: int = 96) -> list[DemoCheck]:
    """Render a torus with the demo program and compare every pixel with numpy.

    The furnace case is the contract's own test: uniform radiance 1, white albedo, no tone
    map: every pixel shows exactly 1 (E = π, ρE/π = 1).
    """
    from .pictures import ObjectRenderer
    from .render import TONE_MAPS, set_uniform, srgb_encode, tone_map
    renderer = ObjectRenderer(ctx, size)
    furnace = sh.irradiance_matrices(contract.furnace_coefficients())
    one_sided = sh.irradiance_matrices(contract.one_sided_coefficients())
    settings = [("furnace_white_shows_1", furnace, (1.0, 1.0, 1.0), 1.0, "none", False),
                ("one_sided_reinhard_srgb", one_sided, (0.8, 0.6, 0.4), 0.7, "reinhard", True),
                ("one_sided_aces_srgb", one_sided, (0.5, 0.7, 0.9), 1.8, "aces", True),
                ("random_linear", sh.irradiance_matrices(contract.random_coefficients()),
                 (0.3, 0.3, 0.3), 1.0, "none", False)]
    out = []
    for name, M, albedo, exposure, tone, srgb in settings:
        renderer.set_lighting(M)
        set_uniform(renderer.lit, "albedo", albedo)
        set_uniform(renderer.lit, "exposure", exposure)
        set_uniform(renderer.lit, "toneMap", TONE_MAPS[tone])
        set_uniform(renderer.lit, "srgbOutput", srgb)
        shown, normals, mask = renderer.render("torus")
        n = normals[mask].astype(np.float64)
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        radiance = np.asarray(albedo) * np.maximum(sh.irradiance_from_matrices(M, n), 0) / math.pi
        want = tone_map(radiance * exposure, tone)
        if srgb:
            want = srgb_encode(want)
        if name.startswith("furnace"):
            want = np.ones_like(want)   # the contract, not the twin: a white surface shows 1
        err = float(np.abs(shown[mask] - want).max())
        out.append(DemoCheck(name, err, DISPLAY_TOLERANCE, int(mask.sum()),
                             bool(err <= DISPLAY_TOLERANCE and mask.sum() > 0)))
    return out


def summary_lines(results, paths) -> list[str]:
    """One line per shader path and tolerance: the :class:`Comparison` results judged at it
    (the SH9 cases at ``--tolerance``; the shadow and occluder cases at their own, scaled by
    it), their worst errors beside that tolerance, never beside another case's."""
    own = [r for r in results if isinstance(r, Comparison)]
    lines = []
    for p in paths:
        for tol in sorted({r.tolerance for r in own if r.path == p}):
            mine = [r for r in own if r.path == p and r.tolerance == tol]
            worst = max(mine, key=lambda r: r.max_rel)
            lines.append(f"{p}: {len(mine)} comparisons at tolerance {tol:.2e}, worst max "
                         f"relative error {worst.max_rel:.2e} ({worst.case}), worst relative "
                         f"RMS {max(r.rms_rel for r in mine):.2e}")
    return lines


# -- command line ------------------------------------------------------------------------------------

def default_panoramas() -> list[Path]:
    """The CC0 panoramas shipped with the package (provider/data/hdri)."""
    return sorted(contract.HDRI_DIR.glob("*.exr"))


def run(args, extensions=()) -> int:
    """``shlight validate-shaders`` (arguments: :mod:`provider.cli.validate`).

    ``extensions``: modules that validate more shader functions the same way (e.g.
    :mod:`provider.verify.lights`), each with ``compare(ctx, path, normals, panoramas,
    vectors, tolerance)`` → comparisons, ``demo_checks(ctx)`` and ``pictures(ctx,
    panoramas, out_dir)`` → picture statistics (printed by the extension).
    """
    out_dir = Path(args.out)
    if args.normals < 1:
        raise InputError("--normals must be positive")
    panoramas = [Path(p) for p in args.panoramas] or default_panoramas()
    for p in panoramas:
        if not p.is_file():
            raise InputError(f"no such panorama: {p}")

    # --write-vectors is written by the command (provider/cli/validate.py, through the
    # output rule) before it calls here, and then read as --vectors
    vectors_path = Path(args.vectors or contract.VECTORS_PATH)
    if args.vectors and not vectors_path.is_file():
        raise InputError(f"no such vectors file: {vectors_path}")

    try:
        ctx = create_context()
    except NoOpenGL as exc:
        raise InputError(f"cannot validate the shaders: {exc}") from None
    info = ctx.info
    print(f"OpenGL: {info.get('GL_RENDERER')} ({info.get('GL_VERSION')})")

    t0 = time.perf_counter()
    normals = dense_normals(args.normals)
    cases = synthetic_cases(normals) + panorama_cases(panoramas, normals)
    vectors = None
    if vectors_path.is_file():
        vectors = contract.load_contract_vectors(vectors_path)
        cases += vector_cases(vectors)
    else:
        print(f"no contract vectors at {vectors_path} (write them with --write-vectors)")

    results, skipped = [], {}
    paths = ["glsl"] + ([] if args.no_hlsl else ["hlsl"])
    for path in paths:
        try:
            evaluator = IrradianceEvaluator(ctx, path)
        except Exception as exc:  # missing tools or a compile error: reported, never passed
            from .hlsl import HlslToolsMissing
            if path == "glsl" or not isinstance(exc, HlslToolsMissing):
                print(f"FAIL  {path}: the shader does not build: {exc}")
                results.append(None)
                continue
            skipped[path] = str(exc)
            print(f"SKIP  {path}: {exc}")
            continue
        for r in run_cases(evaluator, cases, normals, args.tolerance):
            print(r.line())
            results.append(r)
        for ext in extensions:
            try:
                more = ext.compare(ctx, path, normals, panoramas, vectors, args.tolerance)
            except Exception as exc:  # a compile error: reported, never passed
                print(f"FAIL  {path}: {ext.__name__} does not build: {exc}")
                results.append(None)
                continue
            for r in more:
                print(r.line())
                results.append(r)
    compared = [r for r in results if r is not None]
    failed = len(results) - sum(r.passed for r in compared)
    demo = lit_diffuse_checks(ctx) + [d for ext in extensions for d in ext.demo_checks(ctx)]
    for d in demo:
        print(d.line())
    failed += sum(not d.passed for d in demo)

    pictures = []
    if not args.no_pictures and panoramas:
        from .pictures import write_validation_pictures
        pictures = write_validation_pictures(ctx, panoramas, out_dir)
        for pic in pictures:
            print(f"picture {pic['file']}: SH9 shader vs brute-force irradiance, relative RMS "
                  f"sphere {pic['sphere_rms_rel']:.1%}, torus {pic['torus_rms_rel']:.1%} "
                  f"(all normals {pic['all_normals_rms_rel']:.1%})")
        for ext in extensions:
            pictures += ext.pictures(ctx, panoramas, out_dir)

    # Extensions with a measure of their own (e.g. reflections) summarise theirs with
    # ``summary``.
    for line in summary_lines(compared, paths):
        print(line)
    for ext in extensions:
        if hasattr(ext, "summary"):
            for line in ext.summary(compared, paths):
                print(line)
    if args.require_hlsl and skipped:
        failed += 1
    report = {"renderer": info.get("GL_RENDERER"), "version": info.get("GL_VERSION"),
              "tolerance": args.tolerance, "skipped": skipped, "failed": failed,
              "seconds": time.perf_counter() - t0,
              "comparisons": [asdict(r) for r in compared],
              "demo_program": [asdict(d) for d in demo], "pictures": pictures}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "report.json").write_text(json.dumps(report, indent=1))
    verdict = "FAILED" if failed else "passed"
    hlsl_note = f" (HLSL skipped: {skipped['hlsl']})" if "hlsl" in skipped else ""
    print(f"validate-shaders {verdict}: {len(compared)} comparisons, {failed} failed{hlsl_note}; "
          f"report in {out_dir / 'report.json'}", file=sys.stderr if failed else sys.stdout)
    return 1 if failed else 0
