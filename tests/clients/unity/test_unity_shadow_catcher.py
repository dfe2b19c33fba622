"""The Unity package's shadow catchers (issue 30, docs/shadows_consumers.md), compiled as Unity
compiles them, without Unity, with the harness of tests/unityshadertools.py.

* Built-in (unity_package/Shaders/SH9ShadowCatcher.shader): every stage and variant (no shadows,
  SHADOWS_SCREEN with screen-space shadows and with UNITY_NO_SCREENSPACE_SHADOWS as on mobile /
  Quest, GPU instancing, each stereo path) against Unity's own 2019.4.1 CGIncludes (AutoLight.cginc
  and UnityShadowLibrary.cginc included, tests/data/unity_cgincludes_2019.4) and any version named
  in SHLIGHT_UNITY_CGINCLUDES. Then the fragment stage is run (SPIR-V → GLSL, software OpenGL) with a
  shadow map reading V: its colour is SHShadowRatio = provider.core.lights.shadows.shadow_ratio(n,
  V for the key light), its alpha 1 − the ratio's luminance; with V = 1 it is exactly 1 (untouched).
* URP (Samples~/ShadowCatcher/SH9ShadowCatcherURP.shader): every variant of URP's main-light
  shadow keywords against stand-ins of URP's ShaderLibrary (tests/unity_stubs/urp: the functions
  the shader calls, with URP's signatures; URP itself is not here).
* Both: blend factors are the material's, and the two shipped materials of each pipeline multiply
  (DstColor Zero, alpha kept) and cover (Zero OneMinusSrcAlpha, One OneMinusSrcAlpha).
"""
from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from provider.core.geometry import sh
from provider.core.conventions.formats import light_sh
from provider.core.lights.shadows import (occluded_ambient, shadow_ratio, sphere_light_visibility,
                                          sphere_occluder)

from unityshadertools import (API, INCLUDE_SETS, STAGES, STEREO, _gl_context, _tool,
                              bind_uniform_blocks, compile_pass, entry, keyword_sets,
                              layer_depends_on_instance_id, parse_shader, reflect)

ROOT = Path(__file__).resolve().parents[3]
PKG = ROOT / "unity_package"
CATCHER = PKG / "Shaders" / "SH9ShadowCatcher.shader"
URP_CATCHER = PKG / "Samples~" / "ShadowCatcher" / "SH9ShadowCatcherURP.shader"
URP_STUBS = ROOT / "tests" / "unity_stubs" / "urp"
STUBS = ROOT / "tests" / "unity_stubs"
#: the main light's shadow, as Unity sets it for a ForwardBase pass: none, screen-space (desktop),
#: a shadow map sampled in the pass (mobile: UNITY_NO_SCREENSPACE_SHADOWS, hardware PCF)
SHADOW_VARIANTS = {"none": [], "screen": ["SHADOWS_SCREEN"],
                   "mobile": ["SHADOWS_SCREEN", "UNITY_NO_SCREENSPACE_SHADOWS"]}
BLENDS = {"Multiply": (2, 0, 0, 1), "Passthrough": (0, 10, 1, 10)}   # UnityEngine.Rendering.BlendMode


def _catcher_pass():
    passes = parse_shader(CATCHER.read_text(), name="Shlight/SH9 Shadow Catcher")
    assert [(p["pipeline"], p["name"], p["lightmode"]) for p in passes] == \
        [("built-in", "SH9ShadowCatcher", "ForwardBase")]
    p = passes[0]
    assert re.search(r"Blend \[_SrcBlend\] \[_DstBlend\], \[_SrcBlendAlpha\] \[_DstBlendAlpha\]", p["state"])
    assert re.search(r"ZWrite\s+Off", p["state"])
    assert ["multi_compile_instancing"] in p["pragmas"]
    assert any(pr[0] == "multi_compile_fwdbase" for pr in p["pragmas"])
    return p


