"""`shlight validate-shaders`, reflections: the shipped image-based lighting (shaders/ibl.glsl
and .hlsl, docs/contract.md §12) against a CPU reference of the same formula.

    colour = albedo · max(E(N), 0) / π + PF(R, roughness) · EnvBRDFApprox(F0, roughness, N·V)
    R = reflect(−V, N) = 2 (N·V) N − V,  lod = clamp(roughness, 0, 1) · (mip_count − 1)

A glossy sphere is rendered through each shader path (GLSL; HLSL through glslang → SPIR-V →
spirv-cross, :mod:`provider.verify.hlsl`): the sphere is ray-cast on the CPU from a perspective
camera, and each pixel's unit normal N, direction to the eye V, albedo, F0 and roughness are
read by one fragment from float32 textures, so the CPU reference works on exactly the values
the shader saw. The cube is a real OpenGL cube texture with all its mips (RGBA32F or
RGBA16F), trilinear and seamless (:func:`provider.verify.cubemap.upload_cube`); the reference
samples it with :class:`provider.verify.cubemap.CubeSampler`, which filters as OpenGL does
(bilinear within a face, across edges and corners seamlessly, linear between mips), so the
comparison covers face edges and corners too. Each fragment writes the colour
(``shlight_ibl``), the prefiltered radiance (``shlight_prefiltered_radiance``) and the terms
(``shlight_env_brdf_scale_bias``, ``shlight_specular_lod``, N·V).

Error measure: ``|colour_gpu − colour_cpu| / scale`` with scale the sum of the magnitudes of
the terms, albedo·|ñ|ᵀ|M||ñ|/π + max|tap| · (|F0·A| + |B|) (max|tap|: the largest texel the
filter read). float32 evaluation leaves a few units of u = 2⁻²⁴ of it in the sums and the DFG
(the SH9 harness's 32u), plus the texture lookup: R = reflect(−V, N) and its face coordinate
sc/|ma| carry ~4u, which moves the sample by ~2n·u texels on an n×n face, so the bilinear
weights move by that much and the value by up to twice the largest tap. Hence
:func:`ibl_tolerance` = (32 + 4n)u for a cube of n×n mip 0 (160u ≈ 9.5e-6 at n = 32; measured
on llvmpipe: ~5u on smooth cubes, ~50u on the one-sided cube, whose faces step from 4 to 0). A RGBA16F upload is compared with
the reference of the float16-rounded cube (the rounding is the input, not the shader's error).
A face in the wrong slot, a flipped face, a wrong lod or a dropped term is an error of order 1.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..core.geometry import sh
from . import contract, cubemap
from .harness import VERTEX_SHADER
from .render import look_at, set_irradiance_matrices, shader_source

#: float32 unit roundoff.
U32 = 2.0 ** -24


def ibl_tolerance(size: int) -> float:
    """Max |colour_gpu − colour_cpu| / (sum of the magnitudes of the terms) for a cube whose
    mip 0 is size×size: (32 + 4·size)·u (see the module docstring)."""
    return (32 + 4 * int(size)) * U32


#: The tolerance at the default cube size, 32.
IBL_TOLERANCE = ibl_tolerance(32)
#: Bits of sub-texel (and mip-blend) precision in a hardware texture unit's filter weights:
#: Direct3D asks for at least 8 and NVIDIA's and AMD's units use 8, where Mesa's llvmpipe
#: filters in float32. Fixed-function filtering, not the shader's arithmetic.
FILTER_WEIGHT_BITS = 8
#: What 8-bit weights can move a trilinear lookup by, relative to its largest tap: each
#: bilinear weight and the mip blend off by up to 2⁻⁸, each moving the value by up to twice
#: the largest tap: 3 · 2 · 2⁻⁸ ≈ 0.023 (measured on an NVIDIA H100: 1.1e-2 at worst, on the
#: one-sided cube's 4-to-0 step; 3–4e-3 on smooth cubes). A face in the wrong slot, a flip or
#: a wrong lod is still an error of order 1.
HARDWARE_FILTER_TOLERANCE = 3 * 2 * 2.0 ** -FILTER_WEIGHT_BITS


def filters_in_float(renderer: str | None) -> bool:
    """Whether the OpenGL ``renderer`` (GL_RENDERER) filters textures in float (Mesa's
    software rasterisers) rather than with a hardware unit's 8-bit weights."""
    low = (renderer or "").lower()
    return any(name in low for name in ("llvmpipe", "softpipe", "swrast", "lavapipe"))
