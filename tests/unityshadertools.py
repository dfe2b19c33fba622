"""The harness that compiles the Unity package's shaders as Unity compiles them, without Unity
(tests/clients/unity/test_unity_shaders.py says how; the shadow catcher and IBL tests use it too): the
.shader file read into passes and variants, each compiled by glslangValidator's HLSL front
end, reflected by spirv-cross, and run in software OpenGL."""
from __future__ import annotations

import itertools
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PKG_SHADERS = ROOT / "unity_package" / "Shaders"
SHADER = PKG_SHADERS / "SH9Diffuse.shader"
STUBS = ROOT / "tests" / "unity_stubs"

STEREO = {"mono": [], "single-pass": ["UNITY_SINGLE_PASS_STEREO"],
          "single-pass-instanced": ["STEREO_INSTANCING_ON"], "multiview": ["STEREO_MULTIVIEW_ON"]}
# HoloLens renders with D3D11; multiview exists only on GL/Vulkan (Quest), so it is compiled there
API = {"mono": "SHADER_API_D3D11", "single-pass": "SHADER_API_D3D11",
       "single-pass-instanced": "SHADER_API_D3D11", "multiview": "SHADER_API_VULKAN"}
STAGES = {"vertex": ("vert", "SHADER_STAGE_VERTEX"), "fragment": ("frag", "SHADER_STAGE_FRAGMENT")}
# On GL/Vulkan/Metal, Unity's HLSLSupport.cginc uses precision-mangled texture types that Unity's
# own HLSLcc compiler knows (Texture2D_half, sampler2D_float, ...); glslang gets them as plain types.
HLSLCC_TYPES = [f"{t}_{p}={t}" for t in ("sampler2D", "samplerCUBE", "sampler3D", "Texture2D", "Texture2DArray",
                                        "Texture2DMS", "TextureCube", "TextureCubeArray", "Texture3D")
                for p in ("half", "float")]


def _tool(name: str) -> str:
    path = shutil.which(name)
    if not path:
        pytest.skip(f"{name} is not installed (apt-get install glslang-tools spirv-cross spirv-tools)")
    return path


# ---- reading the .shader file ------------------------------------------------------------------

def _blocks(text: str, keyword: str) -> list[str]:
    """The bodies of `keyword { ... }` blocks at the top level of `text` (programs already masked)."""
    out, i = [], 0
    while True:
        m = re.compile(r"\b" + keyword + r"\b\s*\{").search(text, i)
        if not m:
            return out
        depth, j = 1, m.end()
        while depth:
            depth += {"{": 1, "}": -1}.get(text[j], 0)
            j += 1
        out.append(text[m.end():j - 1])
        i = j


def parse_shader(text: str, name: str = "Shlight/SH9 Diffuse") -> list[dict]:
    """Passes: SubShader index and tags, pass name and LightMode, program text, pragmas."""
    text = re.sub(r"//[^\n]*", "", text)
    programs = []

    def mask(m):
        programs.append(m.group(2))
        return f"@PROGRAM{len(programs) - 1}@"
    masked = re.sub(r"(CGPROGRAM|HLSLPROGRAM)(.*?)(ENDCG|ENDHLSL)", mask, text, flags=re.S)
    assert re.search(r'Shader\s+"' + re.escape(name) + '"', masked)
    passes = []
    for s, sub in enumerate(_blocks(masked, "SubShader")):
        tags = dict(re.findall(r'"(\w+)"\s*=\s*"([^"]*)"', (_blocks(sub, "Tags") or [""])[0]))
        for body in _blocks(sub, "Pass"):
            ptags = dict(re.findall(r'"(\w+)"\s*=\s*"([^"]*)"', (_blocks(body, "Tags") or [""])[0]))
            name = re.search(r'Name\s+"([^"]+)"', body).group(1)
            program = programs[int(re.search(r"@PROGRAM(\d+)@", body).group(1))]
            pragmas = [l.strip()[len("#pragma "):].split() for l in program.splitlines()
                       if l.strip().startswith("#pragma ")]
            passes.append({"subshader": s, "pipeline": tags.get("RenderPipeline", "built-in"),
                           "name": name, "lightmode": ptags.get("LightMode", ""), "program": program,
                           "pragmas": pragmas, "state": body})
    return passes


