"""Issue 41: one output rule for every command that writes (provider/cli/outputs.py).

Before any work, in one line (exit 2, nothing on stdout, the target unchanged): a device, a
FIFO, a socket or a folder where a file is wanted, a folder that is missing or cannot be
written, and any of the command's inputs by identity (the same file by another path, a
symbolic or a hard link). A regular file that is no input is replaced whole (a temporary
file renamed over it, its mode kept, no temporary left); a symbolic link is written through.
``-o -`` is standard output where a command offers it (environment, calibrate-lens, marker)
and refused elsewhere. Every run is a real ``shlight`` process on tiny inputs."""
from __future__ import annotations

import os
import socket
import stat
import subprocess

import cv2
import numpy as np
import pytest

from servertools import ROOT, SHLIGHT, run_cli
from servertools import refused as _refused


# a refusal came before any work: a command that started would have said more ("reading 3
# frames ...", a progress line, a summary)


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """Tiny inputs: a 32×16 panorama, a 3-frame bracket (1 EV apart) and a chessboard-less
    photo; the commands are refused before they would read any of them."""
    d = tmp_path_factory.mktemp("outputs-in")
    rng = np.random.default_rng(41)
    assert cv2.imwrite(str(d / "pano.png"), rng.integers(0, 256, (16, 32, 3), dtype=np.uint8))
    base = rng.random((16, 32, 3))
    for i in range(3):
        assert cv2.imwrite(str(d / f"ev{i}.png"),
                           np.clip(base * 80 * 2 ** i, 0, 255).astype(np.uint8))
    return d


def _file_commands(d):
    """command -> (argv for an output OUT, its input files): each command that writes a file."""
    pano, ev = str(d / "pano.png"), [str(d / f"ev{i}.png") for i in range(3)]
    return {
        "environment": (["environment", pano, "--size", "8", "-o"], [pano]),
        "calibrate-response": (["calibrate-response", f"{ev[0]}@1/4", f"{ev[1]}@1/2",
                                f"{ev[2]}@1", "-o"], ev),
        "calibrate-lens": (["calibrate-lens", pano, ev[0], "--board", "9x6", "-o"], [pano, ev[0]]),
        "marker": (["marker", "aruco:DICT_4X4_50:7", "-o"], []),
        "validate-shaders": (["validate-shaders", pano, "--out", str(d / "v"),
                              "--write-vectors"], [pano]),
    }


FILE_COMMANDS = ["environment", "calibrate-response", "calibrate-lens", "marker",
                 "validate-shaders"]
FOLDER_COMMANDS = {"bench": ["bench", "--quick", "--out"],
                   "validate-shaders": ["validate-shaders", "--out"]}


def _run(inputs, command, out):
    argv, _ = _file_commands(inputs)[command]
    return run_cli(*argv, str(out))


def _snapshot(folder):
    return sorted((p.name, p.lstat().st_mode, p.lstat().st_ino) for p in folder.iterdir())


# -- devices, FIFOs, sockets ------------------------------------------------------------------

@pytest.fixture
def device(tmp_path):
    """A character device of our own (as /dev/full: major 1, minor 7), so that a regression
    replaces this node, never the machine's /dev/full; making one needs root."""
    node = tmp_path / "full"
    try:
        os.mknod(node, stat.S_IFCHR | 0o666, os.makedev(1, 7))
    except (PermissionError, AttributeError):
        pytest.skip("making a device node needs root (CAP_MKNOD)")
    return node


def _still_the_device(node):
    st = os.lstat(node)
    assert stat.S_ISCHR(st.st_mode) and st.st_rdev == os.makedev(1, 7)


@pytest.mark.parametrize("command", FILE_COMMANDS)
def test_a_device_is_refused_and_kept(inputs, device, command):
    line = _refused(_run(inputs, command, device), f"shlight {command}: error:",
                    str(device), "is a character device, not a file")
    _still_the_device(device)
    assert ("(standard output: -o -)" in line) == (
        command in ("environment", "calibrate-lens", "marker"))


