"""Probes with positions (docs/contract.md §3, docs/probes.md "Light between probes"): ``shlight
serve --probe-position NAME=X,Y,Z`` puts ``position`` in every message of that probe, over
WebSocket, /latest.json and MQTT; a probe without one has none; ``shlight register`` prints
the camera's position in the marker's frame, which serve reads back."""
from __future__ import annotations

import json

import numpy as np
import pytest

from mqtttools import Mosquitto, Subscriber
from provider.live.wire.message import validate
from servertools import (ServeProcess, ServerThread, connect, health, http_get, poll,
                         recv_until, refused, run_cli)


def test_every_message_of_a_placed_probe_says_where_it_is():
    with ServerThread("--probe", "door=demo", "--probe", "desk=demo", "--fps", "10",
                      "--keepalive", "0.2", "--probe-position", "door=1.5,1.2,-0.25") as srv:
        with connect(srv.url) as ws:
            seen = {}
            while len(seen) < 2 or min(len(v) for v in seen.values()) < 3:
                msg = recv_until(ws, lambda m: m.get("type") == "sh9", what="sh9")
                validate(msg)
                seen.setdefault(msg["probe"], []).append(msg)
        assert all(m["position"] == [1.5, 1.2, -0.25] for m in seen["door"])
        assert all("position" not in m for m in seen["desk"])     # unknown: absent
        status, _, body = http_get(srv.http + "/latest.json?probe=door")
        assert status == 200 and json.loads(body)["position"] == [1.5, 1.2, -0.25]
        assert health(srv.http)["probes"]["door"]["position"] == [1.5, 1.2, -0.25]
        assert "position" not in health(srv.http)["probes"]["desk"]


def test_the_position_reaches_mqtt(tmp_path):
    with Mosquitto(tmp_path) as broker, \
            ServeProcess("--probe", "hall=demo", "--probe-position", "hall=0,2.5,3",
                         "--mqtt", f"mqtt://127.0.0.1:{broker.port}/site") as proc:
        poll(lambda: http_get(f"{proc.http}/latest.json?probe=hall")[0] == 200, timeout=30,
             what="the probe's lighting")
        with Subscriber(broker.port, "site/#") as sub:
            _, payload = sub.first("site/hall")
        msg = json.loads(payload)
        validate(msg)
        assert msg["position"] == [0.0, 2.5, 3.0]


def test_a_registered_camera_is_placed_from_registers_output(tmp_path):
    # What `shlight register` prints (its camera_position: tested below against a still)
    out = {"marker": "aruco:DICT_4X4_50:7", "rotation": np.eye(3).ravel().tolist(),
           "position": [-0.5, -1.0, -2.0], "camera_position": [0.5, 1.0, 2.0]}
    path = tmp_path / "register.json"
    path.write_text(json.dumps(out))
    with ServerThread("--fps", "10", "--probe-position", f"default={path}") as srv:
        with connect(srv.url) as ws:
            msg = recv_until(ws, lambda m: m.get("type") == "sh9", what="sh9")
    assert msg["position"] == [0.5, 1.0, 2.0]


@pytest.mark.parametrize("args,says", [
    (["--probe-position", "hall=1,2,3"], "no probe named 'hall'"),
    (["--probe-position", "default=1,2"], "expected X,Y,Z"),
    (["--probe-position", "default=1,2,inf"], "expected X,Y,Z"),
    (["--probe-position", "default"], "expected NAME=X,Y,Z"),
    (["--probe-position", "default=1,2,3", "--probe-position", "default=1,2,4"],
     "placed twice"),
    (["--probe-position", "default=missing.json"], "no such file"),
])
def test_bad_positions_are_refused_in_one_line(args, says):
    refused(run_cli("serve", "--port", "0", *args), says)


def test_register_prints_the_cameras_position_in_the_markers_frame(tmp_path):
    from marker_scene import composite, marker_grid, scene, to_srgb8
    from provider.core.geometry.projections import make_projection
    import cv2
    proj = make_projection("equirect", 1920, 960)
    base = scene("apartment", proj)
    # the marker 1.2 m ahead (-Z) and 0.3 m to the right, facing the camera (its z toward +Z)
    R, t = np.diag([1.0, 1.0, 1.0]), np.array([0.3, 0.0, -1.2])
    white = 0.8 * float(base.reshape(-1, 3).mean(0) @ [0.2126, 0.7152, 0.0722])
    rgb = to_srgb8(composite(base, proj, marker_grid(), R, t, 0.2), white)
    cv2.imwrite(str(tmp_path / "room.png"), rgb[..., ::-1])
    r = run_cli("register", str(tmp_path / "room.png"), "--marker", "aruco:DICT_4X4_50:7",
                "--marker-size", "0.2", timeout=120)
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    # the camera is 1.2 m out of the print and 0.3 m to its left (2 cm: the pose's target)
    assert np.allclose(out["camera_position"], [-0.3, 0.0, 1.2], atol=0.02)