def _variants(p, version):
    for stage, stereo, shadows, instancing in ((s, t, v, i) for s in STAGES for t in STEREO
                                               for v in SHADOW_VARIANTS for i in ([], ["INSTANCING_ON"])):
        yield stage, stereo, shadows, [API[stereo], "SHADER_TARGET=35", f"UNITY_VERSION={version}",
                                       STAGES[stage][1], *STEREO[stereo], *SHADOW_VARIANTS[shadows], *instancing]


def test_builtin_catcher_compiles_with_unity_includes(tmp_path):
    p = _catcher_pass()
    sets = [(n, d, v) for n, (d, v) in INCLUDE_SETS.items() if n != "stand-in"]
    total = 0
    for name, dirs, versions in sets:
        assert (dirs[0] / "AutoLight.cginc").exists(), f"{dirs[0]} has no AutoLight.cginc"
        failed = []
        for k, (stage, stereo, shadows, defines) in enumerate(_variants(p, versions[-1])):
            spv = tmp_path / f"{name}_{k}.spv"
            ok, log = compile_pass(p, stage, defines, dirs, spv)
            total += 1
            if not ok:
                failed.append(f"{stage} {stereo} {shadows} {defines}:\n{log[-1200:]}")
            elif stage == "vertex" and stereo == "single-pass-instanced":
                assert layer_depends_on_instance_id(spv), f"{name}: eye not from the instance ID"
        assert not failed, f"Unity {name}: {len(failed)} failed:\n" + "\n".join(failed[:3])
    print(f"\n{total} variants of the built-in shadow catcher compiled ({', '.join(n for n, _, _ in sets)})")


def _run_catcher(ctx, spv: Path, normals, values: dict, shadow, coords=None, positions=None) -> np.ndarray:
    """The fragment stage, once per normal; the screen-space shadow texture (an array: single-pass
    instanced stereo) reads `shadow` everywhere (a number), or is `shadow` (an (h, w) array) read
    at `coords` ((n, 2) texture coordinates, one per normal); the world position is `positions`
    ((n, 3), one per normal; default the origin)."""
    glsl = subprocess.run([_tool("spirv-cross"), str(spv), "--version", "430", "--no-es", "--no-420pack-extension"],
                          capture_output=True, text=True, timeout=60).stdout
    refl = reflect(spv)
    inputs = re.findall(r"^(layout\(location = \d+\) )?in (\w+) (\w+);", glsl, re.M)
    body = []
    for _, t, n in inputs:
        if "Normal" in n:
            body.append(f"  {n} = normal;")
        elif "worldPos" in n or "positionWS" in n:
            body.append(f"  {n} = position;")
        elif "ShadowCoord" in n:
            body.append(f"  {n} = {t}(uv, 0.5, 1.0);")             # screen position, w = 1
        else:
            body.append(f"  {n} = {t}(0.0);")
    vertex = ("#version 430\nin vec3 normal;\nin vec3 position;\nin vec2 uv;\nuniform float width;\n" +
              "".join(f"{layout}out {t} {n};\n" for layout, t, n in inputs) +
              "void main() {\n  gl_Position = vec4((float(gl_VertexID) + 0.5) / width * 2.0 - 1.0, 0.0, 0.0, 1.0);\n"
              "  gl_PointSize = 1.0;\n" + "\n".join(body) + "\n}\n")
    prog = ctx.program(vertex_shader=vertex, fragment_shader=glsl)
    n = len(normals)
    prog["width"].value = float(n)
    keep = bind_uniform_blocks(ctx, prog, refl, values)
    img = np.full((1, 1), shadow, np.float32) if np.isscalar(shadow) else np.asarray(shadow, np.float32)
    tex = ctx.texture_array((img.shape[1], img.shape[0], 1), 4, np.repeat(img[..., None], 4, -1).tobytes(), dtype="f4")
    tex.filter = (ctx.NEAREST, ctx.NEAREST)
    tex.use(0)
    fbo = ctx.framebuffer(color_attachments=[ctx.texture((n, 1), 4, dtype="f4")])
    fbo.use()
    fbo.clear()
    uv = np.full((n, 2), 0.5, np.float32) if coords is None else np.asarray(coords, np.float32)
    pos = np.zeros((n, 3), np.float32) if positions is None else np.asarray(positions, np.float32)
    attributes = [(ctx.buffer(np.asarray(normals, np.float32).tobytes()), "3f", "normal")]
    if "uv" in prog:                                    # not in the variant without a shadow map
        attributes.append((ctx.buffer(uv.tobytes()), "2f", "uv"))
    if "position" in prog:
        attributes.append((ctx.buffer(pos.tobytes()), "3f", "position"))
    vao = ctx.vertex_array(prog, attributes)
    vao.render(mode=ctx.POINTS, vertices=n)
    return np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(n, 4)


