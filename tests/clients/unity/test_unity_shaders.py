"""The Unity package's shader (unity_package/Shaders/SH9Diffuse.shader) compiled as Unity compiles
it, without Unity.

Every pass of both SubShaders (URP: colour, ShadowCaster, DepthOnly, DepthNormals; built-in:
ForwardBase, ShadowCaster) is compiled with glslangValidator's HLSL front end, each stage in every
variant Unity would build for it: the pass's own multi_compile keywords, GPU instancing, each
stereo path (none, single-pass, single-pass instanced on D3D11 as on HoloLens, multiview on Vulkan
as on Quest) and, for the colour passes, both colour spaces. The includes are the stand-ins in
tests/unity_stubs, which define the stereo and instancing macros the way Unity's do (a pass that
forgets UNITY_VERTEX_OUTPUT_STEREO does not compile, as in Unity), Unity's own 2019.4.1 CGIncludes
(the six files the shader reaches, MIT, in tests/data/unity_cgincludes_2019.4), and any other
version's where SHLIGHT_UNITY_CGINCLUDES names them (VERSION=DIR pairs separated by ':', e.g.
2022.3=/path/to/builtin_shaders/CGIncludes; Unity publishes them as "Built-in shaders").

Beyond compiling, from the SPIR-V (spirv-cross reflection, spirv-opt):
* SRP Batcher rules: every material property in one cbuffer UnityPerMaterial whose layout is the
  same in every pass and variant; none elsewhere except _Color in the per-instance buffer.
* GPU instancing: _Color per instance in the instanced variants.
* Single-pass instanced stereo: the render-target slice (SV_RenderTargetArrayIndex) is computed
  from the instance ID after optimisation, so each eye gets its own draw.
And the colour pass is run (SPIR-V -> GLSL by spirv-cross, software OpenGL through moderngl, the
same route as `shlight validate-shaders`' HLSL path) with a light from one side.
Nothing here runs Unity.
"""
from __future__ import annotations

import math
import re
import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from unityshadertools import (INCLUDE_SETS, PKG_SHADERS, SHADER, STUBS, _gl_context, _tool,
                              bind_uniform_blocks, compile_pass, keyword_sets,
                              layer_depends_on_instance_id, parse_shader, reflect, uniform_blocks,
                              variants)

MATERIAL_PROPERTIES = {"_Color", "_MainTex_ST", "_Exposure"}   # numeric properties of the Properties block


def _compile_all(tmp_path: Path, includes: list[Path], versions) -> list[dict]:
    passes = parse_shader(SHADER.read_text())
    jobs = []
    for p in passes:
        for stage, stereo, kws, defines in variants(p, versions):
            tag = re.sub(r"\W+", "_", f"{p['pipeline']}_{p['name']}_{stage}_{stereo}_{'_'.join(kws)}_{defines[2]}")
            jobs.append({"pass": p, "stage": stage, "stereo": stereo, "keywords": kws, "defines": defines,
                         "spv": tmp_path / f"{tag}.spv"})

    def run(job):
        job["ok"], job["log"] = compile_pass(job["pass"], job["stage"], job["defines"], includes, job["spv"])
        return job
    with ThreadPoolExecutor(max_workers=2) as pool:
        return list(pool.map(run, jobs))


def _describe(job) -> str:
    p = job["pass"]
    return (f"{p['pipeline']} pass {p['name']} {job['stage']} [{job['stereo']}; "
            f"{' '.join(job['keywords']) or 'no keywords'}; {job['defines'][2]}]")


# ---- tests -----------------------------------------------------------------------------------------

def test_shader_structure():
    """Two SubShaders: URP (found by URP through its RenderPipeline tag) with the passes URP asks for
    (a colour pass, ShadowCaster, DepthOnly for depth priming, DepthNormals), then built-in
    (ForwardBase for the main light, ShadowCaster). Every pass: instancing variants, target 3.5."""
    passes = parse_shader(SHADER.read_text())
    got = [(p["pipeline"], p["name"], p["lightmode"]) for p in passes]
    assert got == [("UniversalPipeline", "SH9Diffuse", ""), ("UniversalPipeline", "ShadowCaster", "ShadowCaster"),
                   ("UniversalPipeline", "DepthOnly", "DepthOnly"), ("UniversalPipeline", "DepthNormals", "DepthNormals"),
                   ("built-in", "SH9Diffuse", "ForwardBase"), ("built-in", "ShadowCaster", "ShadowCaster")], got
    for p in passes:
        assert ["multi_compile_instancing"] in p["pragmas"] and ["target", "3.5"] in p["pragmas"], p["name"]
        assert re.search(r"ZWrite\s+On", p["state"]), p["name"]
        assert ("#define SH9_URP" in p["program"]) == (p["pipeline"] == "UniversalPipeline"), p["name"]
    # URP's depth prepass needs depth; it also copies depth through R on some versions
    depth = next(p for p in passes if p["name"] == "DepthOnly")
    assert re.search(r"ColorMask\s+R\b", depth["state"])
    src = (PKG_SHADERS / "SH9DiffusePasses.hlsl").read_text()
    assert '#include "sh9_irradiance.hlsl"' in src and "SHIrradiance(n)" in src
    assert "Packages/com.unity.render-pipelines" not in src, "a URP include breaks projects without URP"


