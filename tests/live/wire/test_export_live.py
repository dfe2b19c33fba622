"""Other engines' layouts from the live provider and the command line.

``shlight serve``: a WebSocket client subscribes with ``to`` (or ``?to=`` at connect) and gets
``export`` messages; ``/latest.json?to=FORMAT``; unknown formats get an ``error`` reply / HTTP
400 listing the formats; clients without ``to`` keep getting the sh9 message; each message is
converted once per format, however many clients asked. ``shlight export IMAGE --to FORMAT``
prints the same object for one image. The scene is a panorama lit from +X only, so the lit side
is checked end to end through each consumer's evaluation (tests/consumers.py).
"""
from __future__ import annotations

import contextlib
import json

import cv2
import jsonschema
import numpy as np
import pytest
from websockets.exceptions import InvalidStatus

import consumers as cs
from provider.core.conventions import formats as cv
from provider.live.wire.export import export_message
from provider.live.wire.message import load_schema
from servertools import ServerThread, collect, connect, http_get, poll, recv_json, recv_until, run_cli

VALIDATOR = jsonschema.Draft202012Validator(load_schema())
NORMALS = np.vstack([np.eye(3), -np.eye(3)])
RGB = np.array([1.0, 0.5, 0.25])


@pytest.fixture(scope="module")
def plus_x_panorama(tmp_path_factory):
    """A 64×32 Radiance HDR equirect: radiance (1, 0.5, 0.25) where x > 0 (u > 0.5), else 0.
    The column boundaries at u = 0.5 and 1 are the plane x = 0, so its exact SH9 is the
    analytic half-sphere one: E/π = (1 + x)/2 × colour, 0 at −X."""
    img = np.zeros((32, 64, 3), np.float32)
    img[:, 32:] = RGB
    path = tmp_path_factory.mktemp("pano") / "plus_x.hdr"
    assert cv2.imwrite(str(path), np.ascontiguousarray(img[..., ::-1]))
    return str(path)


def expected_plus_x(normals=NORMALS):
    return 0.5 * (1 + normals[:, 0])[:, None] * RGB[None, :]


def is_export(fmt):
    return lambda m: m.get("type") == "export" and m.get("format") == fmt


def sh9(m):
    return m.get("type") == "sh9"


def test_websocket_to_and_latest_json(plus_x_panorama):
    # unchanged lighting is resent only every 60 s: the latest message (and its seq) stays put
    with ServerThread("--source", plus_x_panorama, "--fps", "20", "--keepalive", "60") as srv:
        poll(lambda: srv.server.probes["default"].latest_text, what="first lighting")
        with connect(srv.url) as plain, connect(srv.url) as ws, \
                connect(srv.url + "?probe=default&to=arcore") as at_connect:
            hello = recv_json(ws)
            assert hello["formats"] == ["sh9", *cv.FORMATS]
            VALIDATOR.validate(hello)
            assert recv_json(plain)["type"] == "hello" and recv_json(at_connect)["type"] == "hello"

            # a client that never says `to` gets today's sh9 messages
            msg = recv_until(plain, sh9)
            VALIDATOR.validate(msg)
            assert "format" not in msg and len(msg["coefficients"]) == 27

            # subscribe with `to`: the reply says so, then export messages, lit from +X
            ws.send(json.dumps({"type": "subscribe", "probe": "default", "to": "webxr"}))
            ack = recv_until(ws, lambda m: m["type"] == "subscribed")
            assert ack == {"type": "subscribed", "probe": "default", "max_hz": 0.0, "to": "webxr"}
            ex = recv_until(ws, is_export("webxr"))
            VALIDATOR.validate(ex)
            assert ex["probe"] == "default" and ex["stale"] is False and ex["lights"] == 0
            coeffs = np.reshape(ex["sphericalHarmonicsCoefficients"], (9, 3))
            np.testing.assert_allclose(coeffs, np.reshape(msg["coefficients"], (9, 3)),
                                       rtol=1e-9, atol=1e-9)
            # the client that asked at connect (?to=arcore): ARCore's sample lights +X
            ar = recv_until(at_connect, is_export("arcore"))
            VALIDATOR.validate(ar)
            np.testing.assert_allclose(cs.arcore_sample(ar["sphericalHarmonics"], NORMALS),
                                       expected_plus_x(), rtol=2e-4, atol=2e-4)

            # an unknown format: the error reply, with the list; the connection stays open
            ws.send(json.dumps({"type": "subscribe", "to": "filament"}))
            err = recv_until(ws, lambda m: m["type"] == "error")
            VALIDATOR.validate(err)
            assert err["error"] == "unknown_format"
            assert "threejs, webxr, unity, arcore, gltf, openxr-android" in err["detail"]
            assert all(m.get("type") != "sh9" for m in collect(ws, 0.5))   # still webxr

            # switch layout, then back to the provider's own message
            ws.send(json.dumps({"type": "subscribe", "to": "unity"}))
            u = recv_until(ws, is_export("unity"))
            np.testing.assert_allclose(cs.unity_shown(u["sh"], NORMALS * cs.TO_UNITY),
                                       expected_plus_x(), rtol=2e-4, atol=2e-4)
            ws.send(json.dumps({"type": "subscribe", "to": "sh9"}))
            assert recv_until(ws, lambda m: m["type"] == "subscribed")["to"] == "sh9"
            recv_until(ws, sh9)
            assert all(m.get("type") != "export" for m in collect(ws, 0.5))

            # /latest.json?to=FORMAT: the same conversion as the library's
            for fmt in cv.FORMATS:
                status, headers, body = http_get(srv.http + f"/latest.json?probe=default&to={fmt}")
                assert status == 200 and headers["Content-Type"] == "application/json"
                ex = json.loads(body)
                VALIDATOR.validate(ex)
                status, _, native = http_get(srv.http + "/latest.json")
                want = export_message(json.loads(native), fmt)
                # the live formats with a cube say why it has none here (no --environment)
                assert ("--environment" in ex.pop("cube_note", "")) == (fmt in cv.CUBE_FORMATS)
                assert json.dumps(want, sort_keys=True) == json.dumps(ex, sort_keys=True)
            status, _, body = http_get(srv.http + "/latest.json?to=sh9")
            assert status == 200 and json.loads(body)["type"] == "sh9"
            status, _, body = http_get(srv.http + "/latest.json?to=babylon")
            err = json.loads(body)
            assert status == 400 and err["error"] == "unknown_format"
            assert "openxr-android" in err["detail"]

        with pytest.raises(InvalidStatus) as info:
            connect(srv.url + "?to=babylon", open_timeout=10)
        assert info.value.response.status_code == 400
        assert b"formats: threejs" in info.value.response.body


