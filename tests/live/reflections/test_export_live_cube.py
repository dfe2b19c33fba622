"""The live cube in the live exports (``shlight serve --environment``; docs/contract.md §12):
``/latest.json?to=gltf`` carries EXT_lights_image_based's ``specularImages`` and ``to=arcore``
its ``environmentalHdrCubeMap``, made from the same frame as the served cube and read the way
each consumer reads them (tests/consumers.py: Babylon.js's loader and lookup), equal to the
offline ``shlight export`` of the same frame; a new cube changes them; encoded once per cube,
however many ask; without ``--environment`` the export says why it has no cube.
"""
from __future__ import annotations

import base64
import json

import jsonschema
import numpy as np
import pytest

import consumers as cs
import reference_cube as ref
from conftest import HDRI_DIR
from provider.live.wire.message import load_schema
from servertools import ServerThread, connect, http_get, poll, recv_until, run_cli

VALIDATOR = jsonschema.Draft202012Validator(load_schema())
PANORAMA = str(HDRI_DIR / "sky.exr")      # a real sky: a sun, the hardest case for RGBD


def latest(srv, fmt: str) -> dict:
    status, _, body = http_get(f"{srv.http}/latest.json?to={fmt}", timeout=30)
    assert status == 200, body
    out = json.loads(body)
    VALIDATOR.validate(out)
    return out


def live_export(srv, fmt: str) -> dict:
    """The export once it carries the live cube (the first request may find it still being
    encoded: the note says so, and a later one has it)."""
    poll(lambda: srv.server.probes["default"].latest_text, what="first lighting", timeout=60)
    return poll(lambda: (ex := latest(srv, fmt)).get("environment_seq") is not None and ex,
                what=f"the live {fmt} cube", timeout=60, interval=0.2)


def arcore_faces(ex) -> np.ndarray:
    c = ex["environmentalHdrCubeMap"]
    return np.stack([np.frombuffer(base64.b64decode(s), "<f2").reshape(c["size"], c["size"], 4)
                     for s in c["images"]]).astype(np.float32)


def test_live_gltf_and_arcore_exports_carry_the_live_cube_as_offline():
    """The live exports of a served panorama read, in Babylon.js (gltf) and as ARCore's sample
    uploads them (arcore), as the offline export of the same image: every mip at Babylon's
    roughness within RGBD's 8-bit steps (rel. RMS < 0.5 %, measured 0: the same bytes), the
    ARCore faces within float16 rounding. Two more requests: the same text, encoded once."""
    offline = json.loads(run_cli("export", PANORAMA, "--to", "gltf", timeout=120).stdout)
    offline_arcore = json.loads(run_cli("export", PANORAMA, "--to", "arcore").stdout)
    with ServerThread("--source", PANORAMA, "--environment", "--environment-size", "32",
                      "--keepalive", "60") as srv:
        ex = live_export(srv, "gltf")
        ar = live_export(srv, "arcore")
        worker = srv.server.probes["default"].environment
        encoded = srv.call(lambda: dict(worker.encoded))
        again = [http_get(f"{srv.http}/latest.json?to=gltf")[2] for _ in range(2)]
        assert srv.call(lambda: dict(worker.encoded)) == encoded == {"gltf": 1, "arcore": 1}
        assert srv.call(lambda: worker.latest.seq) == ex["environment_seq"]
    assert again[0] == again[1] and json.loads(again[0])["environment_seq"] == ex["environment_seq"]
    light = ex["light"]
    assert "missing_required" not in ex and "warning" not in ex and "cube_note" not in ex
    assert light["specularImageSize"] == 32 and np.shape(light["specularImages"]) == (5, 6)
    assert ex["specular_roughness"] == offline["specular_roughness"]
    assert ex["document"]["extensions"]["EXT_lights_image_based"]["lights"][0] == light
    live_cube = cs.babylon_gltf_cube(light, ex["images"])
    offline_cube = cs.babylon_gltf_cube(offline["light"], offline["images"])
    for k, (got, want) in enumerate(zip(live_cube, offline_cube)):
        assert ref.rel_rms(got, want) < 0.005, k
        # and what a Babylon.js PBR material of each mip's roughness shows, every direction
        d = ref.cube_directions(got.shape[1]).reshape(-1, 3)
        seen = [cs.babylon_sample(c, cs.babylon_lookup(d), float(k))
                for c in (live_cube, offline_cube)]
        assert ref.rel_rms(*seen) < 0.005, k
    np.testing.assert_allclose(light["irradianceCoefficients"],
                               offline["light"]["irradianceCoefficients"], rtol=1e-4, atol=1e-6)
    assert ar["environmentalHdrCubeMap"]["size"] == 16 and "cube_note" not in ar
    np.testing.assert_allclose(arcore_faces(ar), arcore_faces(offline_arcore), rtol=2e-3,
                               atol=1e-4)


