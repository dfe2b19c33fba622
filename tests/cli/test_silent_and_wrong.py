"""Issue 33, "silent and wrong": what used to be accepted without a word and gave a wrong answer
is now refused in one line (exit 2), said in a warning, or shown in /healthz.

The rule for options (provider/cli/options.py): an option that does nothing with the rest of
the command line, or contradicts another, is refused before any work; one that does nothing
with this input (only the frame shows it) is a warning; a number beyond sense is refused
with its range."""
from __future__ import annotations

import json
import os
import subprocess

import cv2
import numpy as np
import pytest

from provider.core.errors import InputError
from provider.core.registration.ball import BallCircle

from conftest import HDRI_DIR
from servertools import ROOT, SHLIGHT, ServeProcess, ServerThread, health, poll, run_cli

needs_fifo = pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="POSIX FIFOs")


def _refused(res, line):
    """Exit 2, nothing on stdout, and exactly ``line`` on stderr."""
    assert res.returncode == 2, (res.stdout, res.stderr)
    assert res.stdout == "" and "Traceback" not in res.stderr, res.stderr
    assert res.stderr.strip().splitlines() == [line], res.stderr


def _warned(res, *lines):
    """Exit 0 and each of ``lines`` exactly once on stderr."""
    assert res.returncode == 0, res.stderr
    got = res.stderr.splitlines()
    for line in lines:
        assert got.count(line) == 1, res.stderr


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("silent")
    rng = np.random.default_rng(3)
    assert cv2.imwrite(str(d / "pano.png"), rng.integers(0, 256, (32, 64, 3), dtype=np.uint8))
    from provider.core.radiometry.response import CameraResponse
    (d / "camera.json").write_text(json.dumps(CameraResponse.gamma(2.2).to_dict()))
    return d


# ---- serve --source "" ----------------------------------------------------------------------

@pytest.mark.parametrize("argv, line", [
    (["--source", ""], "shlight serve: error: --source is empty (an unset variable in a "
                       "service file?): give a source, e.g. --source demo"),
    (["--source", "  "], "shlight serve: error: --source is empty (an unset variable in a "
                         "service file?): give a source, e.g. --source demo"),
    (["--probe", "desk="], "shlight serve: error: --probe 'desk=': the source is empty (an "
                           "unset variable in a service file?): give desk=SPEC, e.g. desk=demo"),
])
def test_an_empty_source_is_refused_not_served_as_the_demo(argv, line):
    _refused(run_cli("serve", "--port", "0", *argv), line)


# ---- environment -o ---------------------------------------------------------------------------

def test_environment_refuses_to_overwrite_its_input(files, tmp_path):
    src = tmp_path / "v.png"
    src.write_bytes((files / "pano.png").read_bytes())
    (tmp_path / "link.png").symlink_to(src)
    before = src.read_bytes()
    for out in (str(src), str(tmp_path / "." / "v.png"), str(tmp_path / "link.png")):
        stem = os.path.splitext(out)[0]
        _refused(run_cli("environment", str(src), "-o", out, "--size", "8"),
                 f"shlight environment: error: -o {out} is the input image: the cube would "
                 f"overwrite it; give another file, e.g. -o {stem}.ktx2")
    assert src.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link.png", "v.png"]


def test_environment_warns_of_a_name_that_says_another_format(files, tmp_path):
    out = tmp_path / "c.png"
    res = run_cli("environment", str(files / "pano.png"), "-o", str(out), "--size", "8")
    _warned(res, f"shlight environment: warning: -o {out}: the file holds a KTX2 cube map, "
                 "not what '.png' says; name it .ktx2")
    assert out.read_bytes()[:12] == b"\xabKTX 20\xbb\r\n\x1a\n"
    res = run_cli("environment", str(files / "pano.png"), "-o", str(tmp_path / "c.ktx2"),
                  "--size", "8")
    assert res.returncode == 0 and "warning" not in res.stderr, res.stderr


# ---- locate-ball -----------------------------------------------------------------------------