@pytest.mark.parametrize("command", FOLDER_COMMANDS)
def test_a_device_is_no_output_folder(device, command):
    _refused(run_cli(*FOLDER_COMMANDS[command], str(device)), f"shlight {command}: error:",
             f"--out {device} is a character device; give a folder")
    _still_the_device(device)


@pytest.mark.parametrize("command", FILE_COMMANDS)
def test_a_fifo_is_refused_and_kept(inputs, tmp_path, command):
    """A write into a FIFO would wait for a reader for ever (the run's timeout ends it)."""
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    _refused(_run(inputs, command, fifo), "is a FIFO (a named pipe), not a file")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


@pytest.mark.parametrize("command", FOLDER_COMMANDS)
def test_a_fifo_is_no_output_folder(tmp_path, command):
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    _refused(run_cli(*FOLDER_COMMANDS[command], str(fifo)), "is a FIFO (a named pipe)",
             "give a folder")
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)


def test_a_socket_is_refused_and_kept(inputs, tmp_path):
    path = tmp_path / "s.ktx2"
    with socket.socket(socket.AF_UNIX) as s:
        s.bind(str(path))
        _refused(_run(inputs, "environment", path), f"-o {path} is a socket, not a file")
    assert stat.S_ISSOCK(os.lstat(path).st_mode)


@pytest.mark.parametrize("name", ["/dev/stdout", "/dev/fd/1", "/proc/self/fd/1"])
def test_a_descriptor_is_not_standard_output(inputs, name):
    """``-o /dev/stdout`` names whatever stdout is open on (here the test's pipe; in a shell
    perhaps a file it redirected to, which a rename would replace): ``-o -`` is the way."""
    _refused(_run(inputs, "environment", name),
             f"shlight environment: error: -o {name} is an open descriptor, not a file: "
             "give a file's name (standard output: -o -)")


# -- folders ---------------------------------------------------------------------------------

@pytest.mark.parametrize("command", FILE_COMMANDS)
def test_a_folder_is_refused_where_a_file_is_wanted(inputs, tmp_path, command):
    folder = tmp_path / "here"
    folder.mkdir()
    _refused(_run(inputs, command, folder), f"{folder} is a folder: give a file's name in it")
    assert list(folder.iterdir()) == []


@pytest.mark.parametrize("command", FILE_COMMANDS)
def test_a_file_under_a_file_is_refused(inputs, tmp_path, command):
    """The issue's unwritable folder, as every user sees it (root included): a path whose
    folder is a regular file."""
    plain = tmp_path / "plain"
    plain.write_bytes(b"keep")
    _refused(_run(inputs, command, plain / "out.json"),
             f"{plain / 'out.json'}: cannot write it: {plain} is a file, not a folder")
    assert plain.read_bytes() == b"keep"


@pytest.mark.parametrize("command", FOLDER_COMMANDS)
def test_an_output_folder_under_a_file_is_refused(tmp_path, command):
    plain = tmp_path / "plain"
    plain.write_bytes(b"keep")
    _refused(run_cli(*FOLDER_COMMANDS[command], str(plain / "b")),
             f"cannot write under {plain} (a file, not a folder)")
    assert plain.read_bytes() == b"keep"


@pytest.mark.parametrize("command", FILE_COMMANDS)
def test_a_missing_folder_is_refused(inputs, tmp_path, command):
    out = tmp_path / "nowhere" / "out.json"
    _refused(_run(inputs, command, out),
             f"{out}: cannot write it: no folder {tmp_path / 'nowhere'}")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="no /proc here")