def _compiled_catcher_fragment(tmp_path, shadows=True):
    """The built-in catcher's fragment stage compiled to SPIR-V against Unity 2019.4's includes, in
    single-pass instanced stereo (HoloLens' D3D11 path; Quest's multiview reads the same array):
    glslang's HLSL front end has no DX9-style sampler2D for the mono variant's tex2Dproj.
    ``shadows`` False: the variant without the main light's shadow map (no SHADOWS_SCREEN)."""
    dirs, _ = INCLUDE_SETS["2019.4"]
    defines = ["SHADER_API_D3D11", "SHADER_TARGET=35", "UNITY_VERSION=201940", "SHADER_STAGE_FRAGMENT",
               *(["SHADOWS_SCREEN"] if shadows else []), "STEREO_INSTANCING_ON"]
    spv = tmp_path / f"catcher_frag_{int(shadows)}.spv"
    ok, log = compile_pass(_catcher_pass(), "fragment", defines, dirs, spv)
    assert ok, log
    return spv


def test_builtin_catcher_outputs_the_cpu_shadow_ratio(tmp_path):
    """Unity's own AutoLight path (screen-space shadows, single-pass instanced) run with a shadow map that reads V: the
    output is shadow_ratio(n, V) per colour (Unity's frame: z flipped, as the client uploads), alpha
    1 − its luminance; V = 1 leaves the image untouched (ratio 1, alpha 0)."""
    ctx = _gl_context()
    spv = _compiled_catcher_fragment(tmp_path)
    rng = np.random.default_rng(7)
    amb = rng.normal(size=(9, 3)) * 0.2
    amb[0] = [0.9, 0.8, 0.7]
    d_wire = np.array([0.4, 0.8, -0.45])
    d_wire /= np.linalg.norm(d_wire)
    e = np.array([2.5, 2.2, 1.6])
    A_unity = np.diag([1, 1, -1, 1.0]) @ sh.irradiance_matrices(amb) @ np.diag([1, 1, -1, 1.0])
    d_unity = d_wire * [1, 1, -1]
    normals = np.vstack([[0, 1, 0], [0, 0, 1], [0, -1, 0], sh.fibonacci_sphere(29)])
    values = {"_SHIrradianceR": A_unity[0].T, "_SHIrradianceG": A_unity[1].T, "_SHIrradianceB": A_unity[2].T,
              "_SHLightCount": 1, "_SHLightDirection": [*d_unity, 0, *[0] * 12],
              "_SHLightIrradiance": [*e, 0, *[0] * 12], "_ShadowStrength": 1.0}
    for shadow in (0.0, 0.4, 1.0):
        out = _run_catcher(ctx, spv, normals, values, shadow)
        want = shadow_ratio(normals, A_unity, d_unity[None], e[None], [shadow])
        err = np.abs(out[:, :3] - want).max()
        print(f"V = {shadow}: max |shader − shadow_ratio| = {err:.2e}")
        assert err < 2e-5, (shadow, out[:3], want[:3])
        np.testing.assert_allclose(out[:, 3], 1 - want @ [0.2126, 0.7152, 0.0722], atol=2e-5)
        if shadow == 1.0:
            assert np.all(out[:, :3] == 1.0) and np.all(out[:, 3] == 0.0)
    # half strength: V 0 shows as V 0.5
    out = _run_catcher(ctx, spv, normals, {**values, "_ShadowStrength": 0.5}, 0.0)
    np.testing.assert_allclose(out[:, :3], shadow_ratio(normals, A_unity, d_unity[None], e[None], [0.5]), atol=2e-5)


