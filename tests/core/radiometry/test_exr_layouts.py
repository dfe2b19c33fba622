"""OpenEXR files in every layout (issue 41): headers and pixels read by OpenEXR's own bindings,
so a tiled, mipmapped or multi-part environment map (ILM's KernerEnvCube.exr is tiled and
mipmapped) is read by its ``envmap`` attribute by compute, environment, export and serve alike;
and the new user's OpenEXR inputs (an envmap value OpenEXR does not define, a cube read as
something else, a --downsample that splits the cube's faces, a NaN face, a frame of 3e38) each
answer in one line."""
import json
import os
from pathlib import Path

import cv2
import numpy as np
import OpenEXR
import pytest

from provider.core.radiometry.images import exr_envmap, exr_layout, read_image
from provider.core.sh9.engine import SH9Projector
from exrtools import cube_directions, latlong_directions
from servertools import ServerThread, coefficients, connect, recv_until, run_cli

DATA = Path(__file__).resolve().parents[2] / "data"
PANORAMA = DATA / "hdri" / "apartment.exr"      # a real room, no pixel below 0
ILM = DATA / "exr"                              # ILM's maps, tiled and mipmapped (README)


def sample_panorama(pano, d):
    """The panorama (shlight's equirect: the centre looks along −Z) at directions ``d``,
    bilinear: the resampling both OpenEXR layouts below are made by."""
    h, w = pano.shape[:2]
    theta = np.arccos(np.clip(d[..., 1], -1, 1))
    phi = np.arctan2(d[..., 0], -d[..., 2])
    mx = ((phi / (2 * np.pi) + 0.5) * w - 0.5).astype(np.float32)
    my = (theta / np.pi * h - 0.5).astype(np.float32)
    return cv2.remap(pano, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)


def tiled(envmap=None, mode=OpenEXR.ONE_LEVEL):
    """A tiled header (the bindings write level 0 alone: a MIPMAP_LEVELS file they write is
    unreadable, so the mipmapped files are ILM's, under tests/data/exr)."""
    tiles = OpenEXR.TileDescription()
    tiles.xSize = tiles.ySize = 32
    tiles.mode, tiles.roundingMode = mode, OpenEXR.ROUND_DOWN
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.tiledimage,
              "tiles": tiles}
    if envmap is not None:
        header["envmap"] = envmap
    return header


def scanline(envmap=None):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    if envmap is not None:
        header["envmap"] = envmap
    return header


def write(path, pixels, header):
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(pixels, np.float32)}) as f:
        f.write(str(path))
    return str(path)


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    """One real room as a tiled OpenEXR cube (6 × 64² faces, ILM's layout) and latlong
    (512 × 256), both resampled from the same panorama, and that panorama's SH9."""
    d = tmp_path_factory.mktemp("room")
    pano = read_image(PANORAMA)
    cube = sample_panorama(pano, cube_directions(64))
    ll = sample_panorama(pano, latlong_directions(512, 256))
    truth = SH9Projector(pano.shape[1], pano.shape[0]).project(pano).coefficients
    return (write(d / "cube.exr", cube, tiled(OpenEXR.ENVMAP_CUBE)),
            write(d / "latlong.exr", ll, tiled(OpenEXR.ENVMAP_LATLONG)), truth)


def compute(*argv):
    res = run_cli("compute", *argv)
    assert res.returncode == 0, res.stderr
    msg = json.loads(res.stdout)
    return np.asarray(msg["coefficients"]).reshape(9, 3), msg["projection"], res.stderr


def one_error_line(res, *words):
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "error:" in lines[0], res.stderr
    for word in words:
        assert word in lines[0], lines[0]


def test_the_bindings_read_tiled_mipmapped_and_multi_part_headers(room, tmp_path):
    cube, ll, _ = room
    c, l = exr_layout(cube), exr_layout(ll)
    assert (c.envmap, c.tiled, c.levels, c.width, c.height) == ("cube", True, "one", 64, 384)
    assert (l.envmap, l.tiled, l.levels, l.width, l.height) == ("latlong", True, "one",
                                                                 512, 256)
    assert exr_envmap(cube) == "cube" and exr_envmap(ll) == "latlong"
    k = exr_layout(ILM / "ilm" / "KernerEnvCube.exr")
    assert (k.envmap, k.tiled, k.levels, k.width, k.height) == ("cube", True, "mipmap",
                                                                 256, 1536)
    # level 0 of the mipmap is what is read: the full size
    assert read_image(ILM / "ilm" / "KernerEnvCube.exr").shape == (1536, 256, 3)
    assert read_image(ILM / "ilm" / "StageEnvLatLong.exr").shape == (500, 1000, 3)
    flat = write(tmp_path / "flat.exr", np.ones((8, 16, 3)), scanline())
    assert exr_layout(flat).envmap is None and not exr_layout(flat).tiled
    assert exr_layout(tmp_path) is None and exr_layout("/dev/null") is None
    png = tmp_path / "a.png"
    cv2.imwrite(str(png), np.zeros((4, 8, 3), np.uint8))
    assert exr_layout(png) is None
    assert read_image(cube).shape == (384, 64, 3)