def test_conversion_runs_once_per_message_and_format():
    """Eight clients want webxr, two want gltf: the server converts each new message once per
    format, not once per client."""
    with ServerThread("--source", "demo", "--change-threshold", "0", "--fps", "30") as srv:
        with contextlib.ExitStack() as stack:
            clients = [stack.enter_context(connect(srv.url + ("?to=webxr" if i < 8 else "?to=gltf")))
                       for i in range(10)]
            for ws in clients:
                recv_json(ws)
            for i, ws in enumerate(clients):
                recv_until(ws, is_export("webxr" if i < 8 else "gltf"))
            before = srv.call(lambda: (srv.server.exports.conversions, srv.server.probes["default"].seq))
            # five new messages or more, however slow the machine (the clients' own
            # threads receive meanwhile)
            poll(lambda: srv.call(lambda: srv.server.probes["default"].seq) >= before[1] + 5,
                 timeout=120, interval=0.05, what="five more messages")
            after = srv.call(lambda: (srv.server.exports.conversions, srv.server.probes["default"].seq))
            got = [len([m for m in collect(ws, 0.2) if m.get("type") == "export"]) for ws in clients]
        published = after[1] - before[1]
        assert published >= 5 and min(got) >= 3
        assert after[0] - before[0] <= 2 * published + 2, (after, before)


# ---- shlight export ------------------------------------------------------------------------------------

def export_cli(*args) -> dict:
    res = run_cli("export", *args)
    assert res.returncode == 0, res.stderr
    out = json.loads(res.stdout)
    VALIDATOR.validate(out)
    return out


def test_cli_export_equals_the_conversion_of_compute(plus_x_panorama):
    computed = json.loads(run_cli("compute", plus_x_panorama).stdout)
    for fmt in ("threejs", "unity"):
        out = export_cli(plus_x_panorama, "--to", fmt, "--probe", "room")
        assert out["probe"] == "room" and out["format"] == fmt
        want = export_message(dict(computed, probe="room"), fmt)
        assert json.dumps(want, sort_keys=True) == json.dumps(out, sort_keys=True)


def test_cli_export_lights_the_right_side_in_each_variant(plus_x_panorama):
    """The options that pick a side of a documented disagreement reach the export, and each
    export still lights +X in the consumer that reads it that way."""
    for handed in ("left", "right"):
        out = export_cli(plus_x_panorama, "--to", "gltf", "--babylon-handedness", handed)
        assert out["convention"] == f"gltf-babylon-{handed}"
        np.testing.assert_allclose(cs.babylon_gltf(out["light"], NORMALS, handed),
                                   expected_plus_x(), rtol=2e-4, atol=2e-4)
    out = export_cli(plus_x_panorama, "--to", "openxr-android", "--no-condon-shortley")
    assert out["condon_shortley"] is False
    out = export_cli(plus_x_panorama, "--to", "arcore", "--no-condon-shortley", "--rotate", "90,0,0")
    # yaw 90° turns the +X light to −Z; the archived Unity SDK's reading puts it on Unity's +Z
    shown = cs.shade_sh9(cs.unity_pack(cs.arcore_unity_sdk_probe(out["sphericalHarmonics"])),
                         NORMALS * cs.TO_UNITY)
    np.testing.assert_allclose(NORMALS[int(np.argmax(shown[:, 0]))], [0, 0, -1])
    assert min(shown[:, 0]) == pytest.approx(0.0, abs=2e-4)
    out = export_cli(plus_x_panorama, "--to", "webxr")
    assert out["primaryLightIntensity"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


@pytest.mark.parametrize("args,needle", [
    (["{pano}"], "--to"),
    (["{pano}", "--to", "babylon"], "invalid choice"),
    (["{pano}", "--to", "unity", "--babylon-handedness", "right"], "gltf only"),
    (["{pano}", "--to", "threejs", "--no-condon-shortley"], "arcore or openxr-android only"),
    (["/nonexistent/pano.exr", "--to", "webxr"], "no such file"),
])
def test_cli_export_user_errors_are_one_line(plus_x_panorama, args, needle):
    res = run_cli("export", *[a.format(pano=plus_x_panorama) for a in args])
    assert res.returncode == 2 and res.stdout == ""
    assert "Traceback" not in res.stderr
    assert needle in res.stderr.strip().splitlines()[-1], res.stderr