#: Karis's mobile DFG fit (Unreal Engine 4, "Physically Based Shading on Mobile", 2014).
DFG_C0 = np.array([-1.0, -0.0275, -0.572, 0.022])
DFG_C1 = np.array([1.0, 0.0425, 1.04, -0.04])
#: Camera of the test spheres: distance from the centre of the unit sphere, vertical field.
EYE_DISTANCE, FOV_Y = 3.0, 45.0

_GLSL_MAIN = """
uniform sampler2D normals;      // per pixel: unit normal N (RGB32F)
uniform sampler2D views;        // unit direction toward the eye V
uniform sampler2D materials;    // albedo (rgb), perceptual roughness (a)
uniform sampler2D reflectance;  // F0 (rgb)
layout(location = 0) out vec4 colourOut;
layout(location = 1) out vec4 prefilteredOut;
layout(location = 2) out vec4 termsOut;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec3 n = texelFetch(normals, p, 0).xyz;
    vec3 v = texelFetch(views, p, 0).xyz;
    vec4 m = texelFetch(materials, p, 0);
    vec3 f0 = texelFetch(reflectance, p, 0).xyz;
    float NoV = max(dot(n, v), 0.0);
    colourOut = vec4(shlight_ibl(n, v, m.rgb, f0, m.a), 1.0);
    prefilteredOut = vec4(shlight_prefiltered_radiance(reflect(-v, n), m.a), 1.0);
    termsOut = vec4(shlight_env_brdf_scale_bias(m.a, NoV), shlight_specular_lod(m.a), NoV);
}
"""

_HLSL_MAIN = """#include "ibl.hlsl"
Texture2D<float4> _Normals;
Texture2D<float4> _Views;
Texture2D<float4> _Materials;
Texture2D<float4> _Reflectance;
struct Targets
{
    float4 colour : SV_Target0;
    float4 prefiltered : SV_Target1;
    float4 terms : SV_Target2;
};
Targets main(float4 position : SV_Position)
{
    int3 p = int3(position.xy, 0);
    float3 n = _Normals.Load(p).xyz;
    float3 v = _Views.Load(p).xyz;
    float4 m = _Materials.Load(p);
    float3 f0 = _Reflectance.Load(p).xyz;
    float NoV = max(dot(n, v), 0.0);
    Targets t;
    t.colour = float4(shlight_ibl(n, v, m.rgb, f0, m.a), 1.0);
    t.prefiltered = float4(shlight_prefiltered_radiance(reflect(-v, n), m.a), 1.0);
    t.terms = float4(shlight_env_brdf_scale_bias(m.a, NoV), shlight_specular_lod(m.a), NoV);
    return t;
}
"""

#: Texture units of the evaluator's samplers (matched by name; HLSL names are mangled).
_UNITS = (("ormals", 0), ("iews", 1), ("aterials", 2), ("eflectance", 3), ("nvironment", 4))
#: A renderer in Unity's left-handed frame (z -> -z) maps its directions back to the cube's.
UNITY_DIRECTION = {"glsl": "vec3((d).x, (d).y, -(d).z)", "hlsl": "float3((d).x, (d).y, -(d).z)"}
HLSL_GLOBALS = ("_SHIrradianceR", "_SHIrradianceG", "_SHIrradianceB")
TARGET_WIDTH = 256


