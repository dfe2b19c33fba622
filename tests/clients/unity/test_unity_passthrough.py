"""Unity renders a hologram through the headset's passthrough camera (issue 42, items 4 and 6).

The package's core (unity_package/Runtime/Core/Sh9Passthrough.cs, Sh9Capture.cs) is compiled with Mono's
mcs and driven by tests/csharp/PassthroughTest.cs; SH9 Diffuse's SH9_PASSTHROUGH path is compiled with
glslang and run (spirv-cross → GLSL, software OpenGL through moderngl); SH9PassthroughSender is compiled
against stand-ins of UnityEngine and of MRUK's PassthroughCameraAccess (tests/unity_stubs) and sends a
simulated headset's views to a real `shlight serve --passthrough`. The hologram beside its real replica:
a grey Lambertian sphere lit by the room's SH9 and rendered through the model `fit_views` fitted, against
the codes the simulated headset records for the real sphere (tests/replica_unity.py). Nothing here runs
Unity or MRUK.
"""
from __future__ import annotations

import base64
import json
import math
import re
import shutil
import subprocess

import numpy as np
import pytest

from conftest import load_hdri
from provider.core.passthrough import display_codes, display_lookup
from replica_unity import replica_codes, sphere_pixels, stops_apart, true_irradiance
from unitytools import CORE, CSHARP, HARNESS, PKG, RUNTIME, STANDIN, _compile, _mono_tools

STUBS = STANDIN.parent
DRIVER = [HARNESS, CSHARP / "PassthroughTest.cs"]
SHADERS = PKG / "Shaders"
#: A room none of the shared nine is as it stands, and the albedo of the grey sphere.
ROOM, ROOM_SEED = "venice", 23
ALBEDO = 0.5
#: The issue's bar for a consumer's grey sphere: within 0.1 stop of its real replica.
REPLICA_STOPS = 0.1


def _run(exe, *args, stdin: str, timeout=120) -> list[dict]:
    _, mono = _mono_tools()
    r = subprocess.run([mono, str(exe), *args], input=stdin, capture_output=True, text=True,
                       timeout=timeout)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-4000:]
    return [json.loads(line) for line in r.stdout.splitlines() if line.strip()]


@pytest.fixture(scope="module")
def core_exe(tmp_path_factory):
    return _compile(tmp_path_factory.mktemp("passthrough") / "PassthroughTest.exe", [*CORE, *DRIVER])


@pytest.fixture(scope="module")
def room():
    return perturb(load_hdri(ROOM))


def perturb(pano):
    from provider.bench.headset_sim import perturb_panorama
    return perturb_panorama(pano, seed=ROOM_SEED)


@pytest.fixture(scope="module")
def headset(room, tmp_path_factory):
    """40 views of the room by the simulated headset (no exposure metadata), and the fit."""
    from provider.bench.headset_sim import HeadsetSim
    from provider.core.passthrough import fit_views, read_transforms
    from provider.core.passthrough.views import read_view_image
    folder = tmp_path_factory.mktemp("headset")
    truth = HeadsetSim(n_views=40, seed=4).render(room, str(folder))
    views = read_transforms(str(folder / "transforms.json"))
    result = fit_views(room, views, [read_view_image(v) for v in views])
    return truth, result, folder


@pytest.fixture(scope="module")
def sh9_message(room):
    """The room's SH9 as the server sends it (provider's compute on the panorama)."""
    from provider.core.sh9.engine import compute_sh9
    res = compute_sh9(room)
    return {"type": "sh9", "version": 1, "probe": "default", "seq": 1, "time": 0.0,
            "frame": "rh-y-up", "coefficients": res.coefficients.reshape(-1).tolist(),
            "matrices": res.matrices.reshape(-1).tolist()}


def _messages(result, view: int, dim: float = 1.0):
    """The camera and the view's answer as /capture sends them; ``dim`` scales the exposure (a
    hologram in the dark)."""
    doc = result.to_json()
    v = doc["views"][view]
    camera = {"type": "passthrough_camera", "camera": doc["camera"]}
    answer = {"type": "passthrough", "time": float(view), "view": view, "exposure": v["exposure"] * dim,
              "wb_gains": v["wb_gains"], "ev100": v["ev100"], "residual_stops": v["residual_stops"],
              "samples": v["samples"], "solved": True, "dropped_views": 0}
    return camera, answer