def test_all_variants_compile_with_standin_includes(tmp_path):
    """Every pass, stage and variant compiles against the stand-in includes (Unity's macro semantics)."""
    jobs = _compile_all(tmp_path, [STUBS], (202030, 202230))
    failed = [f"{_describe(j)}:\n{j['log'][-1500:]}" for j in jobs if not j["ok"]]
    assert not failed, f"{len(failed)} of {len(jobs)} failed:\n" + "\n".join(failed[:5])
    print(f"\n{len(jobs)} pass/stage/variant combinations compiled (stand-in includes)")
    _check_layouts(jobs)


def _check_layouts(jobs):
    """SRP Batcher and instancing rules on the compiled D3D11 variants (real cbuffers there)."""
    layouts, where = {}, {}
    for j in jobs:
        if "D3D11" not in j["defines"][0]:
            continue
        blocks = uniform_blocks(reflect(j["spv"]))
        per_material = blocks.get("UnityPerMaterial")
        if per_material is not None:
            # with instancing, _Color moves out and a placeholder of the same type keeps its offset:
            # the layout (names of the others, types, offsets) must not change
            layout = tuple(("_Color" if n == "_ColorPerInstanceSlot" else n, t, o) for n, t, o in per_material)
            layouts.setdefault(layout, []).append(_describe(j))
        for name, members in blocks.items():
            if name == "UnityPerMaterial":
                continue
            for m in members:
                leaf = m[0].split(".")[-1]
                if leaf in MATERIAL_PROPERTIES:
                    assert name == "UnityInstancing_SH9PerInstance" and leaf == "_Color" and \
                        "INSTANCING_ON" in j["keywords"], f"{leaf} in cbuffer {name}: {_describe(j)}"
                    where.setdefault(j["pass"]["name"], set()).add(j["stage"])
        p = j["pass"]
        if p["name"] == "SH9Diffuse" and j["stage"] == "vertex":
            assert per_material is not None, f"no UnityPerMaterial in {_describe(j)}"
            assert ("UnityInstancing_SH9PerInstance" in blocks) == ("INSTANCING_ON" in j["keywords"]), _describe(j)
    assert len(layouts) == 1, "UnityPerMaterial differs between passes/variants (SRP Batcher):\n" + \
        "\n".join(f"{k}: {v[:3]}" for k, v in layouts.items())
    layout = next(iter(layouts))
    names = [m[0] for m in layout]
    assert "_MainTex_ST" in names and "_Exposure" in names and ("_Color" in names or "_ColorPerInstanceSlot" in names)
    assert where.get("SH9Diffuse") == {"vertex"}, where   # per-instance colour read in the vertex stage


@pytest.mark.parametrize("includes", list(INCLUDE_SETS))
def test_single_pass_instanced_eye_comes_from_the_instance(tmp_path, includes):
    """HoloLens single-pass instanced: in every pass, the vertex stage writes the render-target slice
    from the instance ID (UNITY_SETUP_INSTANCE_ID + UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO); otherwise
    both eyes' instances land in one eye."""
    dirs, versions = INCLUDE_SETS[includes]
    for p in parse_shader(SHADER.read_text()):
        for instancing in ([], ["INSTANCING_ON"]):
            spv = tmp_path / f"{p['pipeline']}_{p['name']}_{len(instancing)}.spv"
            defines = ["SHADER_API_D3D11", "SHADER_TARGET=35", f"UNITY_VERSION={versions[-1]}", "SHADER_STAGE_VERTEX",
                       "STEREO_INSTANCING_ON", *instancing, *keyword_sets(p, "vertex")[0]]
            ok, log = compile_pass(p, "vertex", defines, dirs, spv)
            assert ok, log
            assert layer_depends_on_instance_id(spv), f"{p['pipeline']} {p['name']}: eye not from the instance ID"


