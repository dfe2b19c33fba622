"""The reflection cube in the export formats (provider/core/reflections/gltf_ibl.py, conventions.py),
each read the way its consumer reads it (tests/consumers.py: Babylon.js's EXT_lights_image_based
loader and PBR lookup; ARCore's acquireEnvironmentalHdrCubeMap as Google's sample uploads it),
and the cube following --rotate wherever the coefficients do (shlight environment, export,
serve --environment).

One-sided scenes: tests/envtools.py write_caps (red cap around +X, green +Y, blue −Z), and
smooth lobes around one axis; a real panorama for the roughness of each mip.
"""
from __future__ import annotations

import base64
import json
import math

import cv2
import jsonschema
import numpy as np
import pytest

import consumers as cs
import reference_cube as ref
from envtools import CAPS, read_ktx2_cube, served_cube, write_caps
from provider.core.conventions import formats as cv
from provider.core.reflections import gltf_ibl
from provider.core.reflections.environment import EnvironmentProjector
from provider.core.errors import InputError
from provider.live.wire.export import export_message
from provider.live.wire.message import load_schema
from servertools import ServerThread, http_get, run_cli

VALIDATOR = jsonschema.Draft202012Validator(load_schema())
AXES = {"+x": np.array([1.0, 0, 0]), "+y": np.array([0, 1.0, 0]), "-z": np.array([0, 0, -1.0])}
SIX = np.vstack([np.eye(3), -np.eye(3)])
MESSAGE = {"type": "sh9", "version": 1, "probe": "p", "seq": 3, "time": 1.0, "stale": False,
           "coefficients": [0.0] * 27, "lights": 0}


def lobe(axis, w=256, h=128, power=8, scale=3.0):
    """A panorama lit only around ``axis``: scale · max(0, d·axis)^power, colour (1, .5, .25)."""
    d = ref.equirect_directions(w, h)
    v = np.maximum(d @ np.asarray(axis, float), 0.0) ** power * scale
    return (v[..., None] * np.array([1.0, 0.5, 0.25])).astype(np.float32)


def babylon_mips(img, size=16, **options):
    """The provider's cube of ``img`` prefiltered at Babylon's roughness (what the CLI exports)."""
    p = EnvironmentProjector(img.shape[1], img.shape[0], size=size,
                             mip_roughness=gltf_ibl.babylon_roughness(size), **options)
    return p.project(img)


def rgbd_close(got, want):
    """Within RGBD's 8-bit steps: half a step of (x·D)^(1/2.2), D ≥ max/255 or 1."""
    peak = np.maximum(np.asarray(want).max(axis=-1, keepdims=True), 1.0)
    assert np.all(np.abs(got - want) <= 0.003 + 0.006 * peak), np.abs(got - want).max()


# ---- glTF EXT_lights_image_based, read by Babylon.js ------------------------------------------------

@pytest.mark.parametrize("handedness", ["left", "right"])
@pytest.mark.parametrize("name", list(AXES))
def test_gltf_cube_reflects_the_light_where_babylon_shows_the_asset(name, handedness):
    a = AXES[name]
    env = babylon_mips(lobe(a))
    ex = cv.export(np.zeros((9, 3)), "gltf", babylon_handedness=handedness, environment=env.mips)
    light = ex["light"]
    assert "missing_required" not in ex and "warning" not in ex
    cube = cs.babylon_gltf_cube(light, ex["images"])
    lod0 = cs.babylon_lod(0.0, light["specularImageSize"], len(cube))
    # a mirror sphere: the reflection toward the glTF axis is bright, the opposite one black
    mirror = cs.babylon_sample(cube, cs.babylon_lookup(np.vstack([a, -a]), handedness), lod0)
    np.testing.assert_allclose(mirror[0], env.mips[0][cs_face(a)].max(axis=(0, 1)), rtol=0.02)
    assert mirror[1].max() == 0.0
    # in Babylon's world: where the loader puts the asset's axis (the root node mirrors x in a
    # left-handed scene), and the lookup Babylon makes for each world direction
    root = np.array([-1.0, 1, 1]) if handedness == "left" else np.ones(3)
    lookups = SIX * (np.ones(3) if handedness == "left" else np.array([1.0, 1, -1]))
    shown = cs.babylon_sample(cube, lookups, lod0)[:, 0]
    np.testing.assert_array_equal(SIX[int(np.argmax(shown))], root * a)
    # every texel of every mip is the provider's radiance toward the same glTF direction
    for k, mip in enumerate(env.mips):
        d = ref.cube_directions(mip.shape[1]).reshape(-1, 3)
        got = cs.babylon_sample(cube, cs.babylon_lookup(d, handedness), float(k))
        rgbd_close(got, mip.reshape(-1, 3))