@pytest.mark.parametrize("command", ["bench", "validate-shaders", "calibrate-lens", "marker"])
def test_a_folder_even_root_cannot_write_is_refused(inputs, command):
    """/proc: root passes every permission check yet can make nothing there (the issue's
    ``bench --out /proc/b`` traceback); the folder is tried for real, not asked."""
    if command in FOLDER_COMMANDS:
        res = run_cli(*FOLDER_COMMANDS[command], "/proc/b")
        _refused(res, "--out /proc/b: cannot write under /proc")
    else:
        _refused(_run(inputs, command, "/proc/out.png"),
                 "-o /proc/out.png: cannot write in /proc (")


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
@pytest.mark.parametrize("command", ["environment", "calibrate-lens", "marker"])
def test_a_read_only_folder_is_refused(inputs, tmp_path, command):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        _refused(_run(inputs, command, ro / "out.png"),
                 f"-o {ro / 'out.png'}: cannot write in {ro} (Permission denied)")
    finally:
        ro.chmod(0o755)


# -- the command's own inputs ----------------------------------------------------------------

@pytest.mark.parametrize("command", ["environment", "calibrate-response", "calibrate-lens",
                                     "validate-shaders"])
@pytest.mark.parametrize("how", ["itself", "another path", "symbolic link", "hard link"])
def test_an_input_by_any_name_is_refused_and_kept(inputs, tmp_path, command, how):
    _, ins = _file_commands(inputs)[command]
    victim = ins[0]
    out = {"itself": victim,
           "another path": os.path.join(os.path.dirname(victim), ".", os.path.basename(victim)),
           "symbolic link": tmp_path / "link.png",
           "hard link": tmp_path / "hard.png"}[how]
    if how == "symbolic link":
        os.symlink(victim, out)
    elif how == "hard link":
        os.link(victim, out)
    before = open(victim, "rb").read()
    around = _snapshot(inputs)
    _refused(_run(inputs, command, out), f"{out} is ", "would overwrite it; give another file")
    assert open(victim, "rb").read() == before
    assert _snapshot(inputs) == around


def test_the_input_image_line_of_environment(inputs):
    pano = inputs / "pano.png"
    _refused(_run(inputs, "environment", pano),
             f"shlight environment: error: -o {pano} is the input image: the cube would "
             f"overwrite it; give another file, e.g. -o {inputs / 'pano'}.ktx2")


def test_calibrate_response_refuses_an_input_frame_by_its_picture(inputs, tmp_path):
    """-o ev0.json writes its curve to ev0.png beside it: the input frame ev0.png."""
    out = inputs / "ev0.json"
    before = (inputs / "ev0.png").read_bytes()
    _refused(_run(inputs, "calibrate-response", out),
             f"shlight calibrate-response: error: -o {out}: its picture {inputs / 'ev0.png'} "
             "is an input frame: the curve's picture would overwrite it; give another file, "
             f"e.g. -o {inputs / 'ev0'}-camera.json")
    assert (inputs / "ev0.png").read_bytes() == before and not out.exists()
    _refused(_run(inputs, "calibrate-response", tmp_path / "cam.png"),
             "the curve's picture is written beside the response as CAMERA.png; name the "
             f"response .json, e.g. -o {tmp_path / 'cam'}.json")


def test_an_engine_file_is_an_input_too(inputs, tmp_path):
    """--camera names a file the command reads: not an output either."""
    camera = tmp_path / "camera.json"
    camera.write_text("{}")
    res = run_cli("environment", str(inputs / "pano.png"), "--camera", str(camera),
                  "-o", str(camera))
    _refused(res, f"-o {camera} is the --camera file: the cube would overwrite it")
    assert camera.read_text() == "{}"


# -- what is written -------------------------------------------------------------------------

def test_a_regular_file_is_replaced_whole_keeping_its_mode(inputs, tmp_path):
    out = tmp_path / "cube.ktx2"
    out.write_bytes(b"old")
    out.chmod(0o640)
    other = tmp_path / "other.ktx2"
    os.link(out, other)             # a second name of the old file: it keeps the old bytes
    res = _run(inputs, "environment", out)
    assert res.returncode == 0, res.stderr
    assert out.read_bytes()[:12] == b"\xabKTX 20\xbb\r\n\x1a\n"
    assert stat.S_IMODE(out.stat().st_mode) == 0o640
    assert other.read_bytes() == b"old"            # renamed over, not written into
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cube.ktx2", "other.ktx2"]