def _render(core_exe, result, sh9_message, scenes):
    """The C# core's grey surfaces: ``scenes`` is [(view, normals)] or [(view, normals, dim)], one output
    per scene."""
    camera, _ = _messages(result, 0)
    lines = [camera, sh9_message]
    for view, normals, *dim in scenes:
        lines += [_messages(result, view, *dim)[1],
                  {"normals": np.asarray(normals).tolist(), "albedo": ALBEDO}]
    out = _run(core_exe, "render", stdin="\n".join(json.dumps(m) for m in lines) + "\n")
    assert len(out) == len(scenes)
    return out


# ---- (a) the display lookup: the same 256 entries in C# as in Python ---------------------------------

def test_the_lookup_is_the_contracts_and_reproduces_the_fitted_curve(core_exe, headset):
    """From the fitted camera.json, the C# core builds the contract's 256-entry lookup (the library's
    display_lookup, to float precision: its range from code 1 to the top) and reads it as display_codes
    does, the linear toe under the first entry and the top code over the last included; and the lookup
    gives back the curve: a sensor exposure g(z) comes out as code z within 0.02 stop of light over the
    codes 6..250 the fit uses."""
    truth, result, _ = headset
    table = result.response.table
    camera = result.response.to_dict()
    lookup = display_lookup(result.response)
    z = np.arange(6, 251, dtype=np.float64)
    x = np.stack([table[z.astype(int), c] for c in range(3)], -1)
    # under the first entry (0 included) and over the last, each the same in r, g, b
    f = np.array([0.0, 1e-3, 0.3, 0.7, 0.999, 1.0, 1.7, 50.0])
    edges = np.repeat((np.where(f <= 1, 2.0 ** lookup.lo, 2.0 ** lookup.hi) * f)[:, None], 3, 1)
    xs = np.vstack([x, edges])
    (out,) = _run(core_exe, "lut", stdin=json.dumps(camera) + "\n" + json.dumps(xs.tolist()) + "\n")
    assert out["log2_lo"] == pytest.approx(lookup.lo, abs=1e-12)
    assert out["log2_hi"] == pytest.approx(lookup.hi, abs=1e-12)
    assert out["toe_scale"] == pytest.approx(2.0 ** -lookup.lo, rel=1e-12)
    got = np.asarray(out["lut"]).reshape(256, 4)
    assert np.all(got[:, 3] == 1.0)
    # float32 storage: 6e-8 of a value in [0, 1]
    assert np.abs(got[:, :3] - lookup.table).max() < 1e-6
    display = np.asarray(out["display"]).reshape(-1, 3)
    assert np.abs(display - display_codes(lookup, xs)).max() < 1e-6
    toe = display[len(x):len(x) + 5]
    assert (toe[0] == 0).all() and (np.diff(toe, axis=0) > 0).any()
    assert (display[-2:] == 1.0).all()
    # and it inverts the curve: both codes turned into light by the fitted curve
    display = display[:len(x)]
    back = np.stack([np.interp(display[:, c] * 255, np.arange(256), table[:, c]) for c in range(3)], -1)
    worst = np.abs(np.log2(back / x)).max()
    print(f"\nlookup over {lookup.hi - lookup.lo:.1f} stops ({(lookup.hi - lookup.lo) / 255:.3f} stop an entry), "
          f"worst round trip {worst:.4f} stop")
    assert worst < 0.02


