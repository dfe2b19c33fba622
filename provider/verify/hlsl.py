"""HLSL to OpenGL GLSL through SPIR-V, so an HLSL shader can be run (not just compiled) here.

glslangValidator's HLSL front end compiles the HLSL to SPIR-V (the same front end as
DXC's SPIR-V path uses for the HLSL language rules: mul() order, matrix packing, cbuffers),
and spirv-cross turns the SPIR-V into GLSL 3.30 that moderngl runs. Globals such as
``float4x4 _SHIrradianceR`` end up in a uniform block (HLSL's implicit ``$Global`` cbuffer,
renamed ``_Global`` by spirv-cross); :class:`CrossCompiled` says where each one lives.
"""
from __future__ import annotations

import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

from .render import SHADER_DIR

INSTALL_HINT = ("the HLSL check needs glslangValidator and spirv-cross: on Debian/Ubuntu "
                "`sudo apt-get install glslang-tools spirv-cross`")


class HlslToolsMissing(RuntimeError):
    """glslangValidator or spirv-cross is not installed; the message says what to install."""


class HlslCompileError(RuntimeError):
    """The HLSL did not compile or convert; the message holds the tool's output."""


@dataclass
class CrossCompiled:
    """GLSL made from an HLSL fragment shader.

    ``glsl`` is the fragment shader text. ``block`` is the name of the uniform block that
    holds the HLSL globals (None if spirv-cross emitted plain uniforms); ``members`` lists
    its members in declaration order as (name, GLSL type, row_major); an array's type
    carries its length, e.g. ``vec4[4]``.
    """
    glsl: str
    block: str | None = None
    members: list = field(default_factory=list)

    def member_offsets(self) -> dict:
        """std140 byte offset of each block member (mat4: 64 bytes, vec4: 16, int and
        float: 4; arrays of vec4: 16 per element, 16-byte aligned)."""
        sizes = {"mat4": 64, "vec4": 16, "int": 4, "float": 4}
        offsets, offset = {}, 0
        for name, gltype, _ in self.members:
            base, _, count = gltype.partition("[")
            if base not in sizes or (count and base != "vec4"):
                raise HlslCompileError(f"unexpected uniform block member {gltype} {name}")
            size = sizes[base] * (int(count.rstrip("]")) if count else 1)
            align = 16 if (count or sizes[base] >= 16) else 4
            offset = -(-offset // align) * align
            offsets[name] = offset
            offset += size
        return offsets


def tools() -> tuple[str, str]:
    """Paths of glslangValidator and spirv-cross, or :class:`HlslToolsMissing`."""
    glslang, cross = shutil.which("glslangValidator"), shutil.which("spirv-cross")
    missing = [n for n, p in (("glslangValidator", glslang), ("spirv-cross", cross)) if not p]
    if missing:
        raise HlslToolsMissing(f"{' and '.join(missing)} not found; {INSTALL_HINT}")
    return glslang, cross


def hlsl_fragment_to_glsl(source: str, entry: str = "main", include_dir: Path = SHADER_DIR,
                          version: int = 330) -> CrossCompiled:
    """Compile an HLSL pixel shader to SPIR-V and convert it to desktop GLSL ``version``.

    ``#include "..."`` lines resolve against ``include_dir`` (default: shaders/).
    """
    glslang, cross = tools()
    with tempfile.TemporaryDirectory(prefix="shlight-hlsl-") as tmp:
        src, spv = Path(tmp) / "shader.frag.hlsl", Path(tmp) / "shader.spv"
        src.write_text(source)
        _run([glslang, "-D", "-V", "-S", "frag", "-e", entry, f"-I{include_dir}",
              "-o", str(spv), str(src)], "glslangValidator")
        # --no-420pack-extension: no layout(binding) (not in core GLSL 3.30); the harness
        # binds the block itself.
        glsl = _run([cross, str(spv), "--version", str(version), "--no-es",
                     "--no-420pack-extension"], "spirv-cross")
    return _describe(glsl)


def _run(cmd, tool) -> str:
    try:
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=60)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise HlslCompileError(f"{tool} failed to run: {exc}") from None
    if r.returncode != 0:
        raise HlslCompileError(f"{tool} failed (exit {r.returncode}):\n{r.stdout}{r.stderr}")
    return r.stdout


_BLOCK = re.compile(r"uniform\s+(\w+)\s*\{(.*?)\}\s*\w*\s*;", re.S)
_MEMBER = re.compile(r"(layout\(([^)]*)\)\s*)?(\w+)\s+(\w+)\s*(\[\d+\])?\s*;")


def _describe(glsl: str) -> CrossCompiled:
    """Find the uniform block spirv-cross made of the HLSL globals (if any)."""
    m = _BLOCK.search(glsl)
    if not m:
        return CrossCompiled(glsl)
    members = [(name, gltype + array, "row_major" in (layout or ""))
               for _, layout, gltype, name, array in _MEMBER.findall(m.group(2))]
    return CrossCompiled(glsl, m.group(1), members)
