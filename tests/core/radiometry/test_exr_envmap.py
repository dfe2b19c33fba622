"""OpenEXR's own environment maps (issue 32): a cube and a latlong written by OpenEXR's Python
bindings with the ``envmap`` header attribute are read in OpenEXR's conventions (ImfEnvmap.cpp,
written out again from its source in tests/exrtools.py, independently of provider/), by default
(``--projection auto``), and give the SH9 of the light they hold."""
import json

import numpy as np
import OpenEXR
import pytest

from provider.core.radiometry.images import exr_envmap
from provider.core.sh9.engine import SH9Projector
from reference import render_equirect
from exrtools import cube_directions, latlong_directions
from servertools import run_cli

AXIS = np.array([0.62, 0.35, 0.70]) / np.linalg.norm([0.62, 0.35, 0.70])


def light(d):
    """A lamp toward AXIS (in OpenEXR's x, y, z = shlight's), a sky above, a dim floor."""
    lamp = 20 * np.maximum(d @ AXIS, 0) ** 32
    sky = 0.6 * np.maximum(d[..., 1], 0) + 0.05
    return (lamp + sky)[..., None] * np.array([1.0, 0.85, 0.7])


def write_exr(path, pixels, envmap):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
              "envmap": envmap}
    with OpenEXR.File(header, {"RGB": pixels}) as f:
        f.write(str(path))


@pytest.fixture(scope="module")
def maps(tmp_path_factory):
    d = tmp_path_factory.mktemp("envmap")
    w, h, n = 256, 128, 64
    # Point samples at OpenEXR's pixel centres (the convention the file format defines);
    # supersampling would blur the lamp inconsistently between the two layouts.
    ll = light(latlong_directions(w, h)).astype(np.float32)
    cube = light(cube_directions(n)).astype(np.float32)
    write_exr(d / "latlong.exr", ll, OpenEXR.ENVMAP_LATLONG)
    write_exr(d / "cube.exr", cube, OpenEXR.ENVMAP_CUBE)
    write_exr(d / "plain.exr", ll, OpenEXR.ENVMAP_LATLONG)
    plain = d / "noenv.exr"
    with OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                      {"RGB": render_equirect(light, 256, 128, 2).astype(np.float32)}) as f:
        f.write(str(plain))
    truth = SH9Projector(1024, 512).project(render_equirect(light, 1024, 512, 3)).coefficients
    return d, truth


def _compute(path, *argv):
    res = run_cli("compute", str(path), *argv)
    assert res.returncode == 0, res.stderr
    return np.asarray(json.loads(res.stdout)["coefficients"]).reshape(9, 3)


def test_the_header_says_which_map(maps):
    d, _ = maps
    assert exr_envmap(d / "latlong.exr") == "latlong"
    assert exr_envmap(d / "cube.exr") == "cube"
    assert exr_envmap(d / "noenv.exr") is None


def test_cube_and_latlong_give_the_same_sh9(maps):
    """Read by default (auto), OpenEXR's cube and its latlong of the same light give the same
    SH9 within 0.5 % of L00 on every coefficient, and the light's own SH9 within 0.5 %."""
    d, truth = maps
    cube, ll = _compute(d / "cube.exr"), _compute(d / "latlong.exr")
    l00 = truth[0].max()
    print("cube-latlong", np.abs(cube - ll).max() / l00, "cube-truth",
          np.abs(cube - truth).max() / l00, "latlong-truth", np.abs(ll - truth).max() / l00)
    assert np.abs(cube - ll).max() < 0.005 * l00
    assert np.abs(cube - truth).max() < 0.005 * l00
    assert np.abs(ll - truth).max() < 0.005 * l00
    # read as shlight's own equirect, OpenEXR's latlong is turned round: the lamp moves
    as_equirect = _compute(d / "latlong.exr", "--projection", "equirect")
    assert np.abs(as_equirect - truth).max() > 0.1 * l00


def test_a_file_without_envmap_is_still_an_equirect(maps):
    d, truth = maps
    got = _compute(d / "noenv.exr")
    assert np.abs(got - truth).max() < 0.01 * truth[0].max()


def test_a_cube_of_the_wrong_shape_is_one_line(tmp_path):
    path = tmp_path / "bad.exr"
    write_exr(path, np.ones((40, 8, 3), np.float32), OpenEXR.ENVMAP_CUBE)
    res = run_cli("compute", str(path))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "six square faces stacked vertically" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_environment_reads_the_cube(maps, tmp_path):
    """`shlight environment cube.exr` (auto) makes a cube file from OpenEXR's cube map."""
    d, _ = maps
    res = run_cli("environment", str(d / "cube.exr"), "-o", str(tmp_path / "c.ktx2"),
                  "--size", "8")
    assert res.returncode == 0, res.stderr
    assert (tmp_path / "c.ktx2").stat().st_size > 0