# A shader missing one stereo/instancing step: the checks above must catch it.
MUTATIONS = {
    "UNITY_VERTEX_OUTPUT_STEREO": ("compile", "STEREO_INSTANCING_ON"),
    "UNITY_VERTEX_INPUT_INSTANCE_ID": ("compile", "INSTANCING_ON"),
    "UNITY_SETUP_INSTANCE_ID(v);": ("eye", "STEREO_INSTANCING_ON"),
    "UNITY_INITIALIZE_VERTEX_OUTPUT_STEREO(o);": ("eye", "STEREO_INSTANCING_ON"),
}


@pytest.mark.parametrize("includes", list(INCLUDE_SETS))
@pytest.mark.parametrize("token", list(MUTATIONS))
def test_missing_stereo_step_is_caught(tmp_path, token, includes):
    """Take one stereo/instancing step out of the forward pass: with the stand-in includes as with
    Unity's, either the variant stops compiling or the eye no longer comes from the instance ID."""
    how, keyword = MUTATIONS[token]
    dirs, versions = INCLUDE_SETS[includes]
    mutated = tmp_path / "shaders"
    mutated.mkdir()
    shutil.copy(PKG_SHADERS / "sh9_irradiance.hlsl", mutated)
    src = (PKG_SHADERS / "SH9DiffusePasses.hlsl").read_text()
    fwd_start = src.index("SH9Varyings SH9ForwardVertex") if token.endswith(";") else src.index("struct SH9Attributes")
    fwd_end = src.index("// ---- shadow caster")
    section = src[fwd_start:fwd_end]
    assert token in section
    (mutated / "SH9DiffusePasses.hlsl").write_text(src[:fwd_start] + section.replace(token, "") + src[fwd_end:])
    p = next(p for p in parse_shader(SHADER.read_text()) if p["pipeline"] == "UniversalPipeline")
    defines = ["SHADER_API_D3D11", "SHADER_TARGET=35", f"UNITY_VERSION={versions[-1]}", "SHADER_STAGE_VERTEX", keyword]
    spv = tmp_path / "mutated.spv"
    ok, log = compile_pass(p, "vertex", defines, dirs, spv, shader_dir=mutated)
    if how == "compile":
        assert not ok, f"without {token} the {keyword} variant still compiles: the stand-ins are too lax"
    else:
        assert ok, log
        assert not layer_depends_on_instance_id(spv), f"without {token} the eye check still passes"
    # and the unmutated shader passes the same check
    ok, log = compile_pass(p, "vertex", defines, dirs, tmp_path / "ok.spv")
    assert ok and (how == "compile" or layer_depends_on_instance_id(tmp_path / "ok.spv")), log


def test_all_variants_compile_with_unity_includes(tmp_path):
    """The same matrix against Unity's own CGIncludes: 2019.4.1's (in tests/data, MIT) and each
    version named in SHLIGHT_UNITY_CGINCLUDES."""
    sets = [(name, dirs, versions) for name, (dirs, versions) in INCLUDE_SETS.items() if name != "stand-in"]
    if not sets:
        pytest.skip("SHLIGHT_UNITY_CGINCLUDES not set (VERSION=DIR[:VERSION=DIR...], DIR = the CGIncludes "
                    "folder of Unity's built-in shaders for that version)")
    total = 0
    for version, includes, numbers in sets:
        assert (includes[0] / "UnityCG.cginc").exists(), f"{includes[0]} has no UnityCG.cginc"
        (tmp_path / version).mkdir()
        jobs = _compile_all(tmp_path / version, includes, numbers)
        failed = [f"{_describe(j)}:\n{j['log'][-1500:]}" for j in jobs if not j["ok"]]
        assert not failed, f"Unity {version}: {len(failed)} of {len(jobs)} failed:\n" + "\n".join(failed[:5])
        _check_layouts(jobs)
        total += len(jobs)
        print(f"\nUnity {version} CGIncludes: {len(jobs)} pass/stage/variant combinations compiled")
    assert total > 0


# ---- the colour pass, run (software OpenGL): SH9 plus the main light where the client drives it -------