def test_builtin_catcher_takes_off_the_occluders_ambient_occlusion(tmp_path):
    """With _SHOccluderSphere set (what SH9ShadowOccluder uploads: the hologram's bounding sphere in
    world space), the run fragment is shadow_ratio(n, V, occluded_ambient) of the CPU for floor points
    around and under the sphere and for tilted receivers, at V 0.4 and 1 (in the open the floor under
    the sphere still darkens: the ambient it hides); w = 0 turns the occluder off."""
    ctx = _gl_context()
    spv = _compiled_catcher_fragment(tmp_path)
    rng = np.random.default_rng(8)
    amb = rng.normal(size=(9, 3)) * 0.2
    amb[0] = [0.9, 0.8, 0.7]
    A_unity = np.diag([1, 1, -1, 1.0]) @ sh.irradiance_matrices(amb) @ np.diag([1, 1, -1, 1.0])
    d_unity = np.array([0.4, 0.8, 0.45]) / np.linalg.norm([0.4, 0.8, 0.45])
    e = np.array([2.5, 2.2, 1.6])
    centre, radius = np.array([0.2, 0.8, -0.1]), 0.3
    x, z = np.meshgrid(np.linspace(-1.5, 1.5, 9), np.linspace(-1.5, 1.5, 9))
    floor = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], -1)
    tilted = rng.uniform(-1, 1, size=(40, 3)) * [1.5, 0.6, 1.5]
    normals = np.vstack([np.tile([0.0, 1.0, 0.0], (len(floor), 1)), sh.fibonacci_sphere(40)])
    points = np.vstack([floor, tilted])
    values = {"_SHIrradianceR": A_unity[0].T, "_SHIrradianceG": A_unity[1].T, "_SHIrradianceB": A_unity[2].T,
              "_SHLightCount": 1, "_SHLightDirection": [*d_unity, 0, *[0] * 12],
              "_SHLightIrradiance": [*e, 0, *[0] * 12], "_ShadowStrength": 1.0,
              "_SHOccluderSphere": [*centre, radius]}
    o = occluded_ambient(normals, A_unity, *sphere_occluder(points, centre, radius))
    assert o[:len(floor)].max() > 0.05 * np.abs(A_unity).max()            # it does hide something
    for shadow in (0.4, 1.0):
        out = _run_catcher(ctx, spv, normals, values, shadow, positions=points)
        want = shadow_ratio(normals, A_unity, d_unity[None], e[None], [shadow], occluded_ambient=o)
        err = np.abs(out[:, :3] - want).max()
        print(f"V = {shadow}, occluder: max |shader − shadow_ratio| = {err:.2e}")
        assert err < 2e-5, (shadow, err)
    assert out[:len(floor), :3].min() < 0.97                          # darker under the sphere when open
    off = _run_catcher(ctx, spv, normals, {**values, "_SHOccluderSphere": [*centre, 0.0]}, 1.0, positions=points)
    assert np.all(off[:, :3] == 1.0)