def cs_face(a):
    return {(1, 0, 0): 0, (0, 1, 0): 2, (0, 0, -1): 5}[tuple(int(x) for x in a)]


def test_gltf_handedness_modes_differ_by_a_half_turn_about_y_for_the_cube_too():
    env = babylon_mips(lobe(AXES["+x"]))
    ex = cv.export(np.zeros((9, 3)), "gltf", environment=env.mips)       # left
    cube = cs.babylon_gltf_cube(ex["light"], ex["images"])
    shown = cs.babylon_sample(cube, cs.babylon_lookup(SIX, "right"), 0.0)[:, 0]
    np.testing.assert_array_equal(SIX[int(np.argmax(shown))], [-1, 0, 0])


def test_gltf_mips_are_at_the_roughness_babylon_reads_them(hdri):
    """Babylon's own prefilter writes mip k at α = 2^(k/scale)/size (hdrFiltering.ts:127-130)
    and its shader reads roughness ρ at log2(size·α)·scale; with the loader's scale, mip k of
    the export must be the GGX-prefiltered radiance at that α (brute force over every pixel)."""
    size, img = 16, hdri("sky")
    img = np.where(np.isfinite(img) & (img > 0), img, 0).astype(np.float32)   # as the provider
    env = babylon_mips(img, size)
    ex = cv.export(np.zeros((9, 3)), "gltf", environment=env.mips)
    mips = len(ex["light"]["specularImages"])
    scale = (mips - 1) / math.log2(size)                    # EXT_lights_image_based.pure.ts:147
    alpha = [2 ** (k / scale) / size for k in range(mips)]
    np.testing.assert_allclose(ex["specular_roughness"][1:], np.sqrt(alpha[1:]), rtol=1e-12)
    assert ex["specular_roughness"][0] == 0.0 and ex["specular_roughness"][-1] == 1.0
    cube = cs.babylon_gltf_cube(ex["light"], ex["images"])
    for k in range(1, mips):
        rho = math.sqrt(alpha[k] - 0.0005)                  # the material roughness at lod k
        assert cs.babylon_lod(rho, size, mips) == pytest.approx(k, abs=1e-9)
        n = size >> k
        d = ref.cube_directions(n).reshape(-1, 3)
        shown = cs.babylon_sample(cube, cs.babylon_lookup(d), cs.babylon_lod(rho, size, mips))
        want = ref.prefiltered(img, ref.cube_directions(n), math.sqrt(alpha[k])).reshape(-1, 3)
        assert ref.rel_rms(shown, want) < 0.03, k
        # the provider's own roughness k/(K−1) would be a different lobe here
        if k < mips - 1:
            other = ref.prefiltered(img, ref.cube_directions(n), k / (mips - 1)).reshape(-1, 3)
            assert ref.rel_rms(shown, other) > 2 * ref.rel_rms(shown, want), k


def test_gltf_export_is_a_conforming_light_and_a_loadable_asset():
    env = babylon_mips(lobe(AXES["+y"]), size=32)
    msg = MESSAGE
    ex = export_message(msg, "gltf", environment=env.mips)
    VALIDATOR.validate(ex)
    light = ex["light"]
    # the extension's required properties (README.md:120-127) and its shapes
    for key in ("irradianceCoefficients", "specularImages", "specularImageSize"):
        assert key in light
    assert light["specularImageSize"] == 32 and light["intensity"] == 1.0
    assert np.shape(light["specularImages"]) == (5, 6)
    assert sorted(np.ravel(light["specularImages"])) == list(range(30))
    for k, faces in enumerate(light["specularImages"]):
        for i in faces:
            img = cv2.imdecode(np.frombuffer(base64.b64decode(
                ex["images"][i]["uri"].split(",", 1)[1]), np.uint8), cv2.IMREAD_UNCHANGED)
            assert img.shape == (32 >> k, 32 >> k, 4) and img.dtype == np.uint8
    doc = json.loads(json.dumps(ex["document"]))
    assert doc["asset"]["version"] == "2.0" and doc["extensionsUsed"] == ["EXT_lights_image_based"]
    assert doc["extensions"]["EXT_lights_image_based"]["lights"][0] == light
    assert doc["scenes"][doc["scene"]]["extensions"]["EXT_lights_image_based"]["light"] == 0
    assert doc["images"] == ex["images"] and ex["specular_clipped_texels"] == 0
    # without a cube the light is still flagged incomplete (the live /latest.json?to=gltf)
    bare = export_message(msg, "gltf")
    VALIDATOR.validate(bare)
    assert bare["missing_required"] == ["specularImages", "specularImageSize"]