def test_answers_are_parsed_and_bad_ones_keep_the_last(core_exe, tmp_path):
    """The gain the shaders get is exposure · wb of the last usable answer; a dropped view or one without
    usable pixels (fitted false) keeps it; a camera that is not a camera.json is refused, never applied."""
    src = tmp_path / "Parse.cs"
    src.write_text("""
using System; using Shlight.Lighting;
static class P { static int Main() {
  var s = new Sh9PassthroughState(); var g = new double[3];
  Console.WriteLine(s.Gain(0, g) + " " + s.Ready);
  s.Handle("{\\"type\\":\\"passthrough\\",\\"exposure\\":0.5,\\"wb_gains\\":[1.2,1,0.8],\\"ev100\\":3,\\"view\\":0}");
  s.Handle("{\\"type\\":\\"passthrough\\",\\"dropped\\":true,\\"reason\\":\\"busy\\",\\"dropped_views\\":1}");
  s.Handle("{\\"type\\":\\"passthrough\\",\\"fitted\\":false,\\"exposure\\":0.1,\\"wb_gains\\":null}");
  s.Handle("{\\"type\\":\\"passthrough_camera\\",\\"camera\\":{\\"format\\":\\"other\\",\\"table\\":{}}}");
  s.Handle("{\\"type\\":\\"error\\",\\"error\\":\\"bad_view\\",\\"detail\\":\\"not a rotation\\"}");
  bool ok = s.Gain(1, g);
  Console.WriteLine(ok + " " + g[0] + " " + g[1] + " " + g[2] + " " + s.Answers + " " + s.Dropped + " " +
                    s.Errors + " " + (s.Camera == null) + " " + s.LastError);
  return 0; } }
""")
    exe = _compile(tmp_path / "Parse.exe", [*CORE, src])
    _, mono = _mono_tools()
    lines = subprocess.run([mono, str(exe)], capture_output=True, text=True, timeout=60).stdout.splitlines()
    assert lines[0] == "False False"
    ok, r, g, b, answers, dropped, errors, no_camera, *error = lines[1].split()
    assert ok == "True" and [float(r), float(g), float(b)] == pytest.approx([1.2, 1.0, 0.8])  # 0.5 · 2^1 · wb
    assert (answers, dropped, errors, no_camera) == ("3", "1", "1", "True")
    assert " ".join(error) == "bad_view: not a rotation"


# ---- (c) the hologram beside its real replica -----------------------------------------------------

def test_a_grey_sphere_renders_within_a_tenth_of_a_stop_of_its_real_replica(core_exe, headset, room,
                                                                             sh9_message):
    """A grey Lambertian sphere (albedo 0.5) at the centre of each of the 40 views: the hologram lit by the
    room's SH9 and drawn by the C# core's maths through the fitted model (the view's exposure and white
    balance, the display lookup) shows, in the median over its visible pixels, the light its real replica
    shows in that view's recorded codes within 0.1 stop, worst channel, in every view where the replica is
    neither clipped nor black. The naive way (sRGB, the exposure by the mean, no white balance) does not."""
    from provider.bench.headset_sim import naive_model
    truth, result, _ = headset
    naive = naive_model(truth, room)
    scenes, reals, naives = [], [], []
    for i in range(len(truth.views)):
        normals, rho2 = sphere_pixels(truth.views[i], truth.rotations[i])
        e = true_irradiance(room, normals)
        real = replica_codes(truth, i, e, rho2, ALBEDO)
        if not ((real >= 1) & (real <= 254)).all():
            continue
        scenes.append((i, normals))
        reals.append(real)
        naives.append(naive(i, ALBEDO / math.pi * e, rho2))
    biases, naive_biases = [], []
    for out, real, naive_codes in zip(_render(core_exe, result, sh9_message, scenes), reals, naives):
        hologram = np.asarray(out["display"]) * 255
        biases.append(float(np.abs(np.median(stops_apart(truth, hologram, real), axis=0)).max()))
        naive_biases.append(float(np.abs(np.median(stops_apart(truth, naive_codes, real), axis=0)).max()))
    biases = np.array(biases)
    print(f"\ngrey sphere in {len(biases)} views: median {np.median(biases):.3f}, worst {biases.max():.3f} stop "
          f"(naive: median {np.median(naive_biases):.3f}, worst {max(naive_biases):.3f})")
    assert len(biases) >= 30
    # the bar; measured 0.045 median, 0.06 worst: a BLAS's or OpenCV's last digits in the fit
    # (1e-6 of a stop) cannot decide it
    assert biases.max() <= REPLICA_STOPS, biases
    assert np.median(naive_biases) > 2 * np.median(biases)



# ---- (b) SH9 Diffuse's SH9_PASSTHROUGH path, compiled and run ---------------------------------------

def _tool(name):
    path = shutil.which(name)
    if not path:
        pytest.skip(f"{name} is not installed (apt-get install glslang-tools spirv-cross)")
    return path


def _gl_context():
    try:
        import moderngl
    except ImportError:
        pytest.skip("moderngl is not installed (pip install -e .[test])")
    try:
        return moderngl.create_context(standalone=True, require=330, backend="egl")
    except Exception as exc:  # moderngl raises plain Exceptions when no GL library is found
        pytest.skip(f"no OpenGL 3.3 context ({exc}); on Debian: apt-get install libegl1 libgl1-mesa-dri")