def test_a_symbolic_link_is_written_through(tmp_path):
    real = tmp_path / "real.png"
    real.write_bytes(b"old")
    link = tmp_path / "m.png"
    link.symlink_to(real)
    res = run_cli("marker", "aruco:DICT_4X4_50:7", "--size", "0.02", "--dpi", "72",
                  "-o", str(link))
    assert res.returncode == 0, res.stderr
    assert link.is_symlink() and real.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.png", "real.png"]


@pytest.mark.parametrize("argv, head", [
    (["marker", "aruco:DICT_4X4_50:7", "--size", "0.02", "--dpi", "72", "-o", "-"],
     b"\x89PNG\r\n\x1a\n"),
    (["environment", "{pano}", "--size", "8", "-o", "-"], b"\xabKTX 20\xbb\r\n\x1a\n")])
def test_dash_is_standard_output_where_offered(inputs, argv, head):
    argv = [a.format(pano=inputs / "pano.png") for a in argv]
    res = subprocess.run([*SHLIGHT, *argv], cwd=ROOT, capture_output=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert res.stdout[:len(head)] == head
    assert b"wrote standard output" in res.stderr or b"standard output:" in res.stderr


@pytest.mark.parametrize("command, option", [("calibrate-response", "-o"),
                                             ("validate-shaders", "--write-vectors")])
def test_dash_is_refused_where_not_offered(inputs, command, option):
    _refused(_run(inputs, command, "-"), f"{option} -: this command writes files, not "
                                         "standard output; give a file's name")
    assert not (inputs / "-").exists()


def test_the_target_is_checked_again_just_before_the_rename(tmp_path):
    """Between the check (before any work) and the rename the target may become something
    else: a FIFO made meanwhile is refused then, kept, and the temporary file removed."""
    from provider.cli.outputs import output_file
    from provider.core.errors import InputError
    target = tmp_path / "late.json"
    out = output_file(str(target), inputs=[])
    os.mkfifo(target)
    with pytest.raises(InputError, match="is a FIFO"):
        out.write("{}")
    assert stat.S_ISFIFO(os.lstat(target).st_mode)
    assert [p.name for p in tmp_path.iterdir()] == ["late.json"]


def test_calibrate_lens_writes_its_lens_file_to_standard_output(calibrated):
    """``-o -``: the lens file alone on stdout (a pipe into a file or another tool), the
    summary on stderr."""
    import json
    d, _, _ = calibrated
    photos = [str(d / f"board{i:02d}.png") for i in range(14)]
    res = run_cli("calibrate-lens", *photos, "--board", "8x5", "-o", "-", timeout=300)
    assert res.returncode == 0, res.stderr
    lens = json.loads(res.stdout)
    assert lens["shlight_lens"] == 1 and lens["views"] == 14
    assert "reprojection error" in res.stderr and "wrote" not in res.stderr + res.stdout


def test_write_vectors_replaces_a_file_whole(tmp_path):
    """``--write-vectors``: written beside its target and renamed over it (its mode kept),
    then checked by the shaders as ``--vectors`` would be (where OpenGL is missing the
    check is refused after the write, in one line)."""
    import json
    out = tmp_path / "v.json"
    out.write_text("old")
    out.chmod(0o600)
    res = run_cli("validate-shaders", "--write-vectors", str(out), "--out", str(tmp_path / "o"),
                  "--no-pictures", "--no-hlsl", "--normals", "64", timeout=600)
    assert res.returncode == 0 or "cannot validate the shaders" in res.stderr, res.stderr
    assert f"wrote {out}" in res.stdout
    names = {c["name"] for c in json.loads(out.read_text())["cases"]}
    assert {"furnace", "panorama_sky"} <= names
    assert stat.S_IMODE(out.stat().st_mode) == 0o600
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