def test_locate_ball_refuses_a_circle_that_runs_past_the_frame():
    """bridge.exr (a panorama, no ball) gave exit 0 and a circle of radius 38 px centred
    23 px from the left edge, 15 px of it outside the frame."""
    res = run_cli("locate-ball", str(HDRI_DIR / "bridge.exr"))
    assert res.returncode == 2 and res.stdout == "", res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("shlight locate-ball: error: no ball found in the 512×256 "
                               "frame (the circles found run past its edge, e.g. centre ")
    assert lines[0].endswith(" px): give it with --ball X,Y,R")


def test_a_ball_must_lie_in_the_frame_give_or_take_a_tenth_of_its_radius():
    assert BallCircle(50, 50, 40).inside(100, 100)
    assert BallCircle(44, 50, 40 / 0.95).inside(100, 100)        # 2 px past: a cut-off rim
    assert not BallCircle(23, 43, 38).inside(512, 256)          # bridge.exr's circle
    assert not BallCircle(-5, 50, 20).inside(100, 100)          # centred outside
    assert not BallCircle(375, 8, 195).inside(512, 256)         # larger than the frame


# ---- a 2:1 frame read as a fisheye ---------------------------------------------------------------

def test_compute_warns_when_a_2_to_1_frame_is_read_as_a_fisheye(files):
    res = run_cli("compute", str(files / "pano.png"), "--projection", "fisheye")
    _warned(res, "shlight compute: warning: a 64×32 frame is shaped like an equirect "
                 "panorama (2:1), not a fisheye circle: is --projection fisheye right?")


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    """A 1920×960 equirect room with an ArUco marker 1 m in front, as an 8-bit PNG."""
    from marker_scene import composite, marker_grid, scene, to_srgb8
    from provider.core.geometry.projections import make_projection
    proj = make_projection("equirect", 1920, 960)
    base = scene("dawn", proj)
    img = composite(base, proj, marker_grid(), np.eye(3), [0, 0, -1.0], 0.2)
    white = 0.8 * float(base.reshape(-1, 3).mean(0) @ [0.2126, 0.7152, 0.0722])
    path = tmp_path_factory.mktemp("room") / "room.png"
    assert cv2.imwrite(str(path), to_srgb8(img, white)[..., ::-1])
    return path


def test_register_warns_when_a_panorama_is_read_as_a_fisheye(room):
    """Needs register.py's call of options.say_projection_warnings (issue 33's report)."""
    res = run_cli("register", str(room), "--marker", "aruco:DICT_4X4_50:7", "--marker-size",
                  "0.2", "--projection", "fisheye")
    _warned(res, "shlight register: warning: a 1920×960 frame is shaped like an equirect "
                 "panorama (2:1), not a fisheye circle: is --projection fisheye right?")


def test_register_refuses_a_field_of_view_for_an_equirect(room):
    """Needs register.py's call of options.refuse_unused_options (issue 33's report)."""
    _refused(run_cli("register", str(room), "--marker", "aruco:DICT_4X4_50:7",
                     "--marker-size", "0.2", "--fov", "90"),
             "shlight register: error: --fov has no effect with --projection equirect (only "
             "fisheye, dual-fisheye, mirrorball read it): leave it out")


# ---- options that do nothing here ---------------------------------------------------------------

def _no_effect(flag, projection, readers):
    return (f"{flag} has no effect with --projection {projection} (only {readers} read it): "
            "leave it out")


