"""The reflection cube's container (docs/contract.md §12, "Transport"): KTX 2.0, RGBA16F,
a cube with all mips, written by provider.live.reflections.ktx2 and read back by readers we did not
write: the npm package ktx-parse and three.js's KTX2Loader, in node (tests/node). Every
half float of every face of every mip is compared with the arrays of compute_environment;
``shlight environment IMAGE -o cube.ktx2`` writes the same file.
"""
from __future__ import annotations

import base64
import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from provider.core.reflections.environment import compute_environment
from provider.core.errors import InputError
from provider.live.reflections.cube import encode_environment
from provider.live.reflections.ktx2 import encode_cube

from servertools import ROOT, run_cli

NODE = shutil.which("node")
NODE_DIR = ROOT / "tests" / "node"
READER = NODE_DIR / "ktx2_read.mjs"
HDRI = ROOT / "tests" / "data" / "hdri"

needs_node = pytest.mark.skipif(
    NODE is None or not (NODE_DIR / "node_modules" / "ktx-parse").is_dir()
    or not (NODE_DIR / "node_modules" / "three").is_dir(),
    reason="node with ktx-parse and three: apt-get install nodejs; npm ci --prefix tests/node")


def read_in_node(path: Path) -> dict:
    """What ktx-parse and three.js's KTX2Loader read from the file (tests/node/ktx2_read.mjs)."""
    out = subprocess.run([NODE, str(READER), str(path)], cwd=NODE_DIR, capture_output=True,
                         text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout)


def halves(b64: str) -> np.ndarray:
    return np.frombuffer(base64.b64decode(b64), "<u2")


def expected_halves(mip: np.ndarray) -> np.ndarray:
    """A mip (6, n, n, 3) as the file must hold it: faces, rows, texels R G B A=1, as the
    bit patterns of IEEE half floats."""
    rgba = np.ones(mip.shape[:3] + (4,), np.float16)
    rgba[..., :3] = mip
    return rgba.view("<u2").reshape(-1)


@pytest.fixture(scope="module")
def bridge_cube():
    return compute_environment(str(HDRI / "bridge.exr"), size=32)


@needs_node
def test_every_half_float_reads_back_in_ktx_parse_and_three(tmp_path, bridge_cube):
    env = bridge_cube
    cube = encode_environment(env, probe="hall", seq=7, sh9_seq=42, time_s=1700000000.5,
                              exposure=2.0, exposure_s=0.01, gain=1.5)
    path = tmp_path / "cube.ktx2"
    path.write_bytes(cube.ktx2)
    got = read_in_node(path)
    k = got["ktxParse"]
    assert (k["vkFormat"], k["typeSize"]) == (97, 2)         # VK_FORMAT_R16G16B16A16_SFLOAT
    assert (k["pixelWidth"], k["pixelHeight"], k["pixelDepth"]) == (32, 32, 0)
    assert (k["layerCount"], k["faceCount"], k["supercompressionScheme"]) == (0, 6, 0)
    assert k["levelCount"] == len(env.mips) == len(k["levels"])
    d = k["dfd"]
    assert (d["colorModel"], d["colorPrimaries"], d["transferFunction"]) == (1, 1, 1)
    assert d["bytesPlane"][0] == 8
    assert [s["channelType"] & 15 for s in d["samples"]] == [0, 1, 2, 15]     # R G B A
    assert all(s["channelType"] & 0xC0 == 0xC0 and s["bitLength"] == 15 for s in d["samples"])
    kv = k["keyValue"]
    assert json.loads(kv["shlight.roughness"]) == pytest.approx(env.roughness, abs=1e-6)
    assert kv["shlight.frame"] == "rh-y-up"
    assert kv["shlight.sh9_seq"] == "42" and kv["shlight.seq"] == "7"
    assert kv["shlight.probe"] == "hall" and kv["shlight.units"]
    assert json.loads(kv["shlight.exposure"]) == {"exposure": 2.0, "exposure_s": 0.01,
                                                  "gain": 1.5}
    assert kv["KTXwriter"].startswith("shlight")
    three = got["three"]
    assert three["type"] == 1016 and three["format"] == 1023     # HalfFloatType, RGBAFormat
    for level, (mip, parsed, loaded) in enumerate(zip(env.mips, k["levels"], three["mipmaps"])):
        n = 32 >> level
        assert mip.shape == (6, n, n, 3)
        want = expected_halves(mip)
        assert (loaded["width"], loaded["height"]) == (n, n)
        for reader, data in (("ktx-parse", parsed["bytes"]), ("three", loaded["data"])):
            np.testing.assert_array_equal(halves(data), want,
                                          err_msg=f"{reader}, mip {level}")
    # Faces and rows in the contract's order: the brightest texel of mip 0 read back where
    # the arrays have it (face, row, column), the sun of the panorama.
    mip0 = halves(k["levels"][0]["bytes"]).view(np.float16).reshape(6, 32, 32, 4)
    assert np.unravel_index(np.argmax(mip0[..., :3].astype(float).sum(-1)), (6, 32, 32)) == \
        np.unravel_index(np.argmax(env.mips[0].astype(np.float16).astype(float).sum(-1)),
                         (6, 32, 32))
    assert np.all(mip0[..., 3] == 1)