def _two_light_scene(rng):
    """A random ambient, a key light (0, 3°) and a second light (1, 9°) in Unity's frame, the SH9
    globals as SH9LightingClient uploads them with Key Light Shadows (the ambient plus light 1's SH9
    projection: Unity's ambient probe keeps it), floor points and tilted receivers around a sphere."""
    amb = rng.normal(size=(9, 3)) * 0.2
    amb[0] = [0.9, 0.8, 0.7]
    d = np.array([[0.4, 0.8, 0.45], [-0.6, 0.7, -0.3]])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    e = np.array([[2.5, 2.2, 1.6], [1.4, 1.5, 1.9]])
    radii = np.array([3.0, 9.0])
    S = np.diag([1, 1, -1, 1.0])
    A = S @ sh.irradiance_matrices(amb) @ S                        # the message's ambient, Unity frame
    d_unity = d * [1, 1, -1]
    folded = S @ sh.irradiance_matrices(amb + light_sh(d[1], e[1])) @ S
    centre, radius = np.array([0.1, 0.7, -0.1]), 0.3
    x, z = np.meshgrid(np.linspace(-1.6, 1.6, 15), np.linspace(-1.6, 1.6, 15))
    floor = np.stack([x.ravel(), np.zeros(x.size), z.ravel()], -1)
    tilted = rng.uniform(-1, 1, size=(40, 3)) * [1.5, 0.3, 1.5]
    normals = np.vstack([np.tile([0.0, 1.0, 0.0], (len(floor), 1)), sh.fibonacci_sphere(40)])
    points = np.vstack([floor, tilted])
    values = {"_SHIrradianceR": folded[0].T, "_SHIrradianceG": folded[1].T, "_SHIrradianceB": folded[2].T,
              "_SHLightCount": 2, "_SHLightDirection": [*d_unity[0], 0, *d_unity[1], 0, *[0] * 8],
              "_SHLightIrradiance": [*e[0], 0, *e[1], 0, *[0] * 8], "_ShadowStrength": 1.0,
              "_SHLightAngularRadius": [*np.radians(radii), 0, 0], "_SHOccluderSphere": [*centre, radius]}
    return A, d_unity, e, radii, centre, radius, normals, points, len(floor), values


def test_builtin_catcher_shadows_the_second_light_past_the_occluder(tmp_path):
    """A 2-light message (issue 30 part B): the key light's shadow from the shadow map (V 0.4 and 1),
    the second light (9°) blocked by the occluder sphere analytically (sphere_light_visibility), the
    ambient less what the sphere hides, and light 1's SH9 projection taken back out of the folded SH9
    globals: the run fragment is the CPU's shadow_ratio(n, V, occluded_ambient) for floor points and
    tilted receivers. Without the occluder, light 1 is unblocked (its own shadow is gone)."""
    ctx = _gl_context()
    spv = _compiled_catcher_fragment(tmp_path)
    A, d, e, radii, centre, radius, normals, points, n_floor, values = _two_light_scene(np.random.default_rng(9))
    v1 = sphere_light_visibility(points, centre, radius, d[1:], radii[1:])[:, 0]
    assert v1[:n_floor].min() < 0.05 and (v1[:n_floor] > 0.05).sum() > n_floor // 2      # umbra and open floor
    o = occluded_ambient(normals, A, *sphere_occluder(points, centre, radius))
    worst = 0.0
    for v0 in (0.4, 1.0):
        out = _run_catcher(ctx, spv, normals, values, v0, positions=points)
        want = shadow_ratio(normals, A, d, e, np.stack([np.full(len(points), v0), v1], 1), occluded_ambient=o)
        worst = max(worst, float(np.abs(out[:, :3] - want).max()))
    print(f"\n2 lights, the second shadowed by the sphere: max |shader − shadow_ratio| = {worst:.2e}")
    assert worst < 2.5e-4        # the shaders' atan and acos: 4096 float32 round-offs (validate-shaders' bound)
    off = _run_catcher(ctx, spv, normals, {**values, "_SHOccluderSphere": [*centre, 0.0]}, 1.0, positions=points)
    want = shadow_ratio(normals, A, d, e, np.ones((len(points), 2)))
    assert np.abs(off[:, :3] - want).max() < 5e-5 and np.abs(off[:, :3] - 1.0).max() < 5e-5
    if os.environ.get("SHLIGHT_DOCS_SCREENSHOT"):
        picture(ctx, spv, values, A, d, e, radii, centre, radius)