def test_tiled_cube_and_latlong_of_one_room_give_the_same_sh9(room):
    """Read by default (auto), a tiled, mipmapped cube and latlong of the same room give the
    same SH9 within 0.5 % of L00, and the panorama's own within 0.5 %: the tolerance is the
    bilinear resampling's (each layout samples the panorama at its own pixel centres), not
    the engine's (OpenEXR's analytic maps agree to 1e-4, test_exr_envmap)."""
    cube, ll, truth = room
    c, pc, _ = compute(cube)
    l, pl, _ = compute(ll)
    assert (pc, pl) == ("exr-cube", "exr-latlong")
    l00 = truth[0].max()
    assert np.abs(c - l).max() < 0.005 * l00
    assert np.abs(c - truth).max() < 0.005 * l00
    assert np.abs(l - truth).max() < 0.005 * l00


#: ILM's full-size maps (tests/data/exr/ilm, as in openexr-images' MultiResolution/);
#: SHLIGHT_OPENEXR_IMAGES: a checkout of that repository instead.
ORIGINALS = (Path(os.environ["SHLIGHT_OPENEXR_IMAGES"]) / "MultiResolution"
             if os.environ.get("SHLIGHT_OPENEXR_IMAGES") else ILM / "ilm")


@pytest.mark.parametrize("name", ["Kerner", "Stage"])
def test_ilm_tiled_mipmapped_cube_and_latlong_give_the_same_sh9(name):
    """ILM's own cube and latlong of one place (KernerEnvCube.exr, KernerEnvLatLong.exr;
    Stage…: 256² faces, 1024 × 512 or 1000 × 500, tiled and mipmapped), read by default
    (auto) by their headers, give the same SH9 within 0.5 % of L00 (measured 0.011 % and
    0.036 %: two maps of one place, resampled by ILM); read as the equirect auto used to
    fall back to, the latlong's L1 turns round (over 20 %)."""
    cube, pc, err1 = compute(str(ORIGINALS / f"{name}EnvCube.exr"))
    ll, pl, err2 = compute(str(ORIGINALS / f"{name}EnvLatLong.exr"))
    assert (pc, pl, err1, err2) == ("exr-cube", "exr-latlong", "", "")
    l00 = ll[0].max()
    assert np.abs(cube - ll).max() < 0.005 * l00
    as_equirect = compute(str(ORIGINALS / f"{name}EnvLatLong.exr"), "--projection", "equirect")
    assert np.abs(as_equirect[0] - cube).max() > 0.2 * l00


@pytest.mark.parametrize("which", [0, 1])
def test_serve_reads_a_file_by_its_header_as_compute_does(room, which):
    """`serve --source ll.exr` honours the header that `compute` honours: one file, one
    lighting (the same engine on the same pixels, so to float32 rounding)."""
    path = room[which]
    want, _, _ = compute(path)
    with ServerThread("--source", path, "--fps", "5") as srv, connect(srv.url) as ws:
        msg = recv_until(ws, lambda m: m.get("type") == "sh9", what="a lighting message")
    got = coefficients(msg).reshape(9, 3)
    # float32 accumulation in a different band order (compute's one frame, the probe's
    # pipeline): well inside 1e-5 of L00
    assert np.abs(got - want).max() < 1e-5 * want[0].max()


def test_serve_reads_a_sequence_by_its_first_files_header(room, tmp_path):
    """`serve --source DIR` of OpenEXR cubes: the first file's header says cube, as
    compute reads each file."""
    folder = tmp_path / "frames"
    folder.mkdir()
    (folder / "a.exr").write_bytes(Path(room[0]).read_bytes())
    want, _, _ = compute(str(folder / "a.exr"))
    with ServerThread("--source", str(folder), "--fps", "5") as srv, connect(srv.url) as ws:
        msg = recv_until(ws, lambda m: m.get("type") == "sh9", what="a lighting message")
    # as above: float32 rounding alone
    assert np.abs(coefficients(msg).reshape(9, 3) - want).max() < 1e-5 * want[0].max()