@pytest.mark.parametrize("argv, line", [
    (["compute", "{png}", "--fov", "90"],
     _no_effect("--fov", "equirect", "fisheye, dual-fisheye, mirrorball")),
    (["compute", "{png}", "--fill", "zero"], _no_effect("--fill", "equirect", "fisheye")),
    (["compute", "{png}", "--fill", "ground"], _no_effect("--fill", "equirect", "fisheye")),
    (["compute", "{png}", "--projection", "dual-fisheye", "--albedo", "0.2"],
     _no_effect("--albedo", "dual-fisheye", "fisheye")),
    (["compute", "{png}", "--center", "3,3"],
     _no_effect("--center", "equirect", "fisheye, mirrorball, angular")),
    (["compute", "{png}", "--ball-mask", "5"], _no_effect("--ball-mask", "equirect", "mirrorball")),
    (["compute", "{png}", "--projection", "angular", "--ball-unseen", "5"],
     _no_effect("--ball-unseen", "angular", "mirrorball")),
    (["compute", "{png}", "--order-budget", "0.05"],
     "--order-budget has no effect without --order auto: give --order auto, or leave "
     "--order-budget out"),
    (["compute", "{png}", "--projection", "mirrorball", "--ball-distance", "3", "--fov", "40"],
     "--ball-distance and --fov both set the mirror ball's perspective (the camera's distance "
     "to it): give one"),
    (["compute", "{png}", "--projection", "mirrorball", "--ball", "20,16,10", "--radius", "9"],
     "--ball and --radius both give the ball's circle: give one"),
    (["export", "{png}", "--to", "unity", "--fov", "90"],
     _no_effect("--fov", "equirect", "fisheye, dual-fisheye, mirrorball")),
    (["environment", "{png}", "-o", "{tmp}/c.ktx2", "--fov", "90"],
     _no_effect("--fov", "equirect", "fisheye, dual-fisheye, mirrorball")),
    (["validate-shaders", "--no-hlsl", "--require-hlsl", "--out", "{tmp}/v"],
     "--no-hlsl and --require-hlsl contradict each other (skip HLSL, and fail without it): "
     "give one"),
    (["serve", "--port", "0", "--fov", "90"],
     _no_effect("--fov", "equirect", "fisheye, dual-fisheye, mirrorball")),
    (["serve", "--port", "0", "--environment-size", "64"],
     "--environment-size has no effect without --environment: give --environment, or leave "
     "--environment-size out"),
    (["serve", "--port", "0", "--environment-hz", "2"],
     "--environment-hz has no effect without --environment: give --environment, or leave "
     "--environment-hz out"),
    (["serve", "--port", "0", "--probe", "a=demo", "--probe-args", "a=--order-budget 0.1"],
     "--probe-args a: --order-budget has no effect without --order auto: give --order auto, "
     "or leave --order-budget out"),
    (["serve", "--port", "0", "--fps", "1e9"],
     "--fps 1e+09: out of range (0, 240] frames a second"),
    (["serve", "--port", "0", "--probe", "a=demo", "--probe-args", "a=--fps 241"],
     "probe a: --fps 241: out of range (0, 240] frames a second"),
])
def test_an_option_that_cannot_do_anything_here_is_refused(files, tmp_path, argv, line):
    argv = [a.format(png=files / "pano.png", tmp=tmp_path) for a in argv]
    _refused(run_cli(*argv), f"shlight {argv[0]}: error: {line}")
    assert list(tmp_path.iterdir()) == []                  # nothing written


def test_serve_checks_an_inherited_option_in_every_probe_that_inherits_it():
    """A command-line option is refused only when no probe that inherits it can use it."""
    from provider.cli import build_parser
    from provider.cli.serve import build_server

    def build(*argv):
        return build_server(build_parser().parse_args(["serve", "--port", "0", *argv]))
    build("--probe", "a=demo", "--probe", "b=demo", "--environment-size", "16",
          "--probe-args", "b=--environment")
    build("--probe", "a=demo", "--probe", "b=demo", "--projection", "fisheye", "--fov", "190",
          "--probe-args", "b=--projection equirect")
    with pytest.raises(InputError, match="^--fov has no effect with --projection equirect"):
        build("--probe", "a=demo", "--probe", "b=demo", "--fov", "120",
              "--probe-args", "b=--projection equirect")
    with pytest.raises(InputError, match="^--probe-args b: --fill has no effect"):
        build("--probe", "a=demo", "--probe", "b=demo", "--projection", "fisheye",
              "--probe-args", "b=--projection equirect --fill zero")


