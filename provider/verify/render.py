"""Headless OpenGL for the shader harness and the examples (moderngl + EGL).

:func:`create_context` gives a standalone OpenGL 3.3+ core context without a display:
Mesa's llvmpipe on machines without a GPU, the real GPU where there is one.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..core.options import MAX_LIGHTS      # the shaders' light slots (SH_MAX_LIGHTS)

#: The shipped shaders: package data (provider/shaders, in a source checkout a link to the
#: repository's shaders/ folder, which the Unity package and the examples use too).
SHADER_DIR = Path(__file__).resolve().parents[1] / "shaders"

INSTALL_HINT = ("headless OpenGL needs EGL and a Mesa driver: on Debian/Ubuntu "
                "`sudo apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri`")


#: What an install without the ``gl`` extra (moderngl, glfw) is told when it needs them.
GL_EXTRA_HINT = ("the GL harness is not installed (moderngl, glfw): "
                 "pip install 'shlight[gl]'")


class NoOpenGL(RuntimeError):
    """No OpenGL context could be made; the message names what to install."""


def gl_module(name: str):
    """``moderngl`` or ``glfw``, or :class:`NoOpenGL` naming the extra that installs them."""
    import importlib
    try:
        return importlib.import_module(name)
    except ImportError:  # an edge install leaves the GL harness out (the gl extra)
        raise NoOpenGL(GL_EXTRA_HINT) from None


def create_context(require: int = 330):
    """A standalone moderngl context (EGL backend), or :class:`NoOpenGL` with a hint."""
    moderngl = gl_module("moderngl")
    errors = []
    for kwargs in ({"backend": "egl"}, {}):
        try:
            return moderngl.create_context(standalone=True, require=require, **kwargs)
        except Exception as exc:  # moderngl raises plain Exceptions for missing libraries
            errors.append(f"{kwargs or 'default'}: {exc}")
    raise NoOpenGL(f"cannot create an OpenGL {require // 100}.{require % 100 // 10} context "
                   f"({'; '.join(errors)}). {INSTALL_HINT}")


def shader_source(name: str) -> str:
    """Text of a file in shaders/ (e.g. "sh9_irradiance.glsl")."""
    path = SHADER_DIR / name
    if not path.exists():
        raise FileNotFoundError(f"shader {name} not found in {SHADER_DIR}")
    return path.read_text()


def uv_sphere(segments: int = 64, rings: int = 32):
    """Unit sphere mesh: (positions (N, 3) float32, normals (N, 3), indices (M, 3) uint32).

    Triangles are counter-clockwise seen from outside (OpenGL's default front face).
    """
    theta = np.linspace(0, math.pi, rings + 1)
    phi = np.linspace(0, 2 * math.pi, segments + 1)
    t, p = np.meshgrid(theta, phi, indexing="ij")
    pos = np.stack([np.sin(t) * np.sin(p), np.cos(t), -np.sin(t) * np.cos(p)], -1).reshape(-1, 3)
    idx = []
    for r in range(rings):
        for s in range(segments):
            a = r * (segments + 1) + s
            b = a + segments + 1
            idx += [(a, a + 1, b), (a + 1, b + 1, b)]  # counter-clockwise seen from outside
    pos = pos.astype(np.float32)
    return pos, pos.copy(), np.asarray(idx, np.uint32)


# -- meshes -------------------------------------------------------------------------------------

def torus(major_radius: float = 0.7, minor_radius: float = 0.3, segments: int = 96,
          sides: int = 48):
    """Torus around the +Y axis, centred at the origin (the "mesh" of the validation pictures).

    Returns (positions (N, 3) float32, unit normals (N, 3) float32, indices (M, 3) uint32),
    counter-clockwise triangles seen from outside. Unlike a sphere its normals do not equal
    its positions, and its inner ring faces inward, so it shows irradiance on normals that a
    sphere seen from one side hides.
    """
    u = np.linspace(0, 2 * math.pi, segments + 1)      # around the main axis (+Y)
    v = np.linspace(0, 2 * math.pi, sides + 1)         # around the tube
    uu, vv = np.meshgrid(u, v, indexing="ij")
    ring = np.stack([np.cos(uu), np.zeros_like(uu), -np.sin(uu)], -1)   # tube centre direction
    normal = ring * np.cos(vv)[..., None] + np.array([0.0, 1.0, 0.0]) * np.sin(vv)[..., None]
    pos = ring * major_radius + normal * minor_radius
    a = (np.arange(segments)[:, None] * (sides + 1) + np.arange(sides)[None, :]).reshape(-1)
    b = a + sides + 1
    idx = np.concatenate([np.stack([a, b, a + 1], -1), np.stack([a + 1, b, b + 1], -1)])
    return (pos.reshape(-1, 3).astype(np.float32), normal.reshape(-1, 3).astype(np.float32),
            idx.astype(np.uint32))


# -- camera matrices (row-major float64, column vectors: clip = P @ V @ world) -----------------

def perspective(fovy_deg: float, aspect: float, near: float = 0.1, far: float = 100.0):
    """OpenGL perspective projection (right-handed eye space looking down -Z, clip z in [-w, w])."""
    f = 1.0 / math.tan(math.radians(fovy_deg) / 2)
    return np.array([[f / aspect, 0, 0, 0],
                     [0, f, 0, 0],
                     [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)],
                     [0, 0, -1, 0]], np.float64)


def look_at(eye, target=(0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0)):
    """World-to-eye matrix of a camera at ``eye`` looking at ``target`` (right-handed, +Y up)."""
    eye, target, up = (np.asarray(v, np.float64) for v in (eye, target, up))
    f = target - eye
    f /= np.linalg.norm(f)
    s = np.cross(f, up)
    s /= np.linalg.norm(s)
    u = np.cross(s, f)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = s, u, -f
    view[:3, 3] = -view[:3, :3] @ eye
    return view


def write_matrix(program, name: str, matrix) -> None:
    """Set a mat3/mat4 uniform from a row-major (math-convention) numpy matrix.

    GLSL matrices are column-major, so the bytes are those of the transpose. Missing
    uniforms (optimised away by the driver) are ignored.
    """
    if name in program:
        program[name].write(np.ascontiguousarray(np.asarray(matrix, np.float32).T).tobytes())


# -- programs -------------------------------------------------------------------------------------

_INCLUDE = "#include"


def expand_includes(text: str, _depth: int = 0) -> str:
    """Replace each ``#include "file"`` line by the text of shaders/file (recursively).

    GLSL has no standard #include: the shipped .vert/.frag files use this one-line form so a
    renderer can paste sh9_irradiance.glsl in (this function does it for moderngl).
    """
    if _depth > 8:
        raise ValueError("#include nested too deeply")
    out = []
    for line in text.splitlines(keepends=True):
        stripped = line.strip()
        if stripped.startswith(_INCLUDE):
            name = stripped[len(_INCLUDE):].strip().strip('"<>')
            body = expand_includes(shader_source(name), _depth + 1)
            out.append(f"// begin {name}\n{body.rstrip()}\n// end {name}\n")
        else:
            out.append(line)
    return "".join(out)


def load_program(ctx, vertex: str, fragment: str):
    """A moderngl program from two files in shaders/, with ``#include`` lines expanded."""
    return ctx.program(vertex_shader=expand_includes(shader_source(vertex)),
                       fragment_shader=expand_includes(shader_source(fragment)))


#: Tone-mapping modes of shaders/lit_diffuse.frag (uniform int toneMap).
TONE_MAPS = {"none": 0, "reinhard": 1, "aces": 2}


def lit_diffuse_program(ctx):
    """The demo program: a Lambertian mesh lit by SH9 (shaders/lit_diffuse.vert/.frag).

    Uniforms: ``model``, ``viewProjection`` (mat4), ``normalMatrix`` (mat3), ``albedo``
    (vec3, linear), ``exposure`` (float), ``toneMap`` (int, :data:`TONE_MAPS`), ``srgbOutput``
    (bool) and the irradiance matrices (:func:`set_irradiance_matrices`). Vertex attributes
    ``in_position`` and ``in_normal``. Output: ρE/π × exposure, tone mapped, optionally sRGB.
    """
    return load_program(ctx, "lit_diffuse.vert", "lit_diffuse.frag")


IRRADIANCE_UNIFORMS = ("shIrradianceR", "shIrradianceG", "shIrradianceB")


def set_irradiance_matrices(program, matrices, names=IRRADIANCE_UNIFORMS) -> None:
    """Upload the three irradiance matrices (3, 4, 4) (the wire "matrices", right-handed).

    M is symmetric and ñᵀMñ depends only on the symmetric part, so the upload order
    (row- or column-major) cannot change the result.
    """
    m = np.asarray(matrices, np.float64).reshape(3, 4, 4)
    for name, mc in zip(names, m):
        write_matrix(program, name, mc)


def set_uniform(program, name: str, value) -> None:
    """Set a uniform if the driver kept it (unused uniforms are optimised away)."""
    if name in program:
        program[name].value = value


def mesh_vertex_array(ctx, program, positions, normals, indices):
    """A vertex array with ``in_position``/``in_normal`` attributes and an index buffer."""
    vbo = ctx.buffer(np.hstack([positions, normals]).astype("f4").tobytes())
    ibo = ctx.buffer(np.asarray(indices, "u4").tobytes())
    attrs = [a for a in ("in_position", "in_normal") if a in program]
    fmt = " ".join("3f" if a in attrs else "3x4" for a in ("in_position", "in_normal"))
    return ctx.vertex_array(program, [(vbo, fmt, *attrs)], index_buffer=ibo, index_element_size=4)


# -- display transforms (numpy twins of the ones in lit_diffuse.frag) -------------------------------

def tone_map(x, mode: str = "reinhard"):
    """Per-channel tone map of linear values: none, Reinhard x/(1+x), or ACES (Narkowicz fit)."""
    x = np.maximum(np.asarray(x, np.float64), 0.0)
    if mode == "none":
        return x
    if mode == "reinhard":
        return x / (1.0 + x)
    if mode == "aces":
        return np.clip((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)
    raise ValueError(f"tone map must be one of {sorted(TONE_MAPS)}; got {mode!r}")


def srgb_encode(linear):
    """IEC 61966-2-1 sRGB encoding of linear values, clipped to [0, 1]."""
    c = np.clip(np.asarray(linear, np.float64), 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1 / 2.4) - 0.055)


# -- the lights uniforms of shaders/sh9_lights.glsl (provider.verify.lights) ---------------------


def _slots(directions, irradiance) -> np.ndarray:
    """(2, MAX_LIGHTS, 4) float32: direction and irradiance vec4 per slot (w = 0)."""
    d = np.asarray(directions, np.float64).reshape(-1, 3)
    irr = np.asarray(irradiance, np.float64).reshape(-1, 3)
    if len(d) > MAX_LIGHTS or len(irr) != len(d):
        raise ValueError(f"at most {MAX_LIGHTS} lights, one irradiance per direction")
    out = np.zeros((2, MAX_LIGHTS, 4), np.float32)
    out[0, :len(d), :3], out[1, :len(d), :3] = d, irr
    return out


def upload_lights(program, directions, irradiance, count=None) -> None:
    """Set ``shLightDirection``, ``shLightIrradiance`` and ``shLightCount`` of a GLSL program
    (``count`` defaults to the number of lights; slots beyond them are zero)."""
    slots = _slots(directions, irradiance)
    n = len(np.asarray(directions).reshape(-1, 3)) if count is None else int(count)
    for name, data in (("shLightDirection", slots[0]), ("shLightIrradiance", slots[1])):
        if name in program:
            program[name].write(data.tobytes())
    set_uniform(program, "shLightCount", n)