class IblEvaluator:
    """Renders ``shlight_ibl`` and its parts through one shader path, one fragment per input.

    ``direction``: a body for SHLIGHT_ENVIRONMENT_DIRECTION(d) (None: the default, d).
    """

    def __init__(self, ctx, path: str = "glsl", direction: str | None = None):
        self.ctx, self.path = ctx, path
        define = ("" if direction is None else
                  f"#define SHLIGHT_ENVIRONMENT_DIRECTION(d) {direction}\n")
        self._block = self._ubo = None
        if path == "glsl":
            fragment = ("#version 330 core\n" + define + shader_source("sh9_irradiance.glsl")
                        + shader_source("ibl.glsl") + _GLSL_MAIN)
            self.program = ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=fragment)
        elif path == "hlsl":
            from .hlsl import HlslCompileError, hlsl_fragment_to_glsl
            compiled = hlsl_fragment_to_glsl(define + _HLSL_MAIN)
            self.glsl = compiled.glsl
            self.program = ctx.program(vertex_shader=VERTEX_SHADER, fragment_shader=compiled.glsl)
            if compiled.block:
                offsets = compiled.member_offsets()
                wanted = HLSL_GLOBALS + ("_SHEnvironmentMipCount",)
                if not all(g in offsets for g in wanted):
                    raise HlslCompileError(f"HLSL globals {wanted} not found in uniform block "
                                           f"{compiled.block}: {compiled.members}")
                self._block = (offsets, {n: rm for n, _, rm in compiled.members})
                self._ubo = ctx.buffer(reserve=max(offsets.values()) + 64)
                self.program[compiled.block].binding = 1
        else:
            raise ValueError(f"path must be 'glsl' or 'hlsl', got {path!r}")
        for name in self.program:
            for key, unit in _UNITS:
                if key in name and hasattr(self.program[name], "value"):
                    self.program[name].value = unit
        self.vao = ctx.vertex_array(self.program, [])

    def _set_uniforms(self, matrices, mip_count: int) -> None:
        m = np.asarray(matrices, np.float64).reshape(3, 4, 4)
        if self._block is None:
            set_irradiance_matrices(self.program, m)
            if "shEnvironmentMipCount" in self.program:
                self.program["shEnvironmentMipCount"].value = int(mip_count)
            return
        offsets, row_major = self._block
        data = bytearray(self._ubo.size)
        for name, mc in zip(HLSL_GLOBALS, m):
            mem = mc.T if row_major[name] else mc     # see harness.IrradianceEvaluator
            data[offsets[name]:offsets[name] + 64] = np.ascontiguousarray(mem, np.float32).tobytes()
        o = offsets["_SHEnvironmentMipCount"]
        data[o:o + 4] = np.int32(mip_count).tobytes()
        self._ubo.write(bytes(data))

    def evaluate(self, cube, mip_count: int, matrices, normals, views, albedo, f0, roughness):
        """{"colour", "prefiltered", "terms"}: (N, 3), (N, 3), (N, 4) float32 for the inputs
        (N, 3) / (N,) with ``cube`` a texture from :func:`cubemap.upload_cube`."""
        n = np.asarray(normals, np.float32).reshape(-1, 3)
        count = len(n)
        w = min(TARGET_WIDTH, count)
        h = -(-count // w)

        def image(values, comps):
            out = np.zeros((w * h, comps), np.float32)
            out[:count] = np.asarray(values, np.float32).reshape(count, comps)
            return out

        mat = np.hstack([np.asarray(albedo, np.float32).reshape(-1, 3),
                         np.asarray(roughness, np.float32).reshape(-1, 1)])
        ctx = self.ctx
        inputs = [ctx.texture((w, h), c, image(v, c).tobytes(), dtype="f4")
                  for v, c in ((n, 3), (views, 3), (mat, 4), (f0, 3))]
        targets = [ctx.texture((w, h), 4, dtype="f4") for _ in range(3)]
        fbo = ctx.framebuffer(color_attachments=targets)
        try:
            for unit, tex in enumerate(inputs):
                tex.filter = (ctx.NEAREST, ctx.NEAREST)
                tex.use(unit)
            cube.use(4)
            self._set_uniforms(matrices, mip_count)
            if self._ubo is not None:
                self._ubo.bind_to_uniform_block(1)
            fbo.use()
            fbo.viewport = (0, 0, w, h)
            fbo.clear(0.0, 0.0, 0.0, 0.0)
            self.vao.render(mode=ctx.TRIANGLES, vertices=3)
            out = [np.frombuffer(fbo.read(components=4, attachment=i, dtype="f4"), np.float32)
                   .reshape(-1, 4)[:count].copy() for i in range(3)]
        finally:
            for obj in (fbo, *targets, *inputs):
                obj.release()
        return {"colour": out[0][:, :3], "prefiltered": out[1][:, :3], "terms": out[2]}


# -- the CPU reference -------------------------------------------------------------------------------

def env_brdf_scale_bias(roughness, NoV) -> np.ndarray:
    """Karis's (A, B), float64 (…, 2): EnvBRDFApprox = F0·A + B (roughness clamped to 0..1)."""
    r = np.clip(np.asarray(roughness, np.float64), 0, 1)[..., None] * DFG_C0 + DFG_C1
    a004 = np.minimum(r[..., 0] ** 2, np.exp2(-9.28 * np.asarray(NoV, np.float64))) * r[..., 0] \
        + r[..., 1]
    return np.stack([-1.04 * a004 + r[..., 2], 1.04 * a004 + r[..., 3]], -1)


def specular_lod(roughness, mip_count: int) -> np.ndarray:
    """lod = clamp(roughness, 0, 1) · (mip_count − 1) (CUBE_CONTRACT: roughness[k] = k/(m − 1))."""
    return np.clip(np.asarray(roughness, np.float64), 0, 1) * (mip_count - 1)


def reference(sampler: cubemap.CubeSampler, matrices, normals, views, albedo, f0, roughness):
    """The shipped formula in float64 on the float32 inputs the shader saw: a dict with
    colour, prefiltered, terms (A, B, lod, N·V) and the error measure's scale (N, 3)."""
    f32 = lambda x, c: np.asarray(x, np.float32).astype(np.float64).reshape(-1, c)  # noqa: E731
    n, v, rho, F0 = f32(normals, 3), f32(views, 3), f32(albedo, 3), f32(f0, 3)
    rough = f32(roughness, 1)[:, 0]
    M = np.asarray(matrices, np.float64).reshape(3, 4, 4)
    dot = np.sum(n * v, axis=-1)
    NoV = np.maximum(dot, 0.0)
    R = 2 * dot[:, None] * n - v
    lod = specular_lod(rough, len(sampler.mips))
    pf, taps = sampler.sample(R, lod)
    ab = env_brdf_scale_bias(rough, NoV)
    brdf = F0 * ab[:, :1] + ab[:, 1:]
    E = sh.irradiance_from_matrices(M, n)
    colour = rho * np.maximum(E, 0) / math.pi + pf[:, :3] * brdf
    scale = (np.abs(rho) * sh.irradiance_from_matrices(np.abs(M), np.abs(n)) / math.pi
             + taps[:, None] * (np.abs(F0 * ab[:, :1]) + np.abs(ab[:, 1:])))
    terms = np.column_stack([ab, lod, NoV])
    return {"colour": colour, "prefiltered": pf[:, :3], "terms": terms, "scale": scale,
            "taps": taps}


# -- spheres -------------------------------------------------------------------------------------------

def sphere_view(size: int, eye, fov_y: float = FOV_Y):
    """A unit sphere at the origin ray-cast from a perspective camera at ``eye`` looking at the
    centre (+Y up). Returns (normals (S, S, 3), views (S, S, 3), mask (S, S), rays (S, S, 3)),
    row 0 at the top of the image, column 0 at its left; V is the unit direction to the eye."""
    eye = np.asarray(eye, np.float64)
    cam = look_at(eye)[:3, :3]                        # rows: right, up, backward
    c = (np.arange(size) + 0.5) / size * 2 - 1
    y, x = np.meshgrid(-c, c, indexing="ij")          # top row first
    f = math.tan(math.radians(fov_y) / 2)
    rays = np.stack([x * f, y * f, -np.ones_like(x)], -1) @ cam   # eye -> world
    rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    b = np.sum(rays * eye, -1)
    disc = b * b - (eye @ eye - 1.0)
    mask = disc > 0
    t = -b - np.sqrt(np.maximum(disc, 0))
    hit = eye + t[..., None] * rays
    normals = hit / np.linalg.norm(hit, axis=-1, keepdims=True)
    views = -rays
    return normals, views, mask, rays


#: Cameras for the comparisons: the front, above-right, behind-left and from below.
CAMERAS = ((0.0, 0.0, EYE_DISTANCE), (1.8, 1.8, 1.8), (-2.2, 0.4, -2.0), (0.3, -2.9, 0.6))


def sphere_inputs(size: int = 96, seed: int = contract.RANDOM_SEED, roughness=None):
    """Per-pixel inputs of glossy spheres seen by :data:`CAMERAS`: (normals, views, albedo,
    f0, roughness) over the sphere pixels. Roughness is uniform in [−0.05, 1.05] (both
    clamps) plus the mip roughnesses exactly, unless given."""
    rng = np.random.default_rng(seed)
    parts = [sphere_view(size, eye) for eye in CAMERAS]
    n = np.concatenate([p[0][p[2]] for p in parts])
    v = np.concatenate([p[1][p[2]] for p in parts])
    count = len(n)
    if roughness is None:
        rough = rng.uniform(-0.05, 1.05, count)
        rough[: count // 8] = np.round(rough[: count // 8] * 8) / 8
    else:
        rough = np.broadcast_to(np.asarray(roughness, np.float64), count).copy()
    albedo = rng.uniform(0.0, 1.0, (count, 3))
    f0 = rng.uniform(0.02, 1.0, (count, 3))
    return n, v, albedo, f0, rough


# -- cases and comparisons ---------------------------------------------------------------------------

def lobes(directions, k: int) -> np.ndarray:
    """A smooth, asymmetric test environment (no face or flip is invariant), different on
    every mip k so that the lod matters: a constant, a gradient and three coloured lobes."""
    d = np.asarray(directions, np.float64)
    axes = np.array([[0.6, 0.7, -0.38], [-0.8, 0.1, 0.59], [0.2, -0.9, 0.39]])
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    sharp = 24.0 / (1 + 2 * k)
    out = 0.2 + 0.1 * k + 0.15 * (d @ np.array([[0.5, 0.2, 0.1], [0.0, 0.4, 0.2],
                                                 [0.3, 0.0, -0.5]]))
    colours = np.array([[3.0, 1.0, 0.2], [0.3, 2.0, 0.5], [0.4, 0.6, 5.0]])
    for a, col in zip(axes, colours):
        out = out + np.exp(sharp * (d @ a - 1))[..., None] * col
    return out


def one_sided(directions, k: int) -> np.ndarray:
    """Bright only on the faces +X (red 4), +Y (green 4) and −Z (blue 4); black elsewhere."""
    face = cubemap.direction_to_face(directions)[0]
    out = np.zeros(np.shape(directions)[:-1] + (3,))
    for f, channel in ((0, 0), (2, 1), (5, 2)):
        out[face == f, channel] = 4.0
    return out


@dataclass
class IblCase:
    """A cube (its mips, the upload precision) and SH9 matrices to light spheres with."""
    name: str
    mips: list
    matrices: np.ndarray
    dtype: str = "f4"
    face_order: tuple = (0, 1, 2, 3, 4, 5)
    independent: str = ""            # "furnace": colour = albedo + F0·A + B exactly
    note: str = ""

    def tolerance(self, factor: float = 1.0) -> float:
        return ibl_tolerance(self.mips[0].shape[1]) * factor

    def reference_mips(self) -> list:
        """The mips as the GPU holds them (float16-rounded for an RGBA16F upload)."""
        return [m[..., :3].astype(np.float64) for m in cubemap.as_rgba(self.mips, self.dtype)]


@dataclass
class IblComparison:
    """One IBL case through one shader path."""
    case: str
    path: str
    pixels: int
    max_rel: float            # max |colour_gpu − colour_cpu| / scale
    rms_rel: float            # relative RMS of the colour difference
    prefiltered_max_rel: float
    terms_max_abs: float      # max |A, B, lod, N·V gpu − cpu|
    independent_max_rel: float | None
    tolerance: float
    note: str = ""
    passed: bool = field(default=False)
    #: the colour's and the lookup's tolerance: ``tolerance``, or on a hardware texture unit
    #: at least :data:`HARDWARE_FILTER_TOLERANCE` (the terms keep ``tolerance``)
    lookup_tolerance: float | None = None

    def line(self) -> str:
        ind = ("" if self.independent_max_rel is None else
               f"  indep {self.independent_max_rel:.1e}")
        return (f"{'PASS' if self.passed else 'FAIL'}  {self.path:4s}  {self.case:28s} "
                f"max {self.max_rel:.2e}  rms {self.rms_rel:.2e}  prefiltered "
                f"{self.prefiltered_max_rel:.2e}  terms {self.terms_max_abs:.1e}{ind} "
                f"(tolerance {self.tolerance:.1e}{self._lookup()}, {self.pixels} pixels)")

    def _lookup(self) -> str:
        if self.lookup_tolerance is None or self.lookup_tolerance == self.tolerance:
            return ""
        return f"; lookup {self.lookup_tolerance:.1e}: hardware filtering"


def judge(case: IblCase, path: str, got: dict, want: dict, inputs,
          tolerance: float | None = None, hardware_filter: bool = False) -> IblComparison:
    """The verdict on the GPU outputs ``got`` against the reference ``want`` (``tolerance``:
    None for :func:`ibl_tolerance` of the case's cube). ``hardware_filter``: the cube was
    sampled by a hardware texture unit (8-bit filter weights), so the lookup and the colour
    are held to :data:`HARDWARE_FILTER_TOLERANCE` at least; the shader's own terms are not."""
    if tolerance is None:
        tolerance = case.tolerance()
    lookup = max(tolerance, HARDWARE_FILTER_TOLERANCE) if hardware_filter else tolerance
    scale = np.maximum(want["scale"], 1e-30)
    err = np.abs(got["colour"] - want["colour"]) / scale
    pf_err = (np.abs(got["prefiltered"] - want["prefiltered"])
              / np.maximum(want["taps"], 1e-30)[:, None])
    terms = np.abs(got["terms"] - want["terms"])
    terms[:, 2] /= max(len(case.mips) - 1, 1)         # lod relative to its range
    ind = None
    if case.independent == "furnace":
        _, _, albedo, f0, _ = inputs
        ab = want["terms"][:, :2]
        exact = np.asarray(albedo, np.float32) + np.asarray(f0, np.float32) * ab[:, :1] + ab[:, 1:]
        ind = float(np.max(np.abs(got["colour"] - exact) / scale))
    r = IblComparison(case.name, path, len(err), float(err.max()),
                      sh.relative_rms(got["colour"], want["colour"]), float(pf_err.max()),
                      float(terms.max()), ind, tolerance, case.note, lookup_tolerance=lookup)
    r.passed = bool(r.max_rel <= lookup and r.prefiltered_max_rel <= lookup
                    and r.terms_max_abs <= tolerance and (ind is None or ind <= tolerance)
                    and np.all(np.isfinite(got["colour"])))
    return r


def run_case(evaluator: IblEvaluator, case: IblCase, inputs,
             tolerance: float | None = None, hardware_filter: bool = False) -> IblComparison:
    """Render ``case`` on spheres (:func:`sphere_inputs`) and judge it against the reference."""
    got, want = render_and_reference(evaluator, case, inputs)
    return judge(case, evaluator.path, got, want, inputs, tolerance, hardware_filter)


def render_and_reference(evaluator: IblEvaluator, case: IblCase, inputs):
    """(GPU outputs, CPU reference) of ``case`` for ``inputs`` (normals, views, albedo, f0,
    roughness)."""
    cube = cubemap.upload_cube(evaluator.ctx, case.mips, case.dtype, case.face_order)
    try:
        got = evaluator.evaluate(cube, len(case.mips), case.matrices, *inputs)
    finally:
        cube.release()
    want = reference(cubemap.CubeSampler(case.reference_mips()), case.matrices, *inputs)
    return got, want


def synthetic_cases(size: int = 32) -> list[IblCase]:
    """Lobes (RGBA32F and RGBA16F), the furnace, and the one-sided cube."""
    random_m = sh.irradiance_matrices(contract.random_coefficients())
    lobe_mips = cubemap.cube_from_function(lobes, size)
    return [
        IblCase("ibl:lobes", lobe_mips, random_m, note="analytic cube, random SH9, RGBA32F"),
        IblCase("ibl:lobes_rgba16f", lobe_mips, random_m, dtype="f2",
                note="the same cube uploaded as RGBA16F"),
        IblCase("ibl:furnace", cubemap.cube_from_function(
            lambda d, k: np.ones(d.shape[:-1] + (3,)), size),
            sh.irradiance_matrices(contract.furnace_coefficients()), independent="furnace",
            note="radiance 1 everywhere: colour = albedo + F0 A + B"),
        IblCase("ibl:one_sided", cubemap.cube_from_function(one_sided, size),
                np.zeros((3, 4, 4)), note="bright +X (red), +Y (green), -Z (blue)"),
    ]


def panorama_cases(paths, size: int = 32) -> list[IblCase]:
    """Each panorama's cube (:func:`cubemap.cube_from_equirect`, RGBA16F as the wire sends it)
    and its SH9."""
    from ..core.sh9.engine import compute_sh9
    from ..core.radiometry.images import read_image
    cases = []
    for path in paths:
        image = read_image(path)
        cases.append(IblCase(f"ibl:panorama:{Path(path).stem}",
                             cubemap.cube_from_equirect(image, size),
                             compute_sh9(image, error_estimate=False).matrices, dtype="f2",
                             note="panorama cube, RGBA16F"))
    return cases


def unity_frame_check(ctx, path: str, inputs, tolerance: float | None = None,
                      hardware_filter: bool = False) -> IblComparison:
    """The lobes case seen from Unity's left-handed frame: normals, views and matrices z-flipped,
    SHLIGHT_ENVIRONMENT_DIRECTION(d) = (d.x, d.y, −d.z): the same colours as in our frame."""
    case = synthetic_cases()[0]
    evaluator = IblEvaluator(ctx, path, UNITY_DIRECTION[path])
    n, v, albedo, f0, rough = inputs
    S3, S4 = np.diag([1.0, 1.0, -1.0]), np.diag([1.0, 1.0, -1.0, 1.0])
    flipped = IblCase("ibl:unity_frame", case.mips, S4 @ case.matrices @ S4,
                      note="z-flipped inputs, SHLIGHT_ENVIRONMENT_DIRECTION flips back")
    cube = cubemap.upload_cube(ctx, case.mips)
    try:
        got = evaluator.evaluate(cube, len(case.mips), flipped.matrices, n @ S3, v @ S3,
                                 albedo, f0, rough)
    finally:
        cube.release()
    want = reference(cubemap.CubeSampler(case.reference_mips()), case.matrices, *inputs)
    return judge(flipped, path, got, want, inputs, tolerance, hardware_filter)