def entry(p: dict, stage: str) -> str:
    """The entry point named by `#pragma vertex NAME` / `#pragma fragment NAME`."""
    return next(pr[1] for pr in p["pragmas"] if pr[0] == stage)


def keyword_sets(p: dict, stage: str) -> list[list[str]]:
    """Keyword combinations of the pass's multi_compile pragmas that reach `stage`."""
    axes = []
    for pr in p["pragmas"]:
        kind = pr[0]
        if kind == "multi_compile_instancing":
            axes.append(["", "INSTANCING_ON"])
        elif kind == "multi_compile_shadowcaster":
            axes.append(["SHADOWS_DEPTH", "SHADOWS_CUBE"])
        elif kind.startswith("multi_compile"):
            only = kind[len("multi_compile"):].lstrip("_")
            if only and only != stage:
                continue           # a stage-specific keyword is stripped from the other stage
            axes.append(["" if k == "_" else k for k in pr[1:]])
    return [[k for k in combo if k] for combo in itertools.product(*axes)]


def variants(p: dict, unity_versions=(202230,)):
    """(stage, stereo, keywords, defines) for every variant of pass `p`."""
    colour = [[], ["UNITY_COLORSPACE_GAMMA"]] if p["name"] == "SH9Diffuse" else [[]]
    # only the DepthNormals encoding depends on the Unity version (URP 10/11 against 12+)
    versions = unity_versions if p["name"] == "DepthNormals" else unity_versions[-1:]
    for stage, stereo, cs, version in itertools.product(STAGES, STEREO, colour, versions):
        for kws in keyword_sets(p, stage):
            defines = [API[stereo], "SHADER_TARGET=35", f"UNITY_VERSION={version}", STAGES[stage][1],
                       *STEREO[stereo], *kws, *cs]
            yield stage, stereo, kws + cs, defines


# ---- compiling -------------------------------------------------------------------------------------