def test_a_bracket_whose_headers_disagree_is_one_line(room, tmp_path):
    cube, ll, _ = room
    one_error_line(run_cli("compute", f"{cube}@1/4", f"{ll}@1"), "headers disagree",
                   "envmap cube", "envmap latlong")


def test_serve_refuses_a_contradicted_header_at_start(room):
    res = run_cli("serve", "--port", "0", "--source", room[0], "--projection", "exr-latlong")
    one_error_line(res, "probe default", "header says envmap cube", "exr-cube")


def test_a_multi_part_file_reads_its_rgb_part_and_says_which(tmp_path):
    """The first part with R, G and B is read (here the second, after a depth part), by
    compute and by read_image alike, and the warning names it."""
    depth = OpenEXR.Part(scanline(), {"Z": np.zeros((32, 64), np.float32)}, "depth")
    rgb = np.full((32, 64, 3), 0.5, np.float32)
    rgb[:16] = 2.0                                      # a bright upper half
    beauty = OpenEXR.Part(scanline(OpenEXR.ENVMAP_LATLONG), {"RGB": rgb}, "beauty")
    path = str(tmp_path / "multi.exr")
    with OpenEXR.File([depth, beauty]) as f:
        f.write(path)
    layout = exr_layout(path)
    assert (layout.parts, layout.part, layout.part_name, layout.envmap) == (2, 1, "beauty",
                                                                             "latlong")
    assert np.array_equal(read_image(path), rgb)
    got, projection, err = compute(path)
    assert projection == "exr-latlong"
    assert "2 parts; reading part 1 'beauty'" in err and err.count("\n") == 1
    single = write(tmp_path / "single.exr", rgb, scanline(OpenEXR.ENVMAP_LATLONG))
    # the same pixels through the same projector on the same machine: the same sums in the
    # same order, so equal up to the JSON's printed digits, on any CPU
    assert np.allclose(got, compute(single)[0], rtol=0, atol=1e-9)


def test_an_envmap_value_openexr_does_not_define_is_a_warning(tmp_path):
    path = write(tmp_path / "seven.exr", np.ones((32, 64, 3)), scanline(7))
    assert exr_layout(path).envmap_value == 7 and exr_envmap(path) is None
    _, projection, err = compute(path)
    assert projection == "equirect"
    assert "envmap = 7" in err and "equirect" in err and err.count("\n") == 1


def test_a_cube_read_as_a_latlong_is_refused_and_as_another_projection_warned(room):
    cube, ll, _ = room
    one_error_line(run_cli("compute", cube, "--projection", "exr-latlong"),
                   "header says envmap cube", "--projection exr-cube")
    one_error_line(run_cli("environment", ll, "--projection", "exr-cube", "-o", "-"),
                   "header says envmap latlong")
    res = run_cli("compute", cube, "--projection", "fisheye")
    assert res.returncode == 0, res.stderr
    assert "header says it is an OpenEXR cube map; read as --projection fisheye" in res.stderr
    # a file without envmap read as an OpenEXR map: the user's word, nothing to contradict
    _, projection, err = compute(ll, "--projection", "exr-latlong")
    assert projection == "exr-latlong" and not err


def test_a_downsample_that_splits_the_cube_faces_is_refused(room):
    """--downsample area-averages blocks of factor² pixels: on a cube of 64-pixel faces a 7
    would average two faces (pixels 90° apart) together; 4 divides the faces and is fine."""
    cube, _, truth = room
    one_error_line(run_cli("compute", cube, "--downsample", "7"),
                   "--downsample 7", "64-pixel faces", "2, 4, 8")
    fast, _, err = compute(cube, "--downsample", "4")
    assert not err
    res = run_cli("compute", cube, "--downsample", "4")
    assert res.returncode == 0, res.stderr
    # the sphere once (it came to 12.8 sr, 2 % over, before the edges' half pixels were
    # split off); 1e-4: the quadrature's own error is 3e-5 at full size
    assert json.loads(res.stdout)["coverage_sr"] == pytest.approx(4 * np.pi, rel=1e-4)
    # the fast path's 16×16-pixel faces against the exact path: the engine's own budget
    # for --downsample (docs/accuracy.md), well within 1 % of L00 on a room
    exact = compute(cube)[0]
    assert np.abs(fast - exact).max() < 0.01 * truth[0].max()


