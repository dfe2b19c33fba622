"""`shlight validate-shaders`, lights: the shipped ambient + directional-lights functions
(shaders/sh9_lights.glsl and .hlsl, docs/contract.md §10) against the CPU, and a picture of what
lights change.

The GLSL and HLSL paths are those of :mod:`provider.verify.harness` (the HLSL through
glslang → SPIR-V → spirv-cross): every case renders E(n) = ñᵀAñ + Σ_k I_k max(0, n·d_k)
(``shIrradianceWithLights`` / ``SHIrradianceWithLights``, and the unclamped function) for
dense normals into float32 targets and compares with the float64 CPU value. The error
measure is the harness's, with the magnitude sum of the light terms added to the scale:
``|E_gpu − E_cpu| / (|ñ|ᵀ|A||ñ| + Σ_k |I_k| (|n|·|d_k|))`` ≤ 32 float32 round-offs.

Cases: one light from (2, 1, -2)/3 only (independent answer: E = I·max(0, n·d)); no light
(must equal SH9 alone); four random lights; more slots uploaded than ``count`` (the unused
slots must not light anything); the engine's lights for each panorama (``lights="auto"``);
and the lights cases of the contract vectors, in both frames.

The shadow functions against :mod:`provider.core.lights.shadows` (measures: each section):
the ratio (``shShadowRatio``) with each light's visibility a uniform at several visibilities
(``shadow:*``); the occluder's ambient occlusion and the ratio fed with it under occluders
overhead, wide and around the receiver (``shadow:occluded_*``); each light's visibility past
a sphere (``shSphereLightVisibility``) for a point, a sun, a lamp and a window behind far,
near and surrounding spheres (``shadow:sphere_light:*``). The HLSL twins the same way.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..core.geometry import sh
from ..core.lights.shadows import occluded_ambient, shadow_ratio, sphere_light_visibility
from ..core.sh9.engine import compute_sh9
from ..core.radiometry.images import read_image
from . import contract
from .harness import (FLOAT32_TOLERANCE, HLSL_GLOBALS, Comparison, DemoCheck, DISPLAY_TOLERANCE,
                      IrradianceEvaluator, glsl_evaluator, hlsl_evaluator, judge)
from .pictures import (LightsObjectRenderer, lights_picture,  # noqa: F401 (lights' API)
                       write_lights_picture)
from .render import (MAX_LIGHTS, _slots, set_uniform, shader_source, srgb_encode,  # noqa: F401
                     tone_map, upload_lights)

GLSL_EVALUATOR = glsl_evaluator("shIrradianceWithLights")
HLSL_EVALUATOR = hlsl_evaluator("sh9_lights.hlsl", "SHIrradianceWithLights")


class LightsEvaluator(IrradianceEvaluator):
    """Renders ambient + lights E(n) through one shader path ("glsl" or "hlsl")."""

    def __init__(self, ctx, path: str = "glsl"):
        source = (shader_source("sh9_lights.glsl") + GLSL_EVALUATOR if path == "glsl"
                  else HLSL_EVALUATOR)
        super().__init__(ctx, path, source)
        self._lights = (_slots([], []), 0)

    def set_lights(self, directions, irradiance, count=None) -> None:
        n = len(np.asarray(directions).reshape(-1, 3)) if count is None else int(count)
        self._lights = (_slots(directions, irradiance), n)

    def set_matrices(self, matrices) -> None:
        slots, count = self._lights
        if self._block is None:
            super().set_matrices(matrices)
            upload_lights(self.program, slots[0, :, :3], slots[1, :, :3], count)
            return
        _, offsets, row_major = self._block
        data = bytearray(self._ubo.size)
        for name, mc in zip(HLSL_GLOBALS, np.asarray(matrices, np.float64).reshape(3, 4, 4)):
            mem = mc.T if row_major[name] else mc      # see IrradianceEvaluator.set_matrices
            data[offsets[name]:offsets[name] + 64] = np.ascontiguousarray(mem, np.float32).tobytes()
        for name, values in (("_SHLightDirection", slots[0]), ("_SHLightIrradiance", slots[1])):
            data[offsets[name]:offsets[name] + values.nbytes] = values.tobytes()
        o = offsets["_SHLightCount"]
        data[o:o + 4] = np.int32(count).tobytes()
        self._ubo.write(bytes(data))

    def evaluate_lights(self, matrices, directions, irradiance, normals, count=None):
        """(clamped, unclamped) E at ``normals`` (N, 3) for these ambient matrices and lights."""
        self.set_lights(directions, irradiance, count)
        return self.evaluate(matrices, normals)


# -- cases and comparisons ------------------------------------------------------------------------

@dataclass
class LightCase:
    """Ambient matrices and lights to upload; ``count`` < len(directions) leaves slots unused."""
    name: str
    matrices: np.ndarray                       # (3, 4, 4) ambient
    directions: np.ndarray                     # (k, 3) unit, toward each light
    irradiance: np.ndarray                     # (k, 3)
    count: int | None = None
    normals: np.ndarray | None = None
    independent: np.ndarray | None = None
    independent_kind: str = ""
    note: str = ""


def cpu_irradiance(case: LightCase, normals) -> tuple[np.ndarray, np.ndarray]:
    """(E, scale) in float64 at ``normals``: E = ñᵀAñ + Σ_k I_k max(0, n·d_k) over the first
    ``count`` lights; scale = |ñ|ᵀ|A||ñ| + Σ_k |I_k| (|n|·|d_k|), the error measure's."""
    n = np.asarray(normals, np.float64)
    k = len(case.directions) if case.count is None else case.count
    d = np.asarray(case.directions, np.float64).reshape(-1, 3)[:k]
    irr = np.asarray(case.irradiance, np.float64).reshape(-1, 3)[:k]
    M = np.asarray(case.matrices, np.float64)
    E = sh.irradiance_from_matrices(M, n) + np.maximum(n @ d.T, 0.0) @ irr
    scale = (sh.irradiance_from_matrices(np.abs(M), np.abs(n))
             + (np.abs(n) @ np.abs(d).T) @ np.abs(irr))
    return E, scale