def _fragment_glsl(tmp_path, defines) -> tuple[str, dict]:
    """The colour pass's fragment stage (SH9ForwardFragment) compiled as Unity compiles the URP pass with
    `defines`, as GLSL 330, and spirv-cross's reflection of it."""
    src = tmp_path / "pass.hlsl"
    src.write_text('#include "HLSLSupport.cginc"\n#include "UnityShaderVariables.cginc"\n'
                   '#define SH9_URP\n#include "SH9DiffusePasses.hlsl"\n')
    spv = tmp_path / f"pass_{len(defines)}.spv"
    cmd = [_tool("glslangValidator"), "-D", "-V", "-S", "frag", "-e", "SH9ForwardFragment", "-o", str(spv),
           *[f"-D{d}" if "=" in d else f"-D{d}=1" for d in defines], f"-I{SHADERS}", f"-I{STUBS}", str(src)]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    glsl = subprocess.run([_tool("spirv-cross"), str(spv), "--version", "330", "--no-es", "--no-420pack-extension"],
                          capture_output=True, text=True, timeout=60)
    refl = subprocess.run([_tool("spirv-cross"), str(spv), "--reflect"], capture_output=True, text=True, timeout=60)
    assert glsl.returncode == 0 and refl.returncode == 0, glsl.stderr + refl.stderr
    return glsl.stdout, json.loads(refl.stdout)


def _run_fragment(ctx, glsl, refl, normals, values, lut, colour):
    """One point per normal through the fragment stage: uniform blocks filled by member name (others 0), a
    white 1×1 _MainTex, ``colour`` as the vertex stage's _Color, and the lookup as a 256×1 float texture, bilinear, clamped. Returns (N, 4)."""
    inputs = re.findall(r"^in (\w+) (\w+);", glsl, re.M)
    vertex = ("#version 330\nin vec3 normal;\nuniform float width;\n" + "".join(f"out {t} {n};\n" for t, n in inputs) +
              "void main() {\n  gl_Position = vec4((float(gl_VertexID) + 0.5) / width * 2.0 - 1.0, 0.0, 0.0, 1.0);\n"
              "  gl_PointSize = 1.0;\n  i_uv = vec2(0.5);\n  i_worldNormal = normal;\n"
              f"  i_color = vec4({colour!r}, {colour!r}, {colour!r}, 1.0);\n}}\n")   # the vertex stage's _Color
    prog = ctx.program(vertex_shader=vertex, fragment_shader=glsl)
    n = len(normals)
    prog["width"].value = float(n)
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
    white = ctx.texture((1, 1), 4, np.ones(4, np.float32).tobytes(), dtype="f4")
    table = ctx.texture((256, 1), 4, np.asarray(lut, np.float32).tobytes(), dtype="f4")
    table.repeat_x = table.repeat_y = False
    import moderngl
    table.filter = (moderngl.LINEAR, moderngl.LINEAR)
    samplers = [name for name in prog if "sampler" in name.lower() or "Combined" in name or name.startswith("_")]
    for name in samplers:
        if "PassthroughLut" in name:
            prog[name].value = 1
        elif "MainTex" in name and not name.endswith("_ST"):
            prog[name].value = 0
    white.use(0)
    table.use(1)
    fbo = ctx.framebuffer(color_attachments=[ctx.texture((n, 1), 4, dtype="f4")])
    fbo.use()
    fbo.clear()
    vbo = ctx.buffer(np.asarray(normals, np.float32).tobytes())
    ctx.vertex_array(prog, [(vbo, "3f", "normal")]).render(mode=ctx.POINTS, vertices=n)
    return np.frombuffer(fbo.read(components=4, dtype="f4"), np.float32).reshape(n, 4)


def _srgb_encode(x):
    x = np.clip(np.asarray(x, np.float64), 0, 1)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


#: How much darker the hologram in the dark is drawn: its sensor exposures ~14 stops under the sphere's, far
#: below the lookup's first entry (code 1), in its linear toe.
DARK = 2.0 ** -14