def test_builtin_catcher_without_a_shadow_map_shadows_the_key_light_past_the_occluder(tmp_path):
    """The variant without the main light's shadow map (Key Light Shadows off, or shadows off in the
    quality settings): the key light too is blocked by the occluder sphere analytically."""
    ctx = _gl_context()
    spv = _compiled_catcher_fragment(tmp_path, shadows=False)
    A, d, e, radii, centre, radius, normals, points, n_floor, values = _two_light_scene(np.random.default_rng(10))
    v = sphere_light_visibility(points, centre, radius, d, radii)
    assert v[:n_floor, 0].min() < 0.05
    o = occluded_ambient(normals, A, *sphere_occluder(points, centre, radius))
    out = _run_catcher(ctx, spv, normals, values, 1.0, positions=points)
    want = shadow_ratio(normals, A, d, e, v, occluded_ambient=o)
    err = float(np.abs(out[:, :3] - want).max())
    print(f"\nno shadow map, both lights by the sphere: max |shader − shadow_ratio| = {err:.2e}")
    assert err < 2.5e-4          # the shaders' atan and acos: 4096 float32 round-offs (validate-shaders' bound)


def picture(ctx, spv, values, A, d, e, radii, centre, radius, size=120):
    """docs/shadows_unity.png: the built-in catcher's output, run, on a 3.2 × 3.2 floor under a sphere
    (radius 0.3, centre 0.7 above the floor; SH9ShadowOccluder's sphere) and two lights (3° key light,
    its shadow map holding the key disc's visibility at each floor point; a 9° second light, blocked by
    the sphere in the shader), multiplied onto a stand-in camera image; and its output across both
    shadows against the CPU's shadow_ratio."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    x, z = np.meshgrid(np.linspace(-1.6, 1.6, size), np.linspace(-1.6, 1.6, size))
    floor = np.stack([x, np.zeros_like(x), z], -1).reshape(-1, 3)
    v = sphere_light_visibility(floor, centre, radius, d, radii)
    coords = np.stack([(np.arange(size * size) % size + 0.5) / size, (np.arange(size * size) // size + 0.5) / size], -1)
    normals = np.tile([0.0, 1.0, 0.0], (size * size, 1))
    out = _run_catcher(ctx, spv, normals, values, v[:, 0].reshape(size, size), coords, positions=floor)[:, :3]
    o = occluded_ambient(normals, A, *sphere_occluder(floor, centre, radius))
    want = shadow_ratio(normals, A, d, e, v, occluded_ambient=o).reshape(size, size, 3)
    out = out.reshape(size, size, 3)
    rng = np.random.default_rng(1)
    camera = (np.array([0.55, 0.47, 0.38]) * (0.85 + 0.15 * ((np.floor(x * 3) + np.floor(z * 3)) % 2))[..., None]
              + rng.normal(0, 0.015, (size, size, 1)))
    fig, ax = plt.subplots(1, 3, figsize=(13, 4.3))
    ext = (-1.6, 1.6, 1.6, -1.6)
    ax[0].imshow(np.clip(camera, 0, 1), extent=ext); ax[0].set_title("camera image (stand-in)")
    ax[1].imshow(np.clip(camera * out, 0, 1), extent=ext)
    ax[1].set_title("× Shlight/SH9 Shadow Catcher (run), occluder set\nkey light 3° (shadow map), second light 9° "
                    "(sphere)", fontsize=9)
    # a line through both shadows: from the key light's umbra centre to the second light's
    feet = [centre - d[k] * centre[1] / d[k][1] for k in (0, 1)]
    t = np.linspace(-0.4, 1.4, 300)
    line = feet[0][None] + t[:, None] * (feet[1] - feet[0])[None]
    ax[1].plot(line[:, 0], line[:, 2], "w:", lw=1)
    ij = np.clip(np.round((line[:, [2, 0]] + 1.6) / 3.2 * (size - 1)).astype(int), 0, size - 1)
    ax[2].plot(t, out[ij[:, 0], ij[:, 1], 1], label="shader output (G)")
    ax[2].plot(t, want[ij[:, 0], ij[:, 1], 1], "k--", label="shadow_ratio (CPU)")
    ax[2].set_ylim(0, 1.05); ax[2].set_xlabel("along the dotted line (0: key shadow, 1: second)")
    ax[2].legend(loc="lower right"); ax[2].set_title("through both shadows")
    fig.tight_layout()
    fig.savefig(ROOT / "docs" / "shadows_unity.png", dpi=90)
    plt.close(fig)


def _urp_pass():
    text = URP_CATCHER.read_text()
    passes = parse_shader(text, name="Shlight/SH9 Shadow Catcher (URP)")
    assert [(p["pipeline"], p["lightmode"]) for p in passes] == [("UniversalPipeline", "UniversalForward")]
    return passes[0]


def test_urp_catcher_compiles_against_urp_standins(tmp_path):
    p = _urp_pass()
    program = p["program"]
    assert '#include "Packages/com.unity.render-pipelines.universal/ShaderLibrary/Core.hlsl"' in program
    assert '#include "Packages/org.shlight.sh9lighting/Shaders/sh9_lights.hlsl"' in program
    assert "CBUFFER_START(UnityPerMaterial)" in program
    # the package folder as Unity resolves Packages/org.shlight.sh9lighting/...
    pkg_root = tmp_path / "resolve" / "Packages"
    pkg_root.mkdir(parents=True)
    (pkg_root / "org.shlight.sh9lighting").symlink_to(PKG)
    glslang = _tool("glslangValidator")
    count, failed = 0, []
    for stage in STAGES:
        for kws in keyword_sets(p, stage):
            for stereo in STEREO:
                defines = [f"{d}=1" if "=" not in d else d for d in
                           [API[stereo], "SHADER_TARGET=35", "UNITY_VERSION=202230", STAGES[stage][1],
                            *STEREO[stereo], *kws]]
                body = "\n".join(l for l in program.splitlines() if not l.strip().startswith("#pragma"))
                src = tmp_path / f"urp_{count}.hlsl"
                src.write_text(body)                     # HLSLPROGRAM: no CG prefix
                spv = src.with_suffix(".spv")
                r = subprocess.run([glslang, "-D", "-V", "-S", STAGES[stage][0], "-e", entry(p, stage), "-o", str(spv),
                                    *[f"-D{d}" for d in defines], f"-I{URP_STUBS}", f"-I{tmp_path / 'resolve'}",
                                    f"-I{STUBS}", str(src)], capture_output=True, text=True, timeout=120)
                count += 1
                if r.returncode:
                    failed.append(f"{stage} {stereo} {kws}:\n{(r.stdout + r.stderr)[-1200:]}")
    assert not failed, f"{len(failed)} of {count} failed:\n" + "\n".join(failed[:3])
    print(f"\n{count} variants of the URP shadow catcher compiled (URP stand-ins)")


def _material(path: Path) -> dict:
    text = path.read_text()
    floats = dict((k, float(v)) for k, v in re.findall(r"- (_\w+): ([-\d.]+)", text))
    guid = re.search(r"m_Shader: \{fileID: 4800000, guid: (\w+), type: 3\}", text).group(1)
    return {"floats": floats, "guid": guid}


def _guid(meta: Path) -> str:
    return re.search(r"guid: (\w+)", meta.read_text()).group(1)


@pytest.mark.parametrize("mode", list(BLENDS))
def test_shipped_materials_blend_as_documented(mode):
    builtin = _material(PKG / "Samples~" / "ShadowCatcher" / f"SH9 Shadow Catcher {mode}.mat")
    assert builtin["guid"] == _guid(CATCHER.with_name(CATCHER.name + ".meta"))
    urp = _material(PKG / "Samples~" / "ShadowCatcher" / f"SH9 Shadow Catcher URP {mode}.mat")
    assert urp["guid"] == _guid(URP_CATCHER.with_name(URP_CATCHER.name + ".meta"))
    for m in (builtin, urp):
        f = m["floats"]
        assert (f["_SrcBlend"], f["_DstBlend"], f["_SrcBlendAlpha"], f["_DstBlendAlpha"]) == BLENDS[mode]
        assert f["_ShadowStrength"] == 1