def test_options_for_8bit_frames_on_a_float_frame_are_a_warning(files, tmp_path):
    exr = str(HDRI_DIR / "lab.exr")
    res = run_cli("environment", exr, "-o", str(tmp_path / "c.ktx2"), "--size", "8",
                  "--camera", str(files / "camera.json"))
    _warned(res, "shlight environment: warning: --camera has no effect on a float frame (its "
                 "curve decodes 8- and 16-bit frames; float frames are linear already)")
    res = run_cli("environment", exr, "-o", str(tmp_path / "d.ktx2"), "--size", "8",
                  "--encoding", "srgb")
    _warned(res, "shlight environment: warning: --encoding srgb has no effect on a float "
                 "frame (float frames are linear already)")


def test_compute_warns_of_a_camera_curve_on_a_float_frame(files):
    """Needs compute.py's call of options.say_frame_warnings (issue 33's report)."""
    res = run_cli("compute", str(HDRI_DIR / "lab.exr"), "--camera", str(files / "camera.json"))
    _warned(res, "shlight compute: warning: --camera has no effect on a float frame (its "
                 "curve decodes 8- and 16-bit frames; float frames are linear already)")


def test_serve_says_a_camera_curve_does_nothing_on_a_float_file(files):
    with ServeProcess("--source", str(HDRI_DIR / "lab.exr"), "--camera",
                      str(files / "camera.json")) as srv:
        pass
    lines = [l for l in srv.output.splitlines() if "--camera has no effect" in l]
    assert len(lines) == 1 and lines[0].endswith(
        "WARNING probe default: --camera has no effect on a float frame (its curve decodes 8- "
        "and 16-bit frames; float frames are linear already)"), srv.output


# ---- /healthz and a file replaced by garbage ---------------------------------------------------------

def test_healthz_is_degraded_while_the_file_cannot_be_read(tmp_path):
    path = tmp_path / "room.png"
    img = np.full((32, 64, 3), 90, np.uint8)
    assert cv2.imwrite(str(path), img)
    with ServerThread("--source", str(path), "--fps", "30") as srv:
        poll(lambda: health(srv.http)["status"] == "ok", timeout=30, what="live lighting")
        (tmp_path / "new.png").write_bytes(b"\x89PNG\r\n\x1a\n" + os.urandom(100))
        os.replace(tmp_path / "new.png", path)
        h = poll(lambda: (lambda h: h if h["status"] == "degraded" else None)(health(srv.http)),
                 timeout=30, what="degraded")
        probe = h["probes"]["default"]
        assert probe["state"] == "live"             # the previous image's lighting goes on
        assert probe["outdated"].startswith(f"{path}: ")
        assert probe["outdated"].endswith(" (the lighting is from its previous version)")
        assert list(probe["bad_files"]) == [str(path)]
        assert cv2.imwrite(str(tmp_path / "new.png"), img + 50)
        os.replace(tmp_path / "new.png", path)
        h = poll(lambda: (lambda h: h if h["status"] == "ok" else None)(health(srv.http)),
                 timeout=30, what="ok again")
        assert "outdated" not in h["probes"]["default"]
        assert not h["probes"]["default"]["bad_files"]


# ---- validate-shaders --write-vectors -----------------------------------------------------------------

def test_write_vectors_alone_writes_in_the_current_folder_not_the_package():
    from provider.cli import build_parser
    args = build_parser(["validate-shaders"]).parse_args(["validate-shaders",
                                                          "--write-vectors"])
    assert args.write_vectors == "contract_vectors.json"      # relative: the current folder
    from provider.verify import contract
    with pytest.raises(TypeError):
        contract.write_contract_vectors()                       # no default into the package


_GENERATE = ("import sys; from provider.verify import contract; "
             "sys.stdout.write(contract.dumps(contract.contract_vectors()))")


