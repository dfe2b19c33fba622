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
from pathlib import Path

import numpy as np
import pytest

from conftest import load_hdri
from replica_unity import display_lut, lut_display, replica_codes, sphere_pixels, stops_apart

ROOT = Path(__file__).resolve().parent.parent
PKG = ROOT / "unity_package"
CORE = sorted((PKG / "Runtime" / "Core").glob("*.cs"))
RUNTIME = sorted((PKG / "Runtime").glob("*.cs"))
STUBS = ROOT / "tests" / "unity_stubs"
DRIVER = ROOT / "tests" / "csharp" / "PassthroughTest.cs"
SHADERS = PKG / "Shaders"
#: A room none of the shared nine is as it stands, and the albedo of the grey sphere.
ROOM, ROOM_SEED = "venice", 23
ALBEDO = 0.5
#: The issue's bar for a consumer's grey sphere: within 0.1 stop of its real replica.
REPLICA_STOPS = 0.1


def _mono():
    mcs, mono = shutil.which("mcs"), shutil.which("mono")
    if not (mcs and mono):
        pytest.skip("Mono is not installed: apt-get install mono-mcs mono-runtime")
    return mcs, mono


def _compile(out: Path, sources, defines=()):
    mcs, _ = _mono()
    r = subprocess.run([mcs, "-nologo", "-warnaserror+", "-nowarn:618", f"-out:{out}",
                        *[f"-define:{d}" for d in defines], *map(str, sources)],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stdout + r.stderr
    return out


def _run(exe, *args, stdin: str, timeout=120) -> list[dict]:
    _, mono = _mono()
    r = subprocess.run([mono, str(exe), *args], input=stdin, capture_output=True, text=True,
                       timeout=timeout)
    assert r.returncode == 0, r.stdout[-2000:] + r.stderr[-4000:]
    return [json.loads(line) for line in r.stdout.splitlines() if line.strip()]


@pytest.fixture(scope="module")
def core_exe(tmp_path_factory):
    return _compile(tmp_path_factory.mktemp("passthrough") / "PassthroughTest.exe", [*CORE, DRIVER])


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


def _messages(result, view: int):
    doc = result.to_json()
    v = doc["views"][view]
    camera = {"type": "passthrough_camera", "camera": doc["camera"]}
    answer = {"type": "passthrough", "time": float(view), "view": view, "exposure": v["exposure"],
              "wb_gains": v["wb_gains"], "ev100": v["ev100"], "residual_stops": v["residual_stops"],
              "samples": v["samples"], "solved": True, "dropped_views": 0}
    return camera, answer


def _render(core_exe, result, view, sh9_message, normals):
    camera, answer = _messages(result, view)
    scene = {"normals": np.asarray(normals).tolist(), "albedo": ALBEDO}
    (out,) = _run(core_exe, "render", stdin="\n".join(json.dumps(m) for m in
                                                     (camera, answer, sh9_message, scene)) + "\n")
    return out


# ---- (a) the display lookup: the same 256 entries in C# as in Python ---------------------------------

def test_the_lookup_is_the_contracts_and_reproduces_the_fitted_curve(core_exe, headset):
    """From the fitted camera.json, the C# core builds the contract's 256-entry lookup (the same numbers
    as tests/replica_unity.py to float precision), and the lookup gives back the curve: a sensor exposure
    g(z) comes out as code z within 0.02 stop of light over the codes 6..250 the fit uses."""
    truth, result, _ = headset
    table = result.response.table
    camera = result.response.to_dict()
    lo, hi, lut = display_lut(table)
    z = np.arange(6, 251, dtype=np.float64)
    x = np.stack([table[z.astype(int), c] for c in range(3)], -1)
    (out,) = _run(core_exe, "lut", stdin=json.dumps(camera) + "\n" + json.dumps(x.tolist()) + "\n")
    assert out["log2_lo"] == pytest.approx(lo, abs=1e-12) and out["log2_hi"] == pytest.approx(hi, abs=1e-12)
    got = np.asarray(out["lut"]).reshape(256, 4)
    assert np.all(got[:, 3] == 1.0)
    # float32 storage: 6e-8 of a value in [0, 1]
    assert np.abs(got[:, :3] - lut).max() < 1e-6
    display = np.asarray(out["display"]).reshape(-1, 3)
    assert np.abs(display - lut_display(lo, hi, lut, x)).max() < 1e-6
    # and it inverts the curve: both codes turned into light by the fitted curve
    back = np.stack([np.interp(display[:, c] * 255, np.arange(256), table[:, c]) for c in range(3)], -1)
    worst = np.abs(np.log2(back / x)).max()
    print(f"\nlookup over {hi - lo:.1f} stops, worst round trip {worst:.4f} stop")
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
    _, mono = _mono()
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
    biases, naive_biases = [], []
    for i in range(len(truth.views)):
        normals, rho2 = sphere_pixels(truth.views[i], truth.rotations[i])
        real = replica_codes(truth, i, room, normals, rho2, ALBEDO)
        if not ((real >= 1) & (real <= 254)).all():
            continue
        out = _render(core_exe, result, i, sh9_message, normals)
        hologram = np.asarray(out["display"]) * 255
        err = stops_apart(truth, hologram, real)
        biases.append(float(np.abs(np.median(err, axis=0)).max()))
        e = np.concatenate([brute(room, normals)])
        naive_codes = naive(i, ALBEDO / math.pi * e, rho2)
        naive_biases.append(float(np.abs(np.median(stops_apart(truth, naive_codes, real), axis=0)).max()))
    biases = np.array(biases)
    print(f"\ngrey sphere in {len(biases)} views: median {np.median(biases):.3f}, worst {biases.max():.3f} stop "
          f"(naive: median {np.median(naive_biases):.3f}, worst {max(naive_biases):.3f})")
    assert len(biases) >= 30
    assert biases.max() <= REPLICA_STOPS, biases
    assert np.median(naive_biases) > 2 * np.median(biases)


def brute(panorama, normals):
    from reference import brute_irradiance
    return np.concatenate([brute_irradiance(panorama, normals[i:i + 256]) for i in range(0, len(normals), 256)])