def test_rgbd_range_and_steps():
    """Babylon's toRGBD (helperFunctions.ts:104) round trip through fromRGBD (:105): within
    8-bit steps from 1e-3 to 255, clipped and counted above 255."""
    v = np.geomspace(1e-3, 255.0, 400)
    rgb = np.stack([v, v * 0.5, v * 0.01], -1)
    enc, clipped = gltf_ibl.rgbd_encode(rgb)
    dec = (enc[:, :3] / 255.0) ** 2.2 / (enc[:, 3:] / 255.0)
    assert clipped == 0
    rgbd_close(dec, rgb)
    enc, clipped = gltf_ibl.rgbd_encode(np.array([[1000.0, 1.0, 0.0], [0.0, 0.0, 0.0]]))
    assert clipped == 1 and enc[1].tolist() == [0, 0, 0, 255]


def test_bad_cubes_are_one_clear_error():
    with pytest.raises(InputError, match="mip 1 must have shape"):
        cv.export(np.zeros((9, 3)), "gltf", environment=[np.zeros((6, 8, 8, 3)), np.zeros((6, 8, 8, 3))])
    with pytest.raises(InputError, match="mip_roughness"):
        EnvironmentProjector(64, 32, size=8, mip_roughness=[0.1, 0.5, 1.0])


# ---- ARCore acquireEnvironmentalHdrCubeMap ----------------------------------------------------------

@pytest.mark.parametrize("name", list(AXES))
def test_arcore_cube_is_glrgba16f_faces_in_gl_order(name):
    a = AXES[name]
    env = EnvironmentProjector(256, 128, size=16).project(lobe(a))
    ex = export_message(MESSAGE, "arcore", environment=env.mips[:1])
    VALIDATOR.validate(ex)
    c = ex["environmentalHdrCubeMap"]
    assert c["size"] == 16 and c["format"] == "AIMAGE_FORMAT_RGBA_FP16"
    # each image uploaded as glTexImage2D(GL_TEXTURE_CUBE_MAP_POSITIVE_X + i, ..., GL_RGBA16F,
    # GL_HALF_FLOAT, bytes) (SpecularCubemapFilter.java:265-274), then looked up with the world
    # reflection direction (environmental_hdr.frag:158): the same table as ours
    faces = np.stack([np.frombuffer(base64.b64decode(s), "<f2").reshape(16, 16, 4)
                      for s in c["images"]]).astype(np.float32)
    assert np.all(faces[..., 3] == 1.0)
    np.testing.assert_allclose(faces[..., :3], env.mips[0], rtol=1e-3, atol=1e-6)
    shown = cs.babylon_sample([faces[..., :3]], SIX, 0.0)[:, 0]
    np.testing.assert_array_equal(SIX[int(np.argmax(shown))], a)


# ---- the command line, and --rotate everywhere ------------------------------------------------------

def test_export_cli_carries_the_cube(tmp_path):
    pano = tmp_path / "caps.hdr"
    write_caps(pano, h=128)
    out = run_cli("export", str(pano), "--to", "gltf", "--cube-size", "16", timeout=120)
    assert out.returncode == 0, out.stderr
    ex = json.loads(out.stdout)
    VALIDATOR.validate(ex)
    assert ex["light"]["specularImageSize"] == 16 and "missing_required" not in ex
    cube = cs.babylon_gltf_cube(ex["light"], ex["images"])
    for label, (axis, rgb) in CAPS.items():       # each cap's colour toward its own axis
        got = cs.babylon_sample(cube, cs.babylon_lookup(np.array([axis], float)), 0.0)[0]
        np.testing.assert_allclose(got, rgb, rtol=0.02, atol=0.01, err_msg=label)
    out = run_cli("export", str(pano), "--to", "gltf", "--no-cube")
    assert json.loads(out.stdout)["missing_required"] == ["specularImages", "specularImageSize"]
    out = run_cli("export", str(pano), "--to", "arcore")
    assert json.loads(out.stdout)["environmentalHdrCubeMap"]["size"] == 16
    bad = run_cli("export", str(pano), "--to", "arcore", "--cube-size", "32")
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert "Traceback" not in bad.stderr


