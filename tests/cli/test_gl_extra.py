"""The GL harness is an extra (``shlight[gl]``: moderngl, glfw): an edge install (a 64-bit Pi
OS, where moderngl publishes no aarch64 wheel after 5.8.2) is numpy, OpenCV and websockets,
and whatever needs OpenGL says in one line what to install. The GL modules are hidden from a
real subprocess (``sys.modules[name] = None`` makes their import fail, as in an install
without the extra); scripts/arm64.sh checks the real edge install on aarch64."""
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
HIDE_GL = "import sys; sys.modules['moderngl'] = None; sys.modules['glfw'] = None\n"


def _run(code: str, tmp_path):
    return subprocess.run([sys.executable, "-c", HIDE_GL + code], cwd=tmp_path,
                          capture_output=True, text=True, timeout=300)


def test_an_edge_install_leaves_the_gl_harness_out():
    """pip install . pulls no moderngl or glfw; the gl extra does, and the test extra
    includes it (the shader harness's tests)."""
    tomllib = pytest.importorskip("tomllib")
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]

    def names(requirements):
        return {re.split(r"[<>=;\[ ]", r, maxsplit=1)[0].lower() for r in requirements}
    assert not {"moderngl", "glfw"} & names(project["dependencies"])
    extras = project["optional-dependencies"]
    assert {"moderngl", "glfw"} <= names(extras["gl"])
    assert "shlight[gl]" in extras["test"]


def test_validate_shaders_without_the_gl_extra_says_what_to_install(tmp_path):
    res = _run("from provider.cli import main\n"
               "sys.exit(main(['validate-shaders', '--no-pictures', '--out', 'v']))", tmp_path)
    assert res.returncode == 2, res.stderr
    assert res.stderr.strip().splitlines() == [
        "shlight validate-shaders: error: cannot validate the shaders: the GL harness is not "
        "installed (moderngl, glfw): pip install 'shlight[gl]'"]


def test_the_viewer_without_the_gl_extra_says_what_to_install(tmp_path):
    res = _run("import runpy\n"
               f"sys.argv = ['viewer.py', '--lighting', 'ws://127.0.0.1:9/']\n"
               f"runpy.run_path({str(ROOT / 'examples/viewer.py')!r}, run_name='__main__')",
               tmp_path)
    assert res.returncode == 1
    assert res.stderr.strip().splitlines() == [
        "viewer: error: the GL harness is not installed (moderngl, glfw): "
        "pip install 'shlight[gl]'"]