def test_layout_of_the_file_follows_the_specification():
    """Offsets the specification fixes, checked on the bytes (the readers above are
    lenient about some of them): identifier, level index, 8-byte aligned levels stored
    smallest first, key/value entries sorted and 4-byte padded."""
    rng = np.random.default_rng(3)
    mips = [rng.random((6, n, n, 3), np.float32) * 10 for n in (16, 8, 4, 2)]
    data = encode_cube(mips, {"b.key": "2", "a.key": "1"})
    assert data[:12] == b"\xabKTX 20\xbb\r\n\x1a\n"
    head = np.frombuffer(data[12:48], "<u4")
    assert list(head) == [97, 2, 16, 16, 0, 0, 6, 4, 0]
    dfd_off, dfd_len, kvd_off, kvd_len = np.frombuffer(data[48:64], "<u4")
    assert np.frombuffer(data[64:80], "<u8").tolist() == [0, 0]      # no supercompression data
    index = np.frombuffer(data[80:80 + 4 * 24], "<u8").reshape(4, 3)
    assert dfd_off == 80 + 4 * 24 and kvd_off == dfd_off + dfd_len and kvd_off % 4 == 0
    offsets = index[:, 0]
    assert all(o % 8 == 0 for o in offsets)
    assert list(offsets) == sorted(offsets, reverse=True)            # mip 0 last in the file
    assert list(index[:, 1]) == [6 * n * n * 8 for n in (16, 8, 4, 2)]
    assert offsets[0] + index[0, 1] == len(data)
    keys, pos = [], kvd_off
    while pos < kvd_off + kvd_len:
        length = int(np.frombuffer(data[pos:pos + 4], "<u4")[0])
        entry = data[pos + 4:pos + 4 + length]
        keys.append(entry.split(b"\0", 1)[0])
        pos += 4 + length + (-length % 4)
    assert keys == sorted(keys) and b"a.key" in keys and b"KTXwriter" in keys
    level2 = np.frombuffer(data[offsets[2]:offsets[2] + index[2, 1]], "<f2").reshape(6, 4, 4, 4)
    np.testing.assert_array_equal(level2[..., :3], mips[2].astype(np.float16))


def test_out_of_range_values_are_clamped_and_bad_cubes_refused():
    mip = np.zeros((6, 8, 8, 3), np.float32)
    mip[2, 0, 0] = (1e6, -1e6, 5.0)
    data = encode_cube([mip])
    texels = np.frombuffer(data[-6 * 64 * 8:], "<f2").reshape(6, 8, 8, 4)
    assert texels[2, 0, 0].tolist() == [65504.0, -65504.0, 5.0, 1.0]    # finite, not inf
    mip[0, 0, 0, 0] = np.nan
    with pytest.raises(InputError, match="NaN"):
        encode_cube([mip])
    with pytest.raises(InputError, match="mip 1"):
        encode_cube([np.zeros((6, 8, 8, 3)), np.zeros((6, 8, 8, 3))])
    with pytest.raises(InputError, match="at least one"):
        encode_cube([])


@needs_node
def test_cli_writes_the_cube_of_compute_environment(tmp_path):
    image = HDRI / "bridge.exr"
    out = tmp_path / "cube.ktx2"
    done = run_cli("environment", str(image), "-o", str(out), "--size", "16")
    assert done.returncode == 0, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "16×16×6" in lines[0] and "mips" in lines[0]
    env = compute_environment(str(image), size=16)
    got = read_in_node(out)["ktxParse"]
    assert got["pixelWidth"] == 16 and got["levelCount"] == len(env.mips)
    for level, mip in enumerate(env.mips):
        np.testing.assert_array_equal(halves(got["levels"][level]["bytes"]),
                                      expected_halves(mip), err_msg=f"mip {level}")


@pytest.mark.parametrize("args, says", [
    (["--size", "33"], "power of two from 8 to 256"),
    (["--size", "512"], "power of two from 8 to 256"),
    (["--size", "4"], "power of two from 8 to 256"),
])
def test_cli_bad_sizes_say_one_line(tmp_path, args, says):
    out = tmp_path / "cube.ktx2"
    done = run_cli("environment", str(HDRI / "bridge.exr"), "-o", str(out), *args)
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and says in done.stderr
    assert "Traceback" not in done.stderr and not out.exists()


def test_cli_missing_image_and_unwritable_output_say_one_line(tmp_path):
    done = run_cli("environment", str(tmp_path / "nope.exr"), "-o", str(tmp_path / "c.ktx2"))
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "nope.exr" in done.stderr
    done = run_cli("environment", str(HDRI / "bridge.exr"), "-o",
                   str(tmp_path / "no-dir" / "c.ktx2"))
    assert done.returncode == 2 and done.stderr.count("\n") == 1
    assert "cannot write" in done.stderr


def test_bench_bytes_per_update_are_those_of_a_real_cube(bridge_cube):
    """provider.bench.environment_transport (the environment bench's bytes): the KTX2 and
    WebSocket bytes of one update as the server sends them, and bytes/s at 1,000 clients."""
    from provider.bench.environment_transport import transport_bytes
    from provider.live.server.session import binary_frame, text_frame
    real = encode_environment(bridge_cube, probe="default", seq=123456, sh9_seq=1234567,
                              time_s=1.7e9, compute_ms=12.345)
    row, = transport_bytes((32,), subscribers=1000, hz=1.0)
    assert row["mips"] == len(bridge_cube.mips)
    # the same pixels; the key/value data differ only by the frame's statistics (a few bytes)
    assert abs(row["ktx2"] - len(real.ktx2)) <= 64
    assert abs(row["websocket"] - len(text_frame(real.text) + binary_frame(real.ktx2))) <= 96
    assert row["bytes_per_s"] == row["websocket"] * 1000
