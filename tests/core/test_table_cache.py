"""Built tables kept on disk (provider.core.table_cache): a restart reads the projectors'
tables instead of building them, and a damaged, foreign or stale file is rebuilt with one
line said. Real projectors, real files in a folder of the test's own (never the user's)."""
from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import provider
from provider.cli import main as shlight
from provider.core import table_cache
from provider.core.lights.extractor import LightExtractor
from provider.core.reflections.environment import EnvironmentProjector
from provider.core.sh9 import tables
from provider.core.sh9.engine import SH9Projector

REPO = Path(__file__).resolve().parents[2]
FRAME = np.random.default_rng(3).integers(0, 256, (64, 128, 3), dtype=np.uint8)
FRAME[10:13, 20:23] = 255                # a small lamp
LIT = np.full((64, 128, 3), 20, np.uint8)
LIT[10:14, 20:24] = 255                  # a lamp in a dim room: the lights' extractor finds it


@pytest.fixture
def cache(tmp_path, monkeypatch) -> Path:
    """The cache on, in a folder of this test's own: returns its tables folder."""
    monkeypatch.setenv("SHLIGHT_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setenv("SHLIGHT_TABLE_CACHE", "1")
    return tmp_path / "cache" / "tables"


def sh9(**options):
    return SH9Projector(128, 64, "dual-fisheye", lights="auto", **options)


def cube():
    return EnvironmentProjector(128, 64, "dual-fisheye", size=8)


def no_build(*args, **kwargs):
    raise AssertionError("the tables were built, not read")


def same_lights(a, b) -> bool:
    """The same lights, bit for bit (the same tables, the same code), and the same error."""
    return (len(a.lights) == len(b.lights) and a.stats["light_error"] == b.stats["light_error"]
            and all(np.array_equal(x.direction, y.direction)
                    and np.array_equal(x.irradiance, y.irradiance)
                    for x, y in zip(a.lights, b.lights)))


def files(folder: Path, kind: str = "") -> list:
    return sorted(folder.glob(f"{kind}*.tables")) if folder.exists() else []


def test_a_second_start_reads_the_tables_and_projects_the_same(cache, monkeypatch):
    first_sh9, first_cube = sh9(), cube()
    assert [f.name.split("-")[0] for f in files(cache)] == ["cube", "lights", "sh9"]
    expected = first_sh9.project(FRAME)
    expected_cube = first_cube.project(FRAME)
    monkeypatch.setattr(tables, "_build", no_build)
    monkeypatch.setattr(EnvironmentProjector, "_build_tables", no_build)
    monkeypatch.setattr(LightExtractor, "_mid_geometry", no_build)
    again, again_cube = sh9(), cube()
    assert again.warnings == [] and again_cube.warnings == []
    # the arrays are the file's pages, mapped read-only: shared, and paged in on use
    assert not again._l00_weights.flags.writeable
    assert not again._extractor._dirs.flags.writeable       # the lights' geometry too
    got = again.project(FRAME)
    np.testing.assert_array_equal(got.coefficients, expected.coefficients)
    lit, lit_expected = again.project(LIT), first_sh9.project(LIT)
    assert lit_expected.lights                  # the lamp, found from the read tables too
    assert same_lights(lit, lit_expected)
    for a, b in zip(again_cube.project(FRAME).mips, expected_cube.mips):
        np.testing.assert_array_equal(a, b)


def test_another_geometry_or_version_is_not_read(cache, monkeypatch):
    sh9()
    sh9(fov_deg=190.0)                           # another lens: another file a kind
    before = files(cache)
    assert len(files(cache, "sh9")) == len(files(cache, "lights")) == 2
    monkeypatch.setattr(provider, "__version__", "0.0.0-other")
    table_cache.code_hash.cache_clear()          # another version of the package
    try:
        sh9()
    finally:
        table_cache.code_hash.cache_clear()
    after = files(cache)
    # built anew, and the old version's files removed: an upgrade does not fill the card
    assert len(after) == 2 and not set(after) & set(before)


def damage_payload(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[-100] ^= 0xFF
    path.write_bytes(bytes(data))


def rewrite_header(path: Path, **fields) -> None:
    data = path.read_bytes()
    start = len(table_cache.MAGIC) + 8
    n = int.from_bytes(data[len(table_cache.MAGIC):start], "little")
    header = json.loads(data[start:start + n])
    header.update(fields)
    new = json.dumps(header).encode()
    assert len(new) == n, "same length, so the payload stays where the header says"
    path.write_bytes(data[:start] + new + data[start + n:])


@pytest.mark.parametrize("kind", ["sh9", "lights"])
@pytest.mark.parametrize("damage", ["a flipped byte", "truncated", "another format",
                                    "another key", "not a table file"])
def test_a_damaged_or_foreign_file_is_rebuilt_with_one_warning(cache, damage, kind):
    first_sh9 = sh9()
    expected, first = first_sh9.project(FRAME).coefficients, first_sh9.project(LIT)
    (path,) = files(cache, kind)
    if damage == "a flipped byte":
        damage_payload(path)
    elif damage == "truncated":
        path.write_bytes(path.read_bytes()[:len(path.read_bytes()) // 2])
    elif damage == "another format":
        rewrite_header(path, format=9)
    elif damage == "another key":
        key = json.loads(path.read_bytes()[len(table_cache.MAGIC) + 8:].split(b"}")[0] + b"}")
        rewrite_header(path, key="0" * len(key["key"]))
    else:
        path.write_bytes(b"#!/bin/sh\necho not tables\n")
    rebuilt = sh9()
    notes = [w for w in rebuilt.warnings if "table cache" in w]
    assert len(notes) == 1 and str(path) in notes[0], rebuilt.warnings
    np.testing.assert_array_equal(rebuilt.project(FRAME).coefficients, expected)
    assert first.lights and same_lights(rebuilt.project(LIT), first)
    assert sh9().warnings == []                  # the file was replaced: said once


def test_a_file_that_unpickles_code_is_refused(cache):
    """A table file is data: a pickle that names anything but numpy and this package's
    classes is rebuilt, not run."""
    sh9()
    (path,) = files(cache, "sh9")
    header = json.loads(path.read_bytes()[len(table_cache.MAGIC) + 8:].split(b"}")[0] + b"}")

    class Evil:
        def __reduce__(self):
            return (print, ("ran",))
    table_cache._save(path, "sh9", header["key"], Evil())
    rebuilt = sh9()
    assert len([w for w in rebuilt.warnings if "builtins.print" in w]) == 1

    class Command:      # this package's own functions are not run either
        def __reduce__(self):
            return (shlight, (["compute", "--help"],))
    table_cache._save(path, "sh9", header["key"], Command())
    rebuilt = sh9()
    assert len([w for w in rebuilt.warnings if "provider.cli.main" in w]) == 1


def test_the_cache_can_be_turned_off(cache, monkeypatch, tmp_path, capsys):
    monkeypatch.setenv("SHLIGHT_TABLE_CACHE", "0")
    sh9(), cube()
    assert files(cache) == []
    monkeypatch.setenv("SHLIGHT_TABLE_CACHE", "1")
    image = tmp_path / "fish.png"
    import cv2
    cv2.imwrite(str(image), FRAME[:, :64])
    assert shlight(["compute", str(image), "--projection", "fisheye",
                    "--no-table-cache"]) == 0
    assert files(cache) == []
    monkeypatch.setenv("SHLIGHT_TABLE_CACHE", "1")     # the flag switched this process off
    assert shlight(["compute", str(image), "--projection", "fisheye"]) == 0
    assert len(files(cache)) == 1
    assert "warning" not in capsys.readouterr().err


def test_an_unwritable_cache_is_said_once_and_the_projector_works(tmp_path, monkeypatch):
    blocker = tmp_path / "a file, not a folder"
    blocker.write_text("")
    monkeypatch.setenv("SHLIGHT_CACHE_DIR", str(blocker))
    monkeypatch.setenv("SHLIGHT_TABLE_CACHE", "1")
    projector = sh9()
    notes = [w for w in projector.warnings if "table cache" in w]
    assert len(notes) == 1 and "cannot be written" in notes[0]
    assert projector.project(FRAME).coefficients.shape == (9, 3)


WRITER = textwrap.dedent("""
    import sys
    from provider.core.reflections.environment import EnvironmentProjector
    from provider.core.sh9.engine import SH9Projector
    p = SH9Projector(128, 64, "dual-fisheye", lights="auto")
    c = EnvironmentProjector(128, 64, "dual-fisheye", size=8)
    assert p.warnings == [] and c.warnings == [], (p.warnings, c.warnings)
""")


def test_processes_writing_the_same_tables_at_once_each_leave_a_whole_file(cache,
                                                                           monkeypatch):
    """Writes go to a temporary file and are renamed into place: four processes starting
    together each build and write, and every reader sees a whole file (no warning)."""
    env = {**__import__("os").environ, "PYTHONPATH": str(REPO)}
    procs = [subprocess.Popen([sys.executable, "-c", WRITER], env=env, stderr=subprocess.PIPE)
             for _ in range(4)]
    for p in procs:
        _, err = p.communicate(timeout=600)
        assert p.returncode == 0, err.decode()[-2000:]
    assert len(files(cache)) == 3                     # SH9's, the lights', the cube's
    assert not list(cache.glob(".tmp-*"))             # no temporary file left behind
    monkeypatch.setattr(tables, "_build", no_build)
    monkeypatch.setattr(EnvironmentProjector, "_build_tables", no_build)
    monkeypatch.setattr(LightExtractor, "_mid_geometry", no_build)
    assert sh9().warnings == [] and cube().warnings == []