def test_a_new_cube_changes_the_served_images():
    """The synthetic scene changes: each new cube (environment_seq) brings new images to
    /latest.json?to=gltf and to a WebSocket client that subscribed with to=gltf."""
    with ServerThread("--fps", "10", "--environment", "--environment-size", "16",
                      "--environment-hz", "4") as srv, connect(srv.url + "?to=gltf") as ws:
        first = live_export(srv, "gltf")
        later = poll(lambda: (ex := latest(srv, "gltf"))["environment_seq"]
                     > first["environment_seq"] and ex, what="a new cube", timeout=60,
                     interval=0.2)
        # the cube lags its sh9 message (made on its own thread at --environment-hz): the
        # first export may pair message N with an older cube, the later one the same message
        # with the cube made from it (cube_fanout.exports_changed: same seq, new cube)
        assert later["seq"] >= first["seq"]
        assert later["images"] != first["images"]
        assert later["light"]["specularImages"] == first["light"]["specularImages"]
        pushed = recv_until(ws, lambda m: m.get("type") == "export"
                            and m.get("environment_seq", -1) >= later["environment_seq"],
                            timeout=30, what="an export with the new cube")
        VALIDATOR.validate(pushed)
        assert pushed["format"] == "gltf" and "missing_required" not in pushed


def test_a_client_with_to_gltf_gets_the_cube_once_it_is_encoded():
    """A still scene (no new sh9 message for 60 s): a client that connects with ?to=gltf gets
    the export at once, and again (same seq) with the cube once its thread has encoded it."""
    with ServerThread("--source", PANORAMA, "--environment", "--keepalive", "60") as srv:
        poll(lambda: srv.server.probes["default"].environment.latest, what="the first cube",
             timeout=60)
        with connect(srv.url + "?to=gltf") as ws:
            first = recv_until(ws, lambda m: m.get("type") == "export", what="an export")
            assert "environment_seq" not in first and "being encoded" in first["cube_note"]
            full = recv_until(ws, lambda m: m.get("type") == "export" and "environment_seq" in m,
                              timeout=60, what="the export with the cube")
    VALIDATOR.validate(full)
    assert full["seq"] == first["seq"] and "missing_required" not in full
    assert len(full["light"]["specularImages"]) == 5


@pytest.mark.parametrize("fmt", ["gltf", "arcore"])
def test_without_environment_the_export_says_why_it_has_no_cube(fmt):
    with ServerThread("--source", PANORAMA, "--keepalive", "60") as srv:
        poll(lambda: srv.server.probes["default"].latest_text, what="first lighting", timeout=60)
        ex = latest(srv, fmt)
    assert "environment_seq" not in ex
    assert "--environment" in ex["cube_note"] and "makes no reflection cube" in ex["cube_note"]
    if fmt == "gltf":
        assert ex["missing_required"] == ["specularImages", "specularImageSize"]
    else:
        assert "environmentalHdrCubeMap" not in ex


def test_an_arcore_export_of_a_cube_coarser_than_arcores_says_so():
    with ServerThread("--source", PANORAMA, "--environment", "--environment-size", "8",
                      "--keepalive", "60") as srv:
        poll(lambda: srv.server.probes["default"].latest_text, what="first lighting", timeout=60)
        ex = poll(lambda: "failed" in (e := latest(srv, "arcore")).get("cube_note", "") and e,
                  what="the arcore note", timeout=60, interval=0.2)
    assert "environmentalHdrCubeMap" not in ex and "16" in ex["cube_note"]