def sh_direction(coefficients, channel):
    """Where the SH9 puts a colour's light: its L1 band (L11, L1-1, L10) ∝ (x, y, z)."""
    c = np.asarray(coefficients, float).reshape(9, 3)[:, channel]
    v = np.array([c[3], c[1], c[2]])
    return v / np.linalg.norm(v)


def cube_direction(mip0, channel):
    """Where the cube puts a colour's light: the flux-weighted mean direction of mip 0."""
    n = mip0.shape[1]
    c = (np.arange(n) + 0.5) / n * 2 - 1                  # texel solid angle ∝ (1 + s² + t²)^-3/2
    omega = (1 + c[:, None] ** 2 + c[None, :] ** 2) ** -1.5
    w = mip0[..., channel] * omega
    v = (w[..., None] * ref.cube_directions(n)).sum(axis=(0, 1, 2))
    return v / np.linalg.norm(v)


def test_rotate_turns_cube_and_sh9_together_offline(tmp_path):
    """shlight environment/compute/export --rotate 90,0,0: the cube is the cube of the scene
    turned the way the coefficients turn, and SH9 and cube put each cap in the same place."""
    pano, rolled = tmp_path / "caps.hdr", tmp_path / "rolled.hdr"
    write_caps(pano, h=128)
    sh = json.loads(run_cli("compute", str(pano), "--rotate", "90,0,0").stdout)["coefficients"]
    red = sh_direction(sh, 0)
    assert abs(red[0]) < 0.1 and abs(abs(red[2]) - 1) < 0.1        # +X turned by 90° about +Y
    img = cv2.imread(str(pano), cv2.IMREAD_UNCHANGED)
    # roll the panorama so that the red cap lies where the coefficients put it (u = 0.25: −X,
    # 0.5: −Z, 0.75: +X; docs/contract.md §1)
    shift = -img.shape[1] // 4 if red[2] < 0 else img.shape[1] // 4
    assert cv2.imwrite(str(rolled), np.roll(img, shift, axis=1))
    plain = json.loads(run_cli("compute", str(rolled)).stdout)["coefficients"]
    np.testing.assert_allclose(plain, sh, atol=0.02 * np.abs(sh).max())
    for args in (["--rotate", "90,0,0"], []):
        src = pano if args else rolled
        out = run_cli("environment", str(src), "-o", str(tmp_path / "c.ktx2"), "--size", "16", *args)
        assert out.returncode == 0, out.stderr
        mips = read_ktx2_cube((tmp_path / "c.ktx2").read_bytes())
        if args:
            turned = mips
    for x, y in zip(turned, mips):
        assert ref.rel_rms(x, y) < 0.02
    for channel in range(3):        # the cube and the SH9 agree on where each cap is
        assert sh_direction(sh, channel) @ cube_direction(turned[0], channel) > 0.98
    # the export path: the glTF cube made with --rotate is the rolled scene's cube
    ex = json.loads(run_cli("export", str(pano), "--to", "gltf", "--cube-size", "16",
                            "--rotate", "90,0,0", timeout=120).stdout)
    ey = json.loads(run_cli("export", str(rolled), "--to", "gltf", "--cube-size", "16",
                            timeout=120).stdout)
    for x, y in zip(cs.babylon_gltf_cube(ex["light"], ex["images"]),
                    cs.babylon_gltf_cube(ey["light"], ey["images"])):
        assert ref.rel_rms(x, y) < 0.03
    np.testing.assert_allclose(ex["light"]["irradianceCoefficients"],
                               ey["light"]["irradianceCoefficients"], atol=0.05)


def test_serve_environment_follows_rotate(tmp_path):
    """shlight serve --environment --rotate: the served cube is the offline --rotate cube, and
    the served coefficients put each cap where the cube does."""
    pano = tmp_path / "caps.hdr"
    write_caps(pano, h=128)
    out = run_cli("environment", str(pano), "-o", str(tmp_path / "c.ktx2"), "--rotate", "90,0,0")
    offline = read_ktx2_cube((tmp_path / "c.ktx2").read_bytes())
    with ServerThread("--source", str(pano), "--environment", "--rotate", "90,0,0",
                      "--keepalive", "60") as srv:
        mips, _ = served_cube(srv.http)
        status, _, body = http_get(srv.http + "/latest.json")
    assert out.returncode == 0 and status == 200
    for x, y in zip(mips, offline):
        np.testing.assert_allclose(x, y, rtol=2e-3, atol=1e-3)
    coefficients = json.loads(body)["coefficients"]
    for channel in range(3):
        assert sh_direction(coefficients, channel) @ cube_direction(mips[0], channel) > 0.98