def test_the_vectors_generator_reproduces_its_file():
    """Two runs (BLAS on one thread, and on two) write the same text; writing the file
    again from its own numbers changes nothing; and the fresh numbers are the committed
    file's within the tolerances tests/shadertools.py states (the engine's float32 sums
    differ in their last digits on another CPU, every other number to 1e-12)."""
    from shadertools import vectors_mismatches

    from provider.verify import contract
    runs = [subprocess.run([*SHLIGHT[:1], "-c", _GENERATE], cwd=ROOT, capture_output=True,
                           text=True, timeout=120,
                           env={**os.environ, "OPENBLAS_NUM_THREADS": n, "OMP_NUM_THREADS": n})
            for n in ("1", "2")]
    assert all(r.returncode == 0 for r in runs), runs[0].stderr + runs[1].stderr
    assert runs[0].stdout == runs[1].stdout
    assert contract.dumps(json.loads(runs[0].stdout)) == runs[0].stdout
    committed = contract.VECTORS_PATH.read_text()
    assert contract.dumps(json.loads(committed)) == committed
    fresh, old = json.loads(runs[0].stdout), json.loads(committed)
    for key in ("cases", "exports"):
        assert vectors_mismatches(fresh[key], old[key], key) == []


# ---- FIFOs -------------------------------------------------------------------------------------------

def _line_within(stream, seconds: float) -> str:
    """The next line of a child's pipe, or "" if none comes within ``seconds`` (a test that
    waits on a FIFO must never hang)."""
    import select
    ready, _, _ = select.select([stream], [], [], seconds)
    return stream.readline() if ready else ""


def _write_fifo(fifo, data: bytes) -> None:
    """Write ``data`` into ``fifo`` once a reader has it open (or is opening it): never
    blocks on a FIFO that nobody reads (ENXIO is retried until the deadline)."""
    def opened():
        try:
            return os.open(fifo, os.O_WRONLY | os.O_NONBLOCK) + 1     # 0 is a valid fd
        except OSError:
            return 0
    fd = poll(opened, timeout=30, what=f"a reader on {fifo}") - 1
    try:
        os.set_blocking(fd, True)
        os.write(fd, data)
    finally:
        os.close(fd)


def _fifo_command(argv, fifo, data: bytes, note: str):
    """Run ``argv`` on ``fifo``: its first stderr line must be ``note`` (said before it
    waits), then ``data`` is written; (returncode, stdout, the rest of stderr)."""
    proc = subprocess.Popen([*SHLIGHT, *argv], cwd=ROOT, text=True, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    try:
        assert _line_within(proc.stderr, 30) == note
        _write_fifo(fifo, data)
        out, rest = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return proc.returncode, out, rest


@needs_fifo
def test_environment_says_it_waits_for_a_writer_on_a_fifo(files, tmp_path):
    fifo = tmp_path / "frame.png"
    os.mkfifo(fifo)
    rc, _, rest = _fifo_command(
        ["environment", str(fifo), "-o", str(tmp_path / "c.ktx2"), "--size", "8"], fifo,
        (files / "pano.png").read_bytes(),
        f"shlight environment: note: waiting for a writer on FIFO {fifo}\n")
    assert rc == 0, rest
    assert (tmp_path / "c.ktx2").is_file()


@needs_fifo
def test_serve_listens_first_then_waits_for_a_writer_on_a_fifo(files, tmp_path):
    fifo = tmp_path / "frame.png"
    os.mkfifo(fifo)
    with ServeProcess("--source", str(fifo)) as srv:       # listening: no writer yet
        poll(lambda: f"waiting for a writer on FIFO {fifo}" in srv.output, timeout=30,
             what="the note")
        _write_fifo(fifo, (files / "pano.png").read_bytes())
        poll(lambda: health(srv.http)["probes"]["default"]["frames"] >= 1, timeout=30,
             what="a frame from the FIFO")
    lines = [l for l in srv.output.splitlines() if "waiting for a writer" in l]
    assert len(lines) == 1, srv.output


@needs_fifo
def test_compute_says_it_waits_for_a_writer_on_a_fifo(files, tmp_path):
    """Needs compute.py's call of options.say_fifo_waits (issue 33's report)."""
    fifo = tmp_path / "frame.png"
    os.mkfifo(fifo)
    rc, out, rest = _fifo_command(["compute", str(fifo)], fifo,
                                  (files / "pano.png").read_bytes(),
                                  f"shlight compute: note: waiting for a writer on FIFO {fifo}\n")
    assert rc == 0, rest
    assert json.loads(out)["type"] == "sh9"