@pytest.mark.parametrize("colour_space", ["linear", "gamma"])
def test_the_shaders_passthrough_path_draws_what_the_core_computes(core_exe, headset, sh9_message, tmp_path,
                                                                   colour_space):
    """SH9 Diffuse's colour pass with SH9_PASSTHROUGH (compiled from the package's HLSL, run in software
    OpenGL) draws the grey sphere of one view as the C# core computes it: the lookup's display value written
    as is in a gamma project, its sRGB decoding in a linear one (which the sRGB framebuffer encodes back to
    it), within 0.001 of the display value (a quarter of a code: float32 and the texture unit's filtering).
    The same sphere in the dark (the exposure 2^-14 of the view's), under the lookup's first entry, is drawn
    on its linear toe to code 0 as the core computes it, within 0.3 %. Both colour passes carry the keyword,
    in the fragment stage only."""
    shader = (SHADERS / "SH9Diffuse.shader").read_text()
    passes = re.findall(r'Name "SH9Diffuse".*?ENDCG', shader, re.S)
    assert len(passes) == 2 and all("#pragma multi_compile_fragment _ SH9_PASSTHROUGH" in p for p in passes)
    truth, result, _ = headset
    view = 7
    normals, _ = sphere_pixels(truth.views[view], truth.rotations[view], step_px=4.0)
    core, dark = _render(core_exe, result, sh9_message, [(view, normals), (view, normals, DARK)])
    m = np.asarray(core["matrices"]).reshape(3, 4, 4)
    defines = ["SHADER_API_D3D11", "SHADER_TARGET=35", "UNITY_VERSION=202230", "SHADER_STAGE_FRAGMENT",
               "SH9_PASSTHROUGH"]
    if colour_space == "gamma":
        defines.append("UNITY_COLORSPACE_GAMMA")
    glsl, refl = _fragment_glsl(tmp_path, defines)
    lo, hi, toe = core["log2_lo"], core["log2_hi"], core["toe_scale"]
    lookup = display_lookup(result.response)
    lut4 = np.concatenate([lookup.table, np.ones((256, 1))], -1)
    unity_normals = np.asarray(normals) * [1, 1, -1]          # the vertex stage's world normals (Unity frame)
    # a material's colour is sRGB in Unity's colour picker: a gamma project hands the shader the encoded value
    # (decoded by UnityCG's GammaToLinearSpace, a polynomial within 0.1 % of sRGB), a linear one the linear value
    colour = ALBEDO if colour_space == "linear" else float(_srgb_encode(ALBEDO))
    ctx = _gl_context()
    shown = {}
    for name, run in (("lit", core), ("dark", dark)):
        values = {"_SHIrradianceR": m[0], "_SHIrradianceG": m[1], "_SHIrradianceB": m[2], "_Exposure": 1.0,
                  "_SHMainLightScale": 0.0, "_SHPassthroughGain": [*run["gain"], 0.0],
                  "_SHPassthroughRange": [lo, 1 / (hi - lo), toe, 0]}
        out = _run_fragment(ctx, glsl, refl, unity_normals, values, lut4, colour)
        assert np.allclose(out[:, 3], 1.0)
        shown[name] = out[:, :3] if colour_space == "gamma" else _srgb_encode(out[:, :3])
    want = np.asarray(core["display"])
    worst = np.abs(shown["lit"] - want).max()
    # the dark sphere is on the toe: each channel a tenth of its first entry or less, not black
    want_dark = np.asarray(dark["display"])
    assert (want_dark <= 0.1 * lookup.table[0]).all() and want_dark.max() > 0
    on_toe = want_dark > 0
    dark_worst = np.abs(shown["dark"][on_toe] / want_dark[on_toe] - 1).max()
    print(f"\n{colour_space}: {len(normals)} pixels, worst {worst * 255:.3f} code from the core's; in the dark "
          f"(codes up to {want_dark.max() * 255:.4f}) worst {dark_worst:.2e} of the core's")
    assert worst < 1e-3
    # float32 shading, and in a gamma project the colour's polynomial sRGB decoding (0.1 %)
    assert dark_worst < 3e-3
    assert (shown["dark"][~on_toe] == 0).all()


# ---- (d) the sender on Quest, against a real server -------------------------------------------------

S = np.diag([1.0, 1.0, -1.0])


def _unity_quaternion(r):
    from scipy.spatial.transform import Rotation
    return Rotation.from_matrix(r).as_quat().tolist()      # (x, y, z, w), Unity's order


@pytest.fixture(scope="module")
def sender_exe(tmp_path_factory):
    return _compile(tmp_path_factory.mktemp("sender") / "PassthroughSender.exe",
                    [*CORE, *RUNTIME, STANDIN, STUBS / "MrukStandIn.cs", *DRIVER],
                    defines=("SHLIGHT_MRUK",))


def test_the_runtime_compiles_without_mruk(tmp_path):
    """Without SHLIGHT_MRUK (a project without Meta's MRUK) the package compiles: the sender is an empty
    component that says what it needs."""
    _compile(tmp_path / "Runtime.dll", [*CORE, *RUNTIME, STANDIN], target="library")
    assert "#if SHLIGHT_MRUK" in (PKG / "Runtime" / "SH9PassthroughSender.cs").read_text()