def run_fragment(ctx, p: dict, defines: list[str], normals, values: dict, tmp_path: Path):
    """Run pass `p`'s fragment stage once per normal (one point per pixel), with the uniform block
    members in `values` (by name; others 0) and a white 1×1 _MainTex. Returns (N, 4) float32."""
    import numpy as np
    spv = tmp_path / f"run_{p['pipeline']}_{len(defines)}.spv"
    ok, log = compile_pass(p, "fragment", defines, [STUBS], spv)
    assert ok, log
    glsl = subprocess.run([_tool("spirv-cross"), str(spv), "--version", "330", "--no-es", "--no-420pack-extension"],
                          capture_output=True, text=True, timeout=60).stdout
    refl = reflect(spv)
    inputs = re.findall(r"^in (\w+) (\w+);", glsl, re.M)
    assert {n for _, n in inputs} == {"i_uv", "i_worldNormal", "i_color"}, inputs
    vertex = ("#version 330\nin vec3 normal;\nuniform float width;\n" +
              "".join(f"out {t} {n};\n" for t, n in inputs) +
              "void main() {\n  gl_Position = vec4((float(gl_VertexID) + 0.5) / width * 2.0 - 1.0, 0.0, 0.0, 1.0);\n"
              "  gl_PointSize = 1.0;\n  i_uv = vec2(0.5);\n  i_worldNormal = normal;\n  i_color = vec4(1.0);\n}\n")
    prog = ctx.program(vertex_shader=vertex, fragment_shader=glsl)
    n = len(normals)
    prog["width"].value = float(n)
    buffers = bind_uniform_blocks(ctx, prog, refl, values)
    texture = ctx.texture((1, 1), 4, np.ones(4, np.float32).tobytes(), dtype="f4")
    texture.use(0)
    fbo = ctx.framebuffer(color_attachments=[ctx.texture((n, 1), 4, dtype="f4")])
    fbo.use()
    fbo.clear()
    vbo = ctx.buffer(np.asarray(normals, np.float32).tobytes())
    vao = ctx.vertex_array(prog, [(vbo, "3f", "normal")])
    vao.render(mode=ctx.POINTS, vertices=n)
    return np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(n, 4)


@pytest.mark.parametrize("pipeline", ["UniversalPipeline", "built-in"])
@pytest.mark.parametrize("colour_space", ["linear", "gamma"])
def test_colour_pass_adds_the_driven_main_light(tmp_path, pipeline, colour_space):
    """The compiled colour pass, run: radiance = albedo · (E(n)/π + main light · max(0, N·L)) with a
    light from +X only, in Unity's frame: +X gets the ambient plus the light, -X and ±Y only the
    ambient; with _SHMainLightScale 0 (the client does not drive a light) no light at all, whatever
    the scene's light says. Built-in reads _WorldSpaceLightPos0/_LightColor0, URP
    _MainLightPosition/_MainLightColor. In gamma projects, lighting is done in linear: the light
    colour (the sRGB encoding of E/π, as SH9LightingClient sets it) is decoded exactly."""
    import numpy as np
    ctx = _gl_context()
    p = next(q for q in parse_shader(SHADER.read_text()) if q["pipeline"] == pipeline and q["name"] == "SH9Diffuse")
    defines = ["SHADER_API_D3D11", "SHADER_TARGET=35", "UNITY_VERSION=202230", "SHADER_STAGE_FRAGMENT"]
    gamma = colour_space == "gamma"
    if gamma:
        defines.append("UNITY_COLORSPACE_GAMMA")
    ambient = 0.05                                # uniform radiance: E = π·0.05, E/π = 0.05
    m = np.zeros((3, 4, 4))
    m[:, 3, 3] = math.pi * ambient
    light = np.array([0.9, 0.6, 0.3])              # E/π of the light on a surface facing it (linear)
    srgb = np.array([_linear_to_gamma_exact(c) for c in light])
    direction = np.array([1.0, 0.0, 0.0, 0.0])    # toward the light, Unity world frame
    normals = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (math.sqrt(0.5), math.sqrt(0.5), 0)]
    common = {"_SHIrradianceR": m[0], "_SHIrradianceG": m[1], "_SHIrradianceB": m[2], "_Exposure": 1.0,
              "_Color": [1, 1, 1, 1]}
    lit = srgb if gamma else light
    if pipeline == "built-in":
        names = {"_WorldSpaceLightPos0": direction, "_LightColor0": [*lit, 1]}
    else:
        names = {"_MainLightPosition": direction, "_MainLightColor": [*lit, 1]}
    for scale in (1.0, 0.0):
        out = run_fragment(ctx, p, defines, normals, {**common, **names, "_SHMainLightScale": scale}, tmp_path)
        cosines = np.maximum(0, np.asarray(normals, float) @ direction[:3])
        want = ambient + scale * cosines[:, None] * light[None, :]
        if gamma:    # the pass encodes with UnityCG's LinearToGammaSpace
            want = np.maximum(1.055 * want ** 0.416666667 - 0.055, 0)
        assert np.allclose(out[:, :3], want, rtol=2e-3, atol=1e-4), (scale, out[:, :3], want)
        assert np.allclose(out[:, 3], 1.0)


def _linear_to_gamma_exact(v: float) -> float:
    """UnityCG.cginc's LinearToGammaSpaceExact, which Sh9Math.LinearToGammaExact mirrors."""
    if v <= 0.0:
        return 0.0
    if v <= 0.0031308:
        return 12.92 * v
    if v < 1.0:
        return 1.055 * v ** 0.4166667 - 0.055
    return v ** 0.45454545