def compile_pass(p: dict, stage: str, defines: list[str], includes: list[Path], out: Path,
                 shader_dir: Path = PKG_SHADERS) -> tuple[bool, str]:
    """glslangValidator on the pass's program, prefixed as Unity prefixes CGPROGRAM blocks."""
    glslang = _tool("glslangValidator")
    body = "\n".join(l for l in p["program"].splitlines() if not l.strip().startswith("#pragma"))
    src = out.with_suffix(".hlsl")
    src.write_text('#include "HLSLSupport.cginc"\n#include "UnityShaderVariables.cginc"\n' + body)
    # Unity's compiler defines platform macros and keywords as 1 (includes test `!(SHADER_API_VULKAN || ...)`)
    defines = [d if "=" in d else f"{d}=1" for d in defines]
    if "SHADER_API_D3D11=1" not in defines:
        defines = [*defines, *HLSLCC_TYPES]
    cmd = [glslang, "-D", "-V", "-S", STAGES[stage][0], "-e", entry(p, stage), "-o", str(out),
           *[f"-D{d}" for d in defines], f"-I{shader_dir}", *[f"-I{i}" for i in includes], str(src)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    return r.returncode == 0, (r.stdout + r.stderr).replace(str(src), src.name)


def reflect(spv: Path) -> dict:
    r = subprocess.run([_tool("spirv-cross"), str(spv), "--reflect"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)


def uniform_blocks(refl: dict) -> dict[str, list[tuple]]:
    """Uniform block name -> members (name, type, offset), nested struct members flattened."""
    types = refl.get("types", {})

    def members(tid, prefix=""):
        out = []
        for m in types[tid]["members"]:
            if m["type"] in types:
                out += [(prefix + m["name"] + "." + n, t, o) for n, t, o in members(m["type"])]
            out.append((prefix + m["name"], m["type"] if m["type"] not in types else "struct", m.get("offset")))
        return out
    return {u["name"]: members(u["type"]) for u in refl.get("ubos", [])}


def _spirv_dis(spv: Path) -> str:
    opt = spv.with_suffix(".opt.spv")
    r = subprocess.run([_tool("spirv-opt"), "-O", str(spv), "-o", str(opt)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    return subprocess.run([_tool("spirv-dis"), str(opt)], capture_output=True, text=True, timeout=60).stdout


def layer_depends_on_instance_id(spv: Path) -> bool:
    """In the optimised module, is the value stored to BuiltIn Layer (SV_RenderTargetArrayIndex)
    computed from a load of BuiltIn InstanceIndex (SV_InstanceID)? (def-use walk over SSA)"""
    dis = _spirv_dis(spv)
    builtin = dict((m.group(2), m.group(1)) for m in re.finditer(r"OpDecorate (%\w+) BuiltIn (\w+)", dis))
    if "Layer" not in builtin or "InstanceIndex" not in builtin:
        return False
    defs = {}
    for line in dis.splitlines():
        m = re.match(r"\s*(%\w+) = Op\w+ (.*)", line)
        if m:
            defs[m.group(1)] = re.findall(r"%\w+", m.group(2))
    stores = [m.group(1) for m in re.finditer(r"OpStore " + re.escape(builtin["Layer"]) + r" (%\w+)", dis)]
    seen, todo = set(), list(stores)
    while todo:
        v = todo.pop()
        if v in seen:
            continue
        seen.add(v)
        if v == builtin["InstanceIndex"]:
            return True
        todo += defs.get(v, [])
    return False


def _include_sets():
    sets = [("stand-in", [STUBS], (202030, 202230)),
            # Unity's own 2019.4.1 (MIT; the six files the shader reaches; see the folder's README)
            ("2019.4", [ROOT / "tests" / "data" / "unity_cgincludes_2019.4"], (201940,))]
    for item in filter(None, os.environ.get("SHLIGHT_UNITY_CGINCLUDES", "").split(":")):
        version, _, folder = item.partition("=")
        major, minor = version.split(".")[:2]
        number = int(major) * 100 + int(minor) * 10       # UNITY_VERSION of VERSION.0: 2022.3 -> 202230
        sets.append((version, [Path(folder)], (number,)))
    return sets


INCLUDE_SETS = {name: (dirs, versions) for name, dirs, versions in _include_sets()}


# ---- running (software OpenGL) ---------------------------------------------------------------------

def _gl_context():
    try:
        import moderngl
    except ImportError:
        pytest.skip("moderngl is not installed (pip install -e .[test])")
    try:
        return moderngl.create_context(standalone=True, require=330, backend="egl")
    except Exception as exc:  # moderngl raises plain Exceptions when no GL library is found
        pytest.skip(f"no OpenGL 3.3 context ({exc}); on Debian: apt-get install libegl1 libgl1-mesa-dri")


def bind_uniform_blocks(ctx, prog, refl, values: dict) -> list:
    """Fill each uniform block spirv-cross reflected (``refl``) with ``values`` at its
    members' offsets (others zero), bind block k to binding k, and return the buffers (keep
    them alive while drawing). Unity's ``$Global`` block is ``_Global`` in the GLSL."""
    import numpy as np
    buffers = []
    for binding, ubo in enumerate(refl["ubos"]):
        data = np.zeros(ubo["block_size"] // 4, np.float32)
        for m in refl["types"][ubo["type"]]["members"]:
            if m["name"] in values:
                v = np.asarray(values[m["name"]], np.float32).reshape(-1)
                data[m["offset"] // 4: m["offset"] // 4 + v.size] = v
        buf = ctx.buffer(data.tobytes())
        buf.bind_to_uniform_block(binding)
        prog["_Global" if ubo["name"] == "$Global" else ubo["name"]].binding = binding
        buffers.append(buf)
    return buffers