def compare_lights(case: LightCase, path: str, clamped, unclamped, normals,
                   tolerance: float = FLOAT32_TOLERANCE) -> Comparison:
    """Rendered E against the float64 CPU value (and the case's independent answer)."""
    n = np.asarray(normals, np.float32).astype(np.float64)   # what the shader saw
    exact, scale = cpu_irradiance(case, n)
    return judge(case, path, clamped, unclamped, exact, scale, tolerance)


def synthetic_light_cases(normals: np.ndarray) -> list[LightCase]:
    """One light from one side only, no light, four random lights, unused slots."""
    d, irr = contract.ONE_SIDED_LIGHT
    zero = np.zeros((3, 4, 4))
    random_m = sh.irradiance_matrices(contract.random_coefficients())
    rng = np.random.default_rng(contract.RANDOM_SEED)
    dirs = rng.normal(size=(MAX_LIGHTS, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    powers = rng.uniform(0.5, 20.0, size=(MAX_LIGHTS, 3))
    n32 = normals.astype(np.float32).astype(np.float64)
    return [
        LightCase("lights:one_sided", zero, d[None], irr[None],
                  independent=np.maximum(n32 @ d, 0.0)[:, None] * irr, independent_kind="analytic",
                  note="one light from (2,1,-2)/3, no ambient: E = I max(0, n.d)"),
        LightCase("lights:none", random_m, np.zeros((0, 3)), np.zeros((0, 3)),
                  independent=sh.irradiance_from_matrices(random_m, n32),
                  independent_kind="vectors", note="no light: exactly SH9"),
        LightCase(f"lights:{MAX_LIGHTS}_random", random_m, dirs, powers,
                  note="every slot in use"),
        LightCase("lights:count_2_of_4", random_m, dirs, powers, count=2,
                  note="slots beyond shLightCount must not light anything"),
    ]


def panorama_light_cases(paths) -> list[LightCase]:
    """The engine's ambient + lights (``lights="auto"``) of each panorama."""
    cases = []
    for path in paths:
        r = compute_sh9(read_image(path), error_estimate=False, lights="auto")
        d = np.array([light.direction for light in r.lights]).reshape(-1, 3)
        irr = np.array([light.irradiance for light in r.lights]).reshape(-1, 3)
        cases.append(LightCase(f"lights:panorama:{Path(path).stem}", r.ambient_matrices, d, irr,
                               note=f"{len(d)} light(s) from the engine"))
    return cases


def vector_light_cases(vectors: dict) -> list[LightCase]:
    """Each lights case of the contract vectors, right-handed and in Unity's frame."""
    cases = []
    for c in vectors["cases"]:
        if "lights" not in c:
            continue
        for frame, prefix in (("", "lights-vectors"), ("unity_", "lights-vectors-unity")):
            cases.append(LightCase(
                f"{prefix}:{c['name']}", c[f"{frame}ambient_matrices"],
                c[f"{frame}light_directions"], c["light_irradiance"],
                normals=c[f"{frame}normals"], independent=c["irradiance_with_lights"],
                independent_kind="vectors", note="contract vectors, lights"))
    return cases


def run_light_cases(evaluator: LightsEvaluator, cases, normals,
                    tolerance: float = FLOAT32_TOLERANCE) -> list[Comparison]:
    out = []
    for case in cases:
        n = normals if case.normals is None else np.asarray(case.normals, np.float64)
        clamped, unclamped = evaluator.evaluate_lights(case.matrices, case.directions,
                                                       case.irradiance, n, case.count)
        out.append(compare_lights(case, evaluator.path, clamped, unclamped, n, tolerance))
    return out


# -- the demo program with lights (shaders/lit_diffuse_lights.frag) and the picture ---------------

def lit_diffuse_lights_check(ctx, size: int = 96) -> DemoCheck:
    """lit_diffuse_lights.frag against its numpy twin (ρ·max(E, 0)/π, Reinhard, sRGB) on a
    torus lit by a uniform ambient and the one-sided light."""
    renderer = LightsObjectRenderer(ctx, size)
    ambient = sh.irradiance_matrices(contract.furnace_coefficients(0.1))
    d, irr = contract.ONE_SIDED_LIGHT
    renderer.set_lights(ambient, d[None], irr[None])
    albedo, exposure = (0.8, 0.6, 0.4), 0.7
    for name, value in (("albedo", albedo), ("exposure", exposure), ("toneMap", 1),
                        ("srgbOutput", True)):
        set_uniform(renderer.lit, name, value)
    shown, normals, mask = renderer.render("torus")
    n = normals[mask].astype(np.float64)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    E = sh.irradiance_from_matrices(ambient, n) + np.maximum(n @ d, 0.0)[:, None] * irr
    want = srgb_encode(tone_map(np.asarray(albedo) * np.maximum(E, 0) / math.pi * exposure,
                                "reinhard"))
    err = float(np.abs(shown[mask] - want).max())
    return DemoCheck("lights_one_sided_reinhard", err, DISPLAY_TOLERANCE, int(mask.sum()),
                     bool(err <= DISPLAY_TOLERANCE and mask.sum() > 0))


# -- the harness extension (provider.verify.harness.run) ------------------------------------------

def compare(ctx, path: str, normals, panoramas, vectors, tolerance) -> list[Comparison]:
    """Every lights case through one shader path ("glsl" or "hlsl")."""
    evaluator = LightsEvaluator(ctx, path)
    cases = synthetic_light_cases(normals) + panorama_light_cases(panoramas)
    if vectors is not None:
        cases += vector_light_cases(vectors)
    out = run_light_cases(evaluator, cases, normals, tolerance)
    out += run_shadow_cases(ShadowEvaluator(ctx, path), shadow_cases(normals, panoramas),
                            normals, tolerance)
    out += run_sphere_light_cases(ctx, path, normals,
                                  tolerance * OCCLUDED_TOLERANCE / FLOAT32_TOLERANCE)
    return out + run_occluded_cases(ctx, path, occluded_cases(normals, panoramas), normals,
                                    tolerance * OCCLUDED_TOLERANCE / FLOAT32_TOLERANCE)


# -- the shadow ratio (shShadowRatio / SHShadowRatio) -------------------------------------------

SHADOW_GLSL_EVALUATOR = glsl_evaluator("shShadowRatio", args="n, shadowVisibility",
                                       uniforms="uniform vec4 shadowVisibility;",
                                       unclamped=False)
SHADOW_HLSL_EVALUATOR = hlsl_evaluator("sh9_lights.hlsl", "SHShadowRatio",
                                       args="n, _ShadowVisibility",
                                       uniforms="float4 _ShadowVisibility;", unclamped=False)

#: Visibilities of lights 0..3 per shadow case: all visible (ratio exactly 1), none, mixed,
#: and out of [0, 1] (the shaders clamp; the CPU reference gets the clamped values).
SHADOW_VISIBILITIES = {"open": (1.0, 1.0, 1.0, 1.0), "shadowed": (0.0, 0.0, 0.0, 0.0),
                       "mixed": (0.25, 1.0, 0.0, 0.6), "clamped": (-0.5, 1.5, 0.5, 2.0)}


class ShadowEvaluator(LightsEvaluator):
    """Renders ``shShadowRatio(n, visibility)`` / ``SHShadowRatio`` through one path."""

    #: The vec4 uniforms set with the matrices: GLSL name -> (attribute, HLSL name); one
    #: that the evaluated function does not use is optimised away and skipped.
    VEC4_UNIFORMS = {"shadowVisibility": ("visibility", "_ShadowVisibility")}

    def __init__(self, ctx, path: str = "glsl", source: str | None = None):
        if source is None:
            source = (shader_source("sh9_lights.glsl") + SHADOW_GLSL_EVALUATOR
                      if path == "glsl" else SHADOW_HLSL_EVALUATOR)
        IrradianceEvaluator.__init__(self, ctx, path, source)
        self._lights = (_slots([], []), 0)
        self.visibility = np.ones(4, np.float32)

    def set_matrices(self, matrices) -> None:
        LightsEvaluator.set_matrices(self, matrices)
        for name, (attribute, hlsl) in self.VEC4_UNIFORMS.items():
            v = np.asarray(getattr(self, attribute), np.float32).reshape(4)
            if self._block is None:
                if name in self.program:
                    set_uniform(self.program, name, tuple(float(x) for x in v))
            elif hlsl in self._block[1]:
                self._ubo.write(v.tobytes(), offset=self._block[1][hlsl])


def compare_shadow(case: LightCase, visibility, path: str, ratio, normals,
                   tolerance: float = FLOAT32_TOLERANCE) -> Comparison:
    """Rendered ratio against :func:`shadow_ratio` in float64 (error measure: module doc)."""
    n = np.asarray(normals, np.float32).astype(np.float64)
    k = len(case.directions) if case.count is None else case.count
    d = np.asarray(case.directions, np.float64).reshape(-1, 3)[:k]
    irr = np.asarray(case.irradiance, np.float64).reshape(-1, 3)[:k]
    v = np.clip(np.asarray(visibility, np.float64), 0.0, 1.0)[:k]
    exact = shadow_ratio(n, case.matrices, d, irr, v)
    M = np.asarray(case.matrices, np.float64)
    open_ = (np.maximum(sh.irradiance_from_matrices(M, n), 0.0)
             + np.maximum(n @ d.T, 0.0) @ irr)
    magnitude = (sh.irradiance_from_matrices(np.abs(M), np.abs(n))
                 + (np.abs(n) @ np.abs(d).T) @ np.abs(irr))
    scale = np.where(open_ > 0, 2.0 * magnitude / np.where(open_ > 0, open_, 1.0), np.inf)
    return judge(case, path, ratio, ratio, exact, scale, tolerance)


def shadow_cases(normals, panoramas) -> list[tuple[LightCase, str, tuple]]:
    """(light case, visibility name, visibility) for every synthetic light set and the
    first panorama with lights, at each of :data:`SHADOW_VISIBILITIES`."""
    sets = [c for c in synthetic_light_cases(normals) if c.name != "lights:none"]
    for case in panorama_light_cases(panoramas):
        if len(case.directions):
            sets.append(case)
            break
    out = []
    for case in sets:
        for vname, v in SHADOW_VISIBILITIES.items():
            shadow = LightCase(f"shadow:{case.name.split(':', 1)[1]}:{vname}", case.matrices,
                               case.directions, case.irradiance, count=case.count,
                               note=f"shadow ratio, visibility {v}")
            out.append((shadow, vname, v))
    return out


def run_shadow_cases(evaluator: ShadowEvaluator, cases, normals,
                     tolerance: float = FLOAT32_TOLERANCE) -> list[Comparison]:
    out = []
    for case, _, v in cases:
        evaluator.visibility = np.asarray(v, np.float32)
        evaluator.set_lights(case.directions, case.irradiance, case.count)
        ratio, _ = evaluator.evaluate(case.matrices, normals)
        out.append(compare_shadow(case, v, evaluator.path, ratio, normals, tolerance))
    return out


# -- the occluder's ambient occlusion (shOccludedAmbient, shShadowRatioOccluded) ---------------

OCCLUDED_GLSL_EVALUATORS = {
    "ambient": glsl_evaluator("shOccludedAmbient", args="n, occluder.xyz, occluder.w",
                              uniforms="uniform vec4 occluder;", unclamped=False),
    "ratio": glsl_evaluator("shShadowRatioOccluded",
                            args="n, shadowVisibility, shOccludedAmbient(n, occluder.xyz, "
                                 "occluder.w)",
                            uniforms="uniform vec4 shadowVisibility;\nuniform vec4 occluder;",
                            unclamped=False)}
OCCLUDED_HLSL_EVALUATORS = {
    "ambient": hlsl_evaluator("sh9_lights.hlsl", "SHOccludedAmbient",
                              args="n, _Occluder.xyz, _Occluder.w",
                              uniforms="float4 _Occluder;", unclamped=False),
    "ratio": hlsl_evaluator("sh9_lights.hlsl", "SHShadowRatioOccluded",
                            args="n, _ShadowVisibility, SHOccludedAmbient(n, _Occluder.xyz, "
                                 "_Occluder.w)",
                            uniforms="float4 _ShadowVisibility;\nfloat4 _Occluder;",
                            unclamped=False)}

#: Error bound of the occluder cases (same measure): the horizon-cut cap uses acos and atan,
#: which shaders do not round correctly (Vulkan's precision table allows 4096 ulp for atan;
#: Mesa llvmpipe is off by 4e-5 of the cap there, 5e-6 of the scale). Everywhere else the
#: occluder terms stay within the float32 bound. validate-shaders' --tolerance scales it.
OCCLUDED_TOLERANCE = 4096 * 2.0 ** -24

#: Occluders per case: (unit direction toward the sphere's centre, sin of its half-angle).
#: Over the dense normals each crosses every receiver horizon: wholly above, cut, below.
OCCLUDERS = {"overhead": ((0.0, 1.0, 0.0), 1 / 3),
             "tilted_wide": ((0.3, 0.8, -0.5), 0.8),
             "inside": ((1.0, 0.0, 0.0), 1.5)}       # sin α ≥ 1: the receiver is inside


class OccludedEvaluator(ShadowEvaluator):
    """Renders ``shOccludedAmbient`` (``what`` = "ambient") or ``shShadowRatioOccluded`` with
    it ("ratio"), and the HLSL twins, for one occluder (a uniform) through one path."""

    VEC4_UNIFORMS = {**ShadowEvaluator.VEC4_UNIFORMS, "occluder": ("occluder", "_Occluder")}

    def __init__(self, ctx, path: str = "glsl", what: str = "ratio"):
        super().__init__(ctx, path, shader_source("sh9_lights.glsl")
                         + OCCLUDED_GLSL_EVALUATORS[what] if path == "glsl"
                         else OCCLUDED_HLSL_EVALUATORS[what])
        self.what = what
        self.occluder = np.array([0.0, 1.0, 0.0, 0.0], np.float32)


def _occluder(direction, sin_half_angle) -> np.ndarray:
    d = np.asarray(direction, np.float64)
    return np.append(d / np.linalg.norm(d), sin_half_angle).astype(np.float32)


def compare_occluded(case: LightCase, occluder, visibility, what: str, path: str, value,
                     normals, tolerance: float = OCCLUDED_TOLERANCE) -> Comparison:
    """Rendered occluded ambient or occluded ratio against :func:`occluded_ambient` /
    :func:`shadow_ratio` in float64. Scale of O: the ambient radiance's magnitude sum toward
    d times π sin²α + 2 sin α (the magnitudes of the cap formula's terms); of the ratio:
    2 (S + that) / D as for the plain ratio."""
    n = np.asarray(normals, np.float32).astype(np.float64)
    occ = np.asarray(occluder, np.float32).astype(np.float64)
    d, s = occ[:3], occ[3]
    M = np.asarray(case.matrices, np.float64)
    o = occluded_ambient(n, M, d, s)
    B = np.abs(M[:, :3, :3])
    radiance_magnitude = (4 * np.abs(d) @ B @ np.abs(d) + 3 * np.abs(M[:, :3, 3]) @ np.abs(d)
                          + np.abs(M[:, 3, 3]) + np.trace(B, axis1=1, axis2=2)) / math.pi
    sc = min(float(s), 1.0)
    o_scale = np.broadcast_to(radiance_magnitude * (math.pi * sc * sc + 2 * sc), o.shape)
    if what == "ambient":
        return judge(case, path, value, value, o, o_scale, tolerance)
    k = len(case.directions) if case.count is None else case.count
    dl = np.asarray(case.directions, np.float64).reshape(-1, 3)[:k]
    irr = np.asarray(case.irradiance, np.float64).reshape(-1, 3)[:k]
    v = np.clip(np.asarray(visibility, np.float64), 0.0, 1.0)[:k]
    exact = shadow_ratio(n, M, dl, irr, v, occluded_ambient=o)
    open_ = np.maximum(sh.irradiance_from_matrices(M, n), 0.0) + np.maximum(n @ dl.T, 0.0) @ irr
    magnitude = (sh.irradiance_from_matrices(np.abs(M), np.abs(n))
                 + (np.abs(n) @ np.abs(dl).T) @ np.abs(irr) + o_scale)
    scale = np.where(open_ > 0, 2.0 * magnitude / np.where(open_ > 0, open_, 1.0), np.inf)
    return judge(case, path, value, value, exact, scale, tolerance)


def occluded_cases(normals, panoramas) -> list[tuple[LightCase, str, np.ndarray, tuple]]:
    """(case, what, occluder, visibility): the occluded ambient and the occluded ratio (at
    the "mixed" visibility) for four random lights over a random ambient and the first
    panorama with lights, under each of :data:`OCCLUDERS`."""
    sets = [c for c in synthetic_light_cases(normals) if c.name == "lights:4_random"]
    for case in panorama_light_cases(panoramas):
        if len(case.directions):
            sets.append(case)
            break
    v = SHADOW_VISIBILITIES["mixed"]
    out = []
    for case in sets:
        for oname, (direction, sin_half) in OCCLUDERS.items():
            for what in ("ambient", "ratio"):
                name = (f"shadow:occluded_{what}:{case.name.split(':', 1)[1]}:{oname}")
                out.append((LightCase(name, case.matrices, case.directions, case.irradiance,
                                      count=case.count,
                                      note=f"occluder {direction}, sin α {sin_half:g}"),
                            what, _occluder(direction, sin_half), v))
    return out


def run_occluded_cases(ctx, path: str, cases, normals,
                       tolerance: float = OCCLUDED_TOLERANCE) -> list[Comparison]:
    evaluators = {what: OccludedEvaluator(ctx, path, what) for what in ("ambient", "ratio")}
    out = []
    for case, what, occluder, v in cases:
        ev = evaluators[what]
        ev.visibility, ev.occluder = np.asarray(v, np.float32), occluder
        ev.set_lights(case.directions, case.irradiance, case.count)
        value, _ = ev.evaluate(case.matrices, normals)
        out.append(compare_occluded(case, occluder, v, what, path, value, normals, tolerance))
    return out

# -- each light's visibility past the occluder (shSphereLightVisibility) --------------------------
# The receiver is at the origin, the sphere's centre at n·distance for every normal n: its
# direction sweeps the sphere of directions (apart, grazing, covering the disc) past one light.

SPHERE_LIGHT_ARGS = "({p}, {v}(n * {at}.x, {at}.y), {light}.xyz, {light}.w)"
SPHERE_LIGHT_EVALUATORS = {
    "glsl": glsl_evaluator("vec3", args="shSphereLightVisibility" + SPHERE_LIGHT_ARGS.format(
        p="vec3(0.0)", v="vec4", at="sphereAt", light="sphereLight"), unclamped=False,
        uniforms="uniform vec4 sphereLight;\nuniform vec4 sphereAt;"),
    "hlsl": hlsl_evaluator("sh9_lights.hlsl", "", args="(float3)SHSphereLightVisibility"
                           + SPHERE_LIGHT_ARGS.format(p="(float3)0.0", v="float4", at="_SphereAt",
                                                      light="_SphereLight"),
                           uniforms="float4 _SphereLight;\nfloat4 _SphereAt;", unclamped=False)}
#: Light radii (degrees: a point, a sun, a lamp, a window) × spheres (distance, radius).
SPHERE_LIGHTS = {"point": 0.0, "sun": 0.27, "lamp": 6.0, "window": 40.0}
SPHERES = {"far": (3.0, 0.3), "near": (1.25, 1.0), "inside": (0.5, 1.0)}
#: The rendered V may match the CPU's this far (radians) along the sphere's direction: the
#: float32 normal and its renormalisation (a point light's rim is a step).
SPHERE_LIGHT_SLACK = 2e-6


class SphereLightEvaluator(ShadowEvaluator):
    """Renders ``shSphereLightVisibility`` / ``SHSphereLightVisibility`` for one light and one
    sphere (uniforms: ``light`` direction and radius, ``at`` distance and radius) per normal."""
    VEC4_UNIFORMS = {"sphereLight": ("light", "_SphereLight"), "sphereAt": ("at", "_SphereAt")}

    def __init__(self, ctx, path: str = "glsl"):
        source = SPHERE_LIGHT_EVALUATORS[path]
        super().__init__(ctx, path, (shader_source("sh9_lights.glsl") if path == "glsl"
                                     else "") + source)


def run_sphere_light_cases(ctx, path: str, normals, tolerance) -> list[Comparison]:
    """:data:`SPHERE_LIGHTS` × :data:`SPHERES` against :func:`sphere_light_visibility`: the
    rendered V within ``tolerance`` of the CPU's V somewhere within :data:`SPHERE_LIGHT_SLACK`
    of the normal's direction (toward or away from the light)."""
    ev, out, zero = SphereLightEvaluator(ctx, path), [], np.zeros((3, 4, 4))
    n = np.asarray(normals, np.float32).astype(np.float64)
    light = np.array([0.3, 0.8, -0.52]) / np.linalg.norm([0.3, 0.8, -0.52])
    along = light - (n @ light)[:, None] * n                   # toward the light, ⟂ n
    along *= SPHERE_LIGHT_SLACK / np.maximum(np.linalg.norm(along, axis=1), 1e-30)[:, None]
    for (lname, radius), (sname, (dist, r)) in itertools.product(SPHERE_LIGHTS.items(),
                                                                 SPHERES.items()):
        ev.light = np.append(light, math.radians(radius)).astype(np.float32)
        ev.at = np.array([dist, r, 0, 0], np.float32)
        v = ev.evaluate(zero, normals)[0][:, :1]
        lo, hi = (sphere_light_visibility(-(n + t * along) * dist, np.zeros(3), r, light[None],
                                          [math.degrees(ev.light[3])]) for t in (-1, 1))
        case = LightCase(f"shadow:sphere_light:{lname}:{sname}", zero, light[None],
                         np.zeros((1, 3)), note=f"light radius {radius}°, R {r} at {dist}")
        exact = np.clip(v, np.minimum(lo, hi), np.maximum(lo, hi))
        out.append(judge(case, path, v, v, exact, np.ones_like(v), tolerance))
    return out


def demo_checks(ctx) -> list[DemoCheck]:
    return [lit_diffuse_lights_check(ctx)]


def pictures(ctx, panoramas, out_dir) -> list[dict]:
    pic = write_lights_picture(ctx, panoramas, out_dir)
    if pic is None:
        return []
    print(f"picture {pic['file']}: SH9 vs ambient + {pic['lights']} light(s) vs brute force, "
          f"relative RMS over the sphere {pic['all_normals_sh9_rms_rel']:.1%} -> "
          f"{pic['all_normals_lights_rms_rel']:.1%}")
    return [pic]
