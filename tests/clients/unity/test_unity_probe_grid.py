"""Unity's light probes filled from the server's grid (unity_package/Runtime/SH9ProbeGrid.cs;
docs/probes.md "In the engines"), checked under Mono against tests/unity_stubs/UnityEngineStandIn.cs
(NOT Unity) and a REAL ``shlight serve`` with the eight positioned probes of the analytic room
(provider/bench/room.py) and ``--room``:

* the probes' positions are the grid's in Unity's frame (z negated) and each probe's values are the
  server's SH9 in Unity's convention: ShadeSH9 on them at Unity's normal S·n equals E(n)/π of the
  server's coefficients at n (the ambient probe's conversion, tests/clients/unity/test_unity.py's ambient checks);
* a sphere at a grid point, lit by Unity's interpolated probe (SphericalHarmonicsL2.Evaluate at its
  normals), shows ``shlight interpolate``'s irradiance there;
* refreshes keep the points (no re-tetrahedralisation); a finer step moves them (one);
  a wrong token is reported with the server's 401.
"""
from __future__ import annotations

import json
import subprocess

import numpy as np
import pytest

from provider.bench import room
from provider.core.geometry import sh
from roomtools import TOKEN, interpolate, serve_args
from servertools import ServerThread, http_get
from unitytools import CORE, CSHARP, HARNESS, RUNTIME, STANDIN, _compile, _mono_tools

S = np.array([1.0, 1.0, -1.0])          # the wire frame -> Unity's: (x, y, z) -> (x, y, -z)


def _shade_sh9(probe27, normals):
    """UnityCG.cginc's ShadeSH9 on SphericalHarmonicsL2 values: basis 1, y, z, x, xy, yz, 3z²-1, xz,
    x²-y² (Sh9Math.AmbientProbeFromMatrices)."""
    x, y, z = normals[:, 0], normals[:, 1], normals[:, 2]
    basis = np.stack([np.ones_like(x), y, z, x, x * y, y * z, 3 * z * z - 1, x * z, x * x - y * y], 1)
    return basis @ np.reshape(probe27, (3, 9)).T


@pytest.fixture(scope="module")
def grid_exe(tmp_path_factory):
    # Unity 6's LightProbes API is behind UNITY_2023_2_OR_NEWER, as Unity defines it
    return _compile(tmp_path_factory.mktemp("probe_grid") / "ProbeGridTest.exe",
                    [*CORE, *RUNTIME, STANDIN, HARNESS, CSHARP / "ProbeGridTest.cs"],
                    defines=("UNITY_2023_2_OR_NEWER",))


