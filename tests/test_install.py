"""A regular install works: the wheel built from this checkout, installed into a fresh
virtual environment, runs every command from a folder that is not the checkout.

The shaders (shaders/, linked into the package as provider/shaders) and the real panoramas
(provider/data/hdri, linked from tests/data/hdri) must be package data, or
``validate-shaders`` and ``bench`` fail after ``pip install .``. The wheel is built without
network access (``--no-build-isolation``, setuptools from the test extras) and installed
without its dependencies, which the fresh environment takes from this one's site-packages
(a path entry, so that the editable install of this checkout stays invisible to it).
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import threading
import urllib.request
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PACKAGE_DATA = ("provider/shaders/sh9_irradiance.glsl", "provider/shaders/sh9_irradiance.hlsl",
                "provider/shaders/lit_diffuse.vert", "provider/shaders/lit_diffuse.frag",
                "provider/shaders/contract_vectors.json", "provider/data/hdri/bridge.exr",
                "provider/data/hdri/README.md", "provider/live/server/static/index.html",
                "provider/live/wire/sh9_message.schema.json",
                "provider/shaders/ibl.glsl", "provider/shaders/ibl.hlsl")


def _run(argv, cwd, timeout=300, env=None):
    return subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=timeout,
                          env=env)


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """(venv bin folder, the installed package folder, a working folder, the wheel)."""
    tmp = tmp_path_factory.mktemp("install")
    src = tmp / "src"
    # A copy, so that building leaves no build/ or egg-info in the checkout; links stay links.
    shutil.copytree(ROOT, src, symlinks=True, ignore=shutil.ignore_patterns(
        ".venv", ".git", "build", "*.egg-info", "out", "bench-results", "__pycache__",
        ".pytest_cache", ".hypothesis", "node_modules", "*.so"))
    dist = tmp / "dist"
    build = _run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation",
                  "--no-index", "-w", str(dist), str(src)], cwd=tmp)
    assert build.returncode == 0, build.stdout + build.stderr
    assert "Warning" not in build.stderr, build.stderr        # no setuptools deprecations
    wheel = next(dist.glob("shlight-*.whl"))
    venv = tmp / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    bindir = venv / "bin"
    py = bindir / "python"
    site = Path(_run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                     cwd=tmp).stdout.strip())
    (site / "shlight_test_deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    inst = _run([sys.executable, "-m", "pip", "--python", str(py), "install", "--no-deps",
                 "--no-index", str(wheel)], cwd=tmp)
    assert inst.returncode == 0, inst.stdout + inst.stderr
    work = tmp / "work"
    work.mkdir()
    where = _run([str(py), "-c", "import provider; print(provider.__file__)"], cwd=work)
    package = Path(where.stdout.strip()).parent
    assert package.parent == site, where          # the wheel's copy, not this checkout
    return bindir, package, work, wheel


def test_the_wheel_holds_the_shaders_and_the_panoramas(installed):
    names = set(zipfile.ZipFile(installed[3]).namelist())
    missing = [n for n in PACKAGE_DATA if n not in names]
    assert not missing, missing
    assert sum(n.startswith("provider/data/hdri/") and n.endswith(".exr") for n in names) == 9
    assert any(n.endswith("licenses/LICENSE") for n in names)
    # The C kernels (setup.py) are compiled into it, with their type stubs.
    for kernel in ("provider/core/radiometry/_blocks", "provider/core/sh9/_fold",
                   "provider/core/lights/_lights"):
        assert any(n.startswith(kernel) and n.endswith((".so", ".pyd")) for n in names), kernel
        assert kernel + ".pyi" in names


def test_compute_from_the_wheel(installed):
    bindir, package, work, _ = installed
    res = _run([str(bindir / "shlight"), "compute", str(package / "data/hdri/bridge.exr")], work)
    assert res.returncode == 0, res.stderr
    msg = json.loads(res.stdout)
    mine = json.loads(_run([sys.executable, "-m", "provider.cli", "compute",
                            str(ROOT / "tests/data/hdri/bridge.exr")], ROOT).stdout)
    assert msg["coefficients"] == mine["coefficients"]


def test_validate_shaders_from_the_wheel(installed):
    from provider.verify.render import NoOpenGL, create_context
    try:
        create_context().release()
    except NoOpenGL as exc:
        pytest.skip(f"no OpenGL here: {exc}")
    bindir, _, work, _ = installed
    res = _run([str(bindir / "shlight"), "validate-shaders", "--no-pictures", "--no-hlsl",
                "--normals", "1024", "--out", str(work / "validate")], work)
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    report = json.loads((work / "validate" / "report.json").read_text())
    assert report and "lab" in json.dumps(report)          # the shipped panoramas were used


def test_bench_from_the_wheel(installed):
    bindir, _, work, _ = installed
    res = _run([str(bindir / "shlight"), "bench", "--quick", "--sections", "scenes", "--out",
                str(work / "bench")], work)
    assert res.returncode == 0, res.stderr[-2000:]
    rows = [l for l in (work / "bench" / "scenes.md").read_text().splitlines()
            if l.startswith("| ") and not l.startswith("| scene") and "---" not in l]
    assert len(rows) == 9, rows
    assert "[1/1] scenes" in res.stderr                      # progress, with its cost


def test_serve_and_its_dashboard_from_the_wheel(installed):
    bindir, _, work, _ = installed
    proc = subprocess.Popen([str(bindir / "shlight"), "serve", "--port", "0"], cwd=work,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    found, lines = threading.Event(), []

    def read():
        for line in proc.stdout:
            lines.append(line)
            if re.search(r"serving ws://[^ ]*:(\d+)/", line):
                found.set()
        found.set()
    threading.Thread(target=read, daemon=True).start()
    try:
        assert found.wait(60) and proc.poll() is None, "".join(lines)
        port = re.search(r"serving ws://[^ ]*:(\d+)/", "".join(lines)).group(1)
        for path, needle in (("/", b"shlight"), ("/static/dashboard.js", b"WebSocket")):
            with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=10) as r:
                assert r.status == 200 and needle in r.read()
    finally:
        proc.terminate()
        proc.wait(15)
    assert "Traceback" not in "".join(lines)


def test_help_lists_every_command_without_loading_numpy():
    """`shlight --help` is instant: the package and the command line load numpy (and
    OpenCV, websockets, moderngl) only for a command that needs them."""
    code = ("import sys, provider.cli\n"
            "try:\n    provider.cli.main(['--help'])\nexcept SystemExit:\n    pass\n"
            "heavy = [m for m in ('numpy', 'cv2', 'websockets', 'moderngl') if m in sys.modules]\n"
            "print('HEAVY', heavy)\n")
    res = _run([sys.executable, "-c", code], ROOT, env={**os.environ})
    assert res.returncode == 0, res.stderr
    for command in ("compute", "serve", "validate-shaders", "bench"):
        assert command in res.stdout
    assert "HEAVY []" in res.stdout, res.stdout