def test_the_sender_sends_quest_views_to_capture_and_the_client_renders_through_the_answers(
        sender_exe, room, tmp_path):
    """SH9PassthroughSender (against stand-ins of UnityEngine and MRUK's PassthroughCameraAccess) on a
    simulated Quest: each camera image (a simulated headset's JPEG), the camera's Unity pose, intrinsics on a
    square 1280-style sensor of which the image is the centred 4:3 crop, and the lighting client's anchor
    turned and moved. Against a real `shlight serve --passthrough --token`, every view message carries the
    view's transforms.json pose in the probe's frame and its intrinsics, every view is answered, the curve
    arrives, and SH9LightingClient in Exposure Mode Passthrough switches SH9_PASSTHROUGH on with the gain
    exposure · wb of the last answer."""
    import OpenEXR
    from provider.bench.headset_sim import HeadsetSim, look_rotation
    from servertools import ServerThread, poll
    exr = tmp_path / "room.exr"
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(room, np.float32)}) as f:
        f.write(str(exr))
    folder = tmp_path / "views"
    HeadsetSim(n_views=8, width=160, height=120, seed=5).render(room, str(folder))
    doc = json.loads((folder / "transforms.json").read_text())
    w, h, fl, cx, cy = doc["w"], doc["h"], doc["fl_x"], doc["cx"], doc["cy"]
    # the anchor: where the 360° camera is in the headset's (Unity) world, and how it is turned
    anchor_r = S @ look_rotation(35.0, 8.0, 3.0) @ S
    anchor_p = np.array([0.4, 1.1, -2.5])
    lines = []
    for frame in doc["frames"]:
        m = np.asarray(frame["transform_matrix"], np.float64)
        local_r, local_p = S @ m[:3, :3] @ S, S @ m[:3, 3]          # the camera relative to the anchor, Unity
        lines.append(json.dumps({
            "position": (anchor_p + anchor_r @ local_p).tolist(),
            "rotation": _unity_quaternion(anchor_r @ local_r),
            "anchor_position": anchor_p.tolist(), "anchor_rotation": _unity_quaternion(anchor_r),
            "focal": [fl, fl], "sensor": [w, w],
            # MRUK's principal point: y up from the bottom of the square sensor, the image its centred crop
            "principal": [cx, (h - cy) + (w - h) / 2], "size": [w, h], "time": frame["time"],
            "jpeg": base64.b64encode((folder / frame["file_path"]).read_bytes()).decode()}))
    token = "quest-token"
    with ServerThread("--source", str(exr), "--fps", "5", "--passthrough", "--passthrough-hz", "0",
                      "--token", token) as srv:
        poll(lambda: srv.call(lambda: next(iter(srv.server.probes.values())).image is not None),
             what="the probe's first frame")
        out = _run(sender_exe, "sender", srv.url, token, "240", stdin="\n".join(lines) + "\n", timeout=300)
    sent, final = [o["sent"] for o in out[:-1]], out[-1]
    assert len(sent) == len(doc["frames"]) and all(sent), out
    for message, frame in zip(sent, doc["frames"]):
        v = json.loads(message)
        assert v["type"] == "view" and (v["w"], v["h"]) == (w, h)
        assert np.allclose(np.reshape(v["transform_matrix"], (4, 4)), frame["transform_matrix"], atol=1e-5)
        assert [v["fl_x"], v["fl_y"], v["cx"], v["cy"]] == pytest.approx([fl, fl, cx, cy], abs=1e-4)
        assert v["time"] == pytest.approx(frame["time"], abs=1e-6)
    print(f"\n{final}")
    assert final["answers"] == len(sent) and final["errors"] == 0 and final["dropped"] == 0, final
    assert final["camera"] and final["lut_uploaded"] and final["passthrough_active"] and final["keyword"]
    assert final["gain"][1] == pytest.approx(final["exposure"], rel=1e-6)     # green: wb = 1
    # the lookup's range as SH9DiffusePasses.hlsl reads it: (lo, 1 / (hi − lo), 2^−lo) of the curve received
    lo, hi = final["log2_lo"], final["log2_hi"]
    assert final["range"] == pytest.approx([lo, 1 / (hi - lo), 2.0 ** -lo], rel=1e-6)