def test_unity_light_probes_hold_the_servers_grid(room_probes, grid_exe):
    """SH9ProbeGrid: the scene's light probes hold the server's grid in Unity's frame and
    convention; a sphere at a grid point evaluates to the command's light there; refreshes keep
    the tetrahedra, a new step rebuilds them; a scene without light probes or a wrong token is
    reported, not thrown."""
    _, mono = _mono_tools()
    # the box in the wire frame: x 1..3, y 0.5..1.5, z 1..3 -> Unity's z -3..-1
    lo, hi, step = np.array([1, 0.5, 1.0]), np.array([3, 1.5, 3.0]), 1.0
    at = np.array([2.0, 1.5, 2.0])                        # a grid point, wire frame
    normals = np.vstack([np.eye(3), -np.eye(3), sh.fibonacci_sphere(20)])
    unity_normals = normals * S
    with ServerThread(*serve_args(room_probes)) as srv:
        # Unity's box: min and max per axis in Unity's frame
        umin, umax = np.minimum(lo * S, hi * S), np.maximum(lo * S, hi * S)
        args = [srv.url, TOKEN, *map(str, umin), *map(str, umax), str(step), *map(str, at * S),
                ";".join(",".join(map(str, n)) for n in unity_normals)]
        r = subprocess.run([mono, str(grid_exe), *args], capture_output=True, text=True, timeout=400)
        assert r.returncode == 0, r.stdout + r.stderr
        out = json.loads(r.stdout.strip().splitlines()[-1])
        status, _, body = http_get(f"{srv.http}/probe-grid.json?min=1,0.5,1&max=3,1.5,3&step=1"
                                   f"&token={TOKEN}")
        assert status == 200
        server = json.loads(body)
    # a scene without baked light probes: said how to fix, nothing filled
    assert "bake a Light Probe Group" in out["no_probes_error"] and out["fills_without_probes"] == 0
    assert out["first"], out["error"]
    positions = np.reshape(server["positions"], (-1, 3))
    assert len(positions) == 18
    # the probes sit at the grid's points in Unity's frame
    assert np.allclose(np.reshape(out["positions"], (-1, 3)), positions * S, atol=1e-6)
    # each probe holds the server's light in Unity's convention: ShadeSH9(S n) = E(n) / π
    coefficients = np.reshape(server["coefficients"], (-1, 9, 3))
    probes = np.reshape(out["probes"], (-1, 27))
    for c, p in zip(coefficients, probes):
        expected = sh.irradiance(c, normals) / np.pi
        # float32 in SphericalHarmonicsL2: about 1e-7 of the largest term
        assert np.allclose(_shade_sh9(p, unity_normals), expected, rtol=1e-5,
                           atol=1e-5 * np.abs(expected).max())
    # a sphere at the point, lit by Unity's probe there: shlight interpolate's irradiance / π
    # the server's grid points re-project 32-row panoramas (provider/live/probe/points.py GRID_ROWS)
    cli = interpolate(room_probes, at, "--rows", "32")
    E = sh.irradiance(np.reshape(cli["coefficients"], (9, 3)), normals) / np.pi
    shown = np.reshape(out["evaluated"], (-1, 3))
    # the server's grid and the command compute the point alike; float32 in Unity: 1e-5
    assert np.allclose(shown, E, rtol=1e-5, atol=1e-5 * np.abs(E).max())
    # and that is the room's light there (the parallax method's error, docs/probes.md)
    assert sh.irradiance_error(np.reshape(cli["coefficients"], (9, 3)), room.exact_sh9(at)) < 0.05
    # refreshed without moving: the tetrahedra built once; a finer step: built again, 5 × 3 × 5 points
    assert out["refreshed"] and out["tetrahedralizations_after_refresh"] == 1
    assert out["moved"] and out["count_after_move"] == 75
    assert out["tetrahedralizations_after_move"] == 2 == out["stand_in_tetrahedralize_calls"]
    assert "401" in out["wrong_token_error"]


@pytest.fixture(scope="module")
def point_exe(tmp_path_factory):
    return _compile(tmp_path_factory.mktemp("point_light") / "PointLightTest.exe",
                    [*CORE, *RUNTIME, STANDIN, HARNESS, CSHARP / "PointLightTest.cs"])


def test_a_renderer_gets_the_light_where_it_stands(room_probes, point_exe):
    """SH9PointLight: a sphere not on light probes gets, as its own probe, the light at its
    position (shlight interpolate's there), then where it moved to; disabled, it is given back."""
    _, mono = _mono_tools()
    at, moved = np.array([3.0, 1.2, 1.2]), np.array([4.0, 1.0, 2.5])       # wire frame
    normals = np.vstack([np.eye(3), -np.eye(3), sh.fibonacci_sphere(20)])
    with ServerThread(*serve_args(room_probes)) as srv:
        args = [srv.url, TOKEN, *map(str, at * S), *map(str, moved * S),
                ";".join(",".join(map(str, n)) for n in normals * S)]
        r = subprocess.run([mono, str(point_exe), *args], capture_output=True, text=True,
                           timeout=300)
        assert r.returncode == 0, r.stdout + r.stderr
        out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["first"], out["error"]
    assert out["usage"] == "CustomProvided"
    # Unity's frame: the renderer's probe at S n shows E(n)/π of the light at the point (float32)
    for place, shown in ((at, out["evaluated"]), (moved, out["evaluated_moved"])):
        cli = np.reshape(interpolate(room_probes, place)["coefficients"], (9, 3))
        E = sh.irradiance(cli, normals) / np.pi
        assert np.allclose(np.reshape(shown, (-1, 3)), E, rtol=1e-5, atol=1e-5 * np.abs(E).max())
    assert out["followed"] and out["moved_position"] == moved.tolist()
    assert out["usage_after"] == "BlendProbes" and out["block_after"] is None