# ---- the live path: a twin projector at Babylon's roughness, the cube encoded once -----------

def test_a_twin_at_babylons_roughness_is_the_projector_made_for_it_and_shares_its_work_image():
    """EnvironmentProjector.at_roughness (what serve --environment uses for gltf): the same
    mips as a projector built with mip_roughness, from the work image the cube's own
    projector hands the SH9 pass (so the live glTF cube needs no second decode)."""
    from provider.core.sh9.engine import SH9Projector
    img = (np.clip(lobe(AXES["+x"], 128, 64), 0, 1) * 255).astype(np.uint8)
    cube = EnvironmentProjector(128, 64, size=16)
    twin = cube.at_roughness(gltf_ibl.babylon_roughness(16))
    made = babylon_mips(img, size=16)
    assert twin.roughness == made.roughness != cube.roughness
    sh9 = SH9Projector(128, 64)
    work = cube.new_work(sh9)
    sh9.project(img, work=work)
    shared = twin.project(img, work=work)
    assert shared.stats.get("shared_decode") is True
    for a, b in zip(shared.mips, made.mips):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-7)
    np.testing.assert_array_equal(shared.mips[0], cube.project(img).mips[0])


def test_a_twin_refilters_the_cubes_pyramid_to_the_mips_it_would_project():
    """What serve --environment does per cube for gltf: the twin's refilter of the cube's
    result (the prefilter alone) gives the mips its own projection of the frame gives, sun
    and all (the bright pixels' exact path); a result of another geometry is refused."""
    sun = lobe(AXES["+y"], 256, 128)
    sun[20, 40] = 1e4                          # a sun 10⁴× the sky: the bright-pixel path
    cube = EnvironmentProjector(256, 128, size=32)
    twin = cube.at_roughness(gltf_ibl.babylon_roughness(32))
    made = cube.project(sun, exposure_s=0.5)
    refiltered = twin.refilter(made)
    projected = twin.project(sun, exposure_s=0.5)
    assert len(refiltered.mips) == len(projected.mips) == len(made.mips)
    for a, b in zip(refiltered.mips, projected.mips):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-6)
    assert refiltered.roughness == twin.roughness != made.roughness
    assert refiltered.mips[0] is made.mips[0]
    assert not np.allclose(refiltered.mips[2], made.mips[2])     # another roughness
    assert refiltered.stats["exposure_s"] == 0.5 and refiltered.stats["compute_ms"] > 0
    other = EnvironmentProjector(256, 128, size=32).project(sun)
    with pytest.raises(ValueError, match="projector of this geometry"):
        twin.refilter(other)


def test_an_encoded_cube_is_the_export_of_its_mips():
    env = babylon_mips(lobe(AXES["-z"]), size=16)
    once = cv.encode_cube("gltf", env.mips)
    assert cv.export(np.zeros((9, 3)), "gltf", environment=once) == \
        cv.export(np.zeros((9, 3)), "gltf", environment=env.mips)
    with pytest.raises(InputError, match="cannot serve a gltf export"):
        cv.export(np.zeros((9, 3)), "gltf", babylon_handedness="right", environment=once)
    # arcore: mip 0 pooled exactly to ARCore's 16² from a finer cube; a coarser one refused
    fine = EnvironmentProjector(256, 128, size=32).project(lobe(AXES["-z"])).mips
    coarse = EnvironmentProjector(256, 128, size=16).project(lobe(AXES["-z"])).mips
    assert cv.encode_cube("arcore", fine).fields["size"] == 16
    np.testing.assert_allclose(_halves(cv.encode_cube("arcore", fine)),
                               _halves(cv.encode_cube("arcore", coarse)), rtol=2e-3, atol=1e-6)
    tiny = EnvironmentProjector(64, 32, size=8).project(lobe(AXES["-z"], 64, 32)).mips
    with pytest.raises(InputError, match="too coarse"):
        cv.encode_cube("arcore", tiny)


def _halves(encoded):
    return np.stack([np.frombuffer(base64.b64decode(s), "<f2") for s in encoded.fields["images"]]
                    ).astype(np.float32)
