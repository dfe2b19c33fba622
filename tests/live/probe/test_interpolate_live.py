"""The light at points of the room, served live (docs/probes.md, "Light between probes"):
``shlight serve`` with eight positioned probes of the analytic room (provider/bench/room.py) and
``--room`` answers ``/latest.json?at=X,Y,Z`` with ``shlight interpolate``'s numbers and
``/probe-grid.json`` with a grid of SH9, behind the same token; bad requests are 400s."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from provider.bench import room
from provider.core.geometry import sh
from provider.live.wire.message import validate
from servertools import ServerThread, connect, http_get, poll, recv_until, refused, run_cli

TOKEN = "s3cret"


@pytest.fixture(scope="module")
def probes_file(tmp_path_factory):
    return room.write_probes(tmp_path_factory.mktemp("room"), height=128)


def _serve_args(probes_file, *extra):
    probes = json.loads(probes_file.read_text())["probes"]
    args = ["--fps", "2", "--token", TOKEN]
    for p in probes:
        args += ["--probe", f"{p['name']}={probes_file.parent / p['image']}",
                 "--probe-position", f"{p['name']}={','.join(map(str, p['position']))}"]
    return [*args, *extra]


def _get(srv, path):
    sep = "&" if "?" in path else "?"
    status, headers, body = http_get(f"{srv.http}{path}{sep}token={TOKEN}")
    return status, headers, json.loads(body) if body else None


def _interpolate(probes_file, *args):
    r = subprocess.run([sys.executable, "-m", "provider.cli", "interpolate", str(probes_file),
                        *map(str, args)], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)["points"]


def test_a_point_and_a_grid_through_the_room(probes_file):
    at = (2.2, 1.1, 3.4)
    with ServerThread(*_serve_args(probes_file, "--room", room.room_box())) as srv:
        found = poll(lambda: (lambda r: r if r[0] == 200 else None)(
            _get(srv, "/latest.json?at=" + ",".join(map(str, at)))), timeout=60,
            what="the light at the point")
        _, _, point = found
        assert point["type"] == "point" and point["method"] == "parallax"
        validate(point)
        # the command's numbers, from the same files (float PFM, read alike)
        cli = _interpolate(probes_file, "--at", ",".join(map(str, at)),
                           "--room", room.room_box())[0]
        assert np.allclose(point["coefficients"], cli["coefficients"], rtol=1e-5, atol=1e-6)
        assert sh.irradiance_error(np.reshape(point["coefficients"], (9, 3)),
                                   room.exact_sh9(at)) < 0.03
        # a grid for the engines: 5 × 2 × 4 points, x fastest
        status, _, grid = _get(srv, "/probe-grid.json?min=1,0.5,1&max=5,1.5,4&step=1")
        assert status == 200, grid
        assert grid["counts"] == [5, 2, 4] and grid["method"] == "parallax"
        positions = np.reshape(grid["positions"], (-1, 3))
        assert np.allclose(positions[:2], [[1, 0.5, 1], [2, 0.5, 1]])
        assert np.allclose(positions[5], [1, 1.5, 1]) and np.allclose(positions[10], [1, 0.5, 2])
        coefficients = np.reshape(grid["coefficients"], (-1, 9, 3))
        errors = [sh.irradiance_error(c, room.exact_sh9(x))
                  for c, x in zip(coefficients[::7], positions[::7])]
        # 32-row panoramas at grid points: 1.3 % median in the docs' room (resolution only)
        assert np.median(errors) < 0.03 and max(errors) < 0.08, errors
        # behind the token, as /latest.json
        status, _, _ = http_get(f"{srv.http}/probe-grid.json?min=1,1,1&max=2,2,2&step=1")
        assert status == 401


def test_without_the_room_a_point_blends_the_probes_messages(probes_file):
    at = (2.2, 1.1, 3.4)
    with ServerThread(*_serve_args(probes_file)) as srv:
        _, _, point = poll(lambda: (lambda r: r if r[0] == 200 else None)(
            _get(srv, "/latest.json?at=" + ",".join(map(str, at)))), timeout=60,
            what="the light at the point")
        assert point["method"] in ("tetrahedra", "hull") and point["lights"] == 0
        cli = _interpolate(probes_file, "--at", ",".join(map(str, at)))[0]
        assert point["weights"] == cli["weights"]
        # the live probes' SH9 (the engine's) equal the command's own projection of the files
        assert np.allclose(point["coefficients"], cli["coefficients"], rtol=1e-4, atol=1e-5)


def test_a_websocket_client_follows_a_point(probes_file):
    at, elsewhere = [2.2, 1.1, 3.4], [4.5, 0.6, 1.2]
    with ServerThread(*_serve_args(probes_file, "--room", room.room_box())) as srv:
        _, _, expected = poll(lambda: (lambda r: r if r[0] == 200 else None)(
            _get(srv, "/latest.json?at=" + ",".join(map(str, at)))), timeout=60,
            what="the light at the point")
        with connect(srv.url + f"?token={TOKEN}") as ws:
            ws.send(json.dumps({"type": "subscribe", "at": at}))
            msg = recv_until(ws, lambda m: m.get("type") == "point", timeout=60,
                             what="the point's light")
            validate(msg)
            assert msg["position"] == at and msg["coefficients"] == expected["coefficients"]
            # another point: its own light; a bad one: an error, the connection stays
            ws.send(json.dumps({"type": "subscribe", "at": elsewhere}))
            msg = recv_until(ws, lambda m: m.get("type") == "point"
                             and m["position"] == elsewhere, timeout=60, what="the new point")
            assert sh.irradiance_error(np.reshape(msg["coefficients"], (9, 3)),
                                       room.exact_sh9(elsewhere)) < 0.03
            ws.send(json.dumps({"type": "subscribe", "at": [1, "x", 2]}))
            err = recv_until(ws, lambda m: m.get("type") == "error", what="an error")
            assert err["error"] == "bad_request" and "at" in err["detail"]
            ws.send(json.dumps({"type": "subscribe", "at": [9, 1, 1]}))   # outside the room
            err = recv_until(ws, lambda m: m.get("type") == "error", what="an error")
            assert err["error"] == "bad_request" and "not inside the room" in err["detail"]
            # the point followed before is still followed: its light comes again as the
            # probes' frames change (a file source re-sends its frame: same numbers)
            ws.send(json.dumps({"type": "ping", "id": 1}))
            recv_until(ws, lambda m: m.get("type") == "pong", what="the pong")


@pytest.mark.parametrize("path,code,says", [
    ("/latest.json?at=1,2", 400, "expected X,Y,Z"),
    ("/latest.json?at=9,1,1", 400, "not inside the room"),
    ("/probe-grid.json?min=0.5,0.5,0.5&max=5.5,2.5,4.5&step=0.1", 400, "at most 512"),
    ("/probe-grid.json?min=1,1,1&max=2,2,2&step=nan", 400, "step"),
    ("/probe-grid.json?min=2,1,1&max=1,2,2&step=1", 400, "min <= max"),
])
def test_bad_point_requests_are_400s(probes_file, path, code, says):
    with ServerThread(*_serve_args(probes_file, "--room", room.room_box())) as srv:
        status, _, body = _get(srv, path)
        if status == 503:                       # not every probe has its frame yet
            status, _, body = poll(lambda: (lambda r: r if r[0] != 503 else None)(
                _get(srv, path)), timeout=60, what="an answer")
        assert status == code and says in body["detail"], body


@pytest.mark.parametrize("extra,says", [
    (["--room", "box:0,0,0,6,3"], "six finite numbers"),
    (["--room", "box:0,0,0,3,3,3"], "not inside the room"),
])
def test_a_room_the_probes_are_not_in_is_refused_at_start(probes_file, extra, says):
    refused(run_cli("serve", "--port", "0", *_serve_args(probes_file, *extra)), says)


def test_a_room_without_positions_or_with_fisheyes_is_refused_at_start(tmp_path):
    refused(run_cli("serve", "--port", "0", "--room", "box:0,0,0,6,3,5"), "--probe-position")
    refused(run_cli("serve", "--port", "0", "--projection", "fisheye", "--probe-position",
                    "default=1,1,1", "--room", "box:0,0,0,6,3,5"), "equirect")


def test_a_server_without_positions_has_no_points():
    with ServerThread("--fps", "5") as srv:
        status, _, body = http_get(f"{srv.http}/latest.json?at=1,1,1")
        assert status == 404 and b"--probe-position" in body