@pytest.mark.parametrize("kind, size", [("exr-cube", (64, 384)), ("exr-latlong", (256, 128))])
@pytest.mark.parametrize("factor", [2, 4, 8, 16])
def test_downsampled_openexr_maps_cover_the_sphere_once(kind, size, factor):
    """The outer half of the map's edge pixels lies beyond the map at every --downsample, as
    at full size: the coverage stays 4π (1e-4: the full-size quadrature's own 3e-5)."""
    from provider.core.geometry.projections import make_projection
    small = make_projection(kind, *size).scaled(factor)
    assert small.coverage == pytest.approx(4 * np.pi, rel=1e-4)


def test_a_cube_with_a_nan_face_says_so(tmp_path):
    """A cube whose −Y face is NaN: compute and environment say how many pixels are taken as
    black and which face (the coverage is the sphere the projection sees, not the light)."""
    faces = np.ones((6 * 16, 16, 3), np.float32)
    faces[3 * 16:4 * 16] = np.nan
    path = write(tmp_path / "nan.exr", faces, scanline(OpenEXR.ENVMAP_CUBE))
    res = run_cli("compute", path)
    assert res.returncode == 0, res.stderr
    assert json.loads(res.stdout)["nonfinite_pixels"] == 256
    want = "256 of 1,536 pixels (16.7%) are NaN or infinite (the whole -Y face of the cube)"
    assert want in res.stderr and res.stderr.count("\n") == 1
    res = run_cli("environment", path, "--size", "8", "-o", str(tmp_path / "c.ktx2"))
    assert res.returncode == 0, res.stderr
    assert want in res.stderr


def test_environment_refuses_the_frame_compute_refuses(tmp_path):
    """A frame of 3e38 (float32's range, far beyond what the shaders hold): compute, export
    and environment each refuse it in one line, rather than environment clamping it to half
    float's 65504 as if it were a bright room."""
    path = write(tmp_path / "huge.exr", np.full((32, 64, 3), 3e38), scanline())
    one_error_line(run_cli("compute", path), "the lighting overflows")
    one_error_line(run_cli("export", path, "--to", "gltf"), "the lighting overflows")
    one_error_line(run_cli("environment", path, "--size", "8", "-o", str(tmp_path / "c.ktx2")),
                   "the lighting overflows", "texel")
    assert not (tmp_path / "c.ktx2").exists()
    # a bright but representable frame is stored clamped, with a count (legal: a warning)
    bright = write(tmp_path / "bright.exr", np.full((32, 64, 3), 1e6), scanline())
    res = run_cli("environment", bright, "--size", "8", "-o", str(tmp_path / "b.ktx2"))
    assert res.returncode == 0 and "brighter than half float's 65504" in res.stderr


def test_a_mipmapped_file_without_its_levels_is_one_line(tmp_path):
    """A header that promises mipmap levels the file lacks (what OpenEXR's Python bindings
    write for MIPMAP_LEVELS): the library reads no pixels, and compute says so in its own
    words, not "list index out of range"."""
    path = write(tmp_path / "nolevels.exr", np.ones((32, 64, 3)),
                 tiled(OpenEXR.ENVMAP_LATLONG, OpenEXR.MIPMAP_LEVELS))
    res = run_cli("compute", path)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "the OpenEXR file's pixels cannot be read" in lines[0]


def test_a_truncated_tiled_file_leaves_stdout_empty(tmp_path):
    """ILM's tiled, mipmapped cube cut short: OpenEXR's bindings print why on Python's
    stdout, where it would land in the JSON a pipe reads; compute's stdout stays empty, and
    its one error line carries the library's words."""
    whole = (ILM / "ilm" / "KernerEnvCube.exr").read_bytes()
    path = tmp_path / "cut.exr"
    path.write_bytes(whole[: len(whole) * 2 // 3])
    res = run_cli("compute", str(path))
    assert res.returncode == 2 and res.stdout == "", res.stdout
    (line,) = res.stderr.strip().splitlines()
    assert "pixels cannot be read" in line and "the library: reading pixel data" in line


def test_what_others_print_while_an_exr_is_read_is_kept(capsys):
    """Only the library's own lines are taken while a file's pixels are read: anything else
    printed meanwhile reaches stdout, in order."""
    from provider.core.radiometry import images
    with images._exr_words() as said:
        print("first")
        print("Warning: Exception raised reading pixel data for part 0 - broken")
        print("second")
        assert len(said()) == 1
    assert capsys.readouterr().out == "first\nsecond\n"
