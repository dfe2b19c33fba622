"""Shared fixtures: the real HDR panoramas in tests/data/hdri (CC0, see its README), and a
headless OpenGL context for the shader tests."""
import os
from pathlib import Path

import pytest

# The tests run numpy's BLAS with one thread, as every shlight command does
# (provider/cli/threads.py): a float32 product summed by two threads in another order would
# differ from the command's in the last bits, and the tests compare them exactly.
from provider.cli.threads import limit_blas_threads

limit_blas_threads()


def pytest_collection_modifyitems(config, items):
    """The benches (``@pytest.mark.bench``) measure rather than check: the unit suite leaves
    them out unless the marker expression names them (``pytest -m bench``, as .ci/run does
    in a step of its own)."""
    if "bench" in (config.getoption("markexpr") or ""):
        return
    benches = [item for item in items if item.get_closest_marker("bench")]
    if benches:
        config.hook.pytest_deselected(items=benches)
        items[:] = [item for item in items if not item.get_closest_marker("bench")]

DATA = Path(__file__).resolve().parent / "data"
HDRI_DIR = DATA / "hdri"
HDRI_NAMES = sorted(p.stem for p in HDRI_DIR.glob("*.exr"))


def load_hdri(name: str):
    """(256, 512, 3) float32 linear RGB radiance of a bundled panorama."""
    from provider.core.radiometry.images import read_image
    return read_image(HDRI_DIR / f"{name}.exr")


@pytest.fixture(scope="session")
def hdri():
    """name -> float32 panorama, loaded once per session."""
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = load_hdri(name)
        return cache[name]
    return get


@pytest.fixture(scope="module")
def ctx():
    """A headless OpenGL 3.3 context (Mesa EGL), one per test module; the test skips with
    what to install where none can be made (SHLIGHT_REQUIRE_GL=1: fail instead)."""
    from provider.verify.render import NoOpenGL, create_context
    try:
        return create_context()
    except NoOpenGL as exc:
        if os.environ.get("SHLIGHT_REQUIRE_GL"):
            raise
        pytest.skip(str(exc))


@pytest.fixture(scope="session", autouse=True)
def table_cache_off(tmp_path_factory):
    """The projectors' table cache (provider.core.table_cache) off, and pointed away from the
    user's own: a test builds its tables as before, whatever an earlier test (or a test
    that changed a module's constant) left on disk. tests/core/test_table_cache.py turns it on
    in a folder of its own."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("SHLIGHT_CACHE_DIR", str(tmp_path_factory.mktemp("shlight-cache")))
        mp.setenv("SHLIGHT_TABLE_CACHE", "0")
        yield


@pytest.fixture(params=["c", "python"])
def kernels(request, monkeypatch):
    """The test runs twice, as markupsafe runs its suite over its speedups: "c" on the C
    kernels (skipped where they were not built: tests/core/kernels/test_kernels.py fails there), "python"
    on their Python twins, put where :mod:`provider.core.radiometry.blocks`,
    :mod:`provider.core.sh9.lens_fold`, :mod:`provider.core.sh9.clipping` (the fold's
    ``count_top``), :mod:`provider.core.sh9.equirect_pass` and
    :mod:`provider.core.lights.coarse_truth`, :mod:`provider.core.lights.caps` and
    :mod:`provider.core.lights.first_pass` chose the kernel at import;
    ``KERNEL`` then says built, so the products take the same one-pass
    paths, through the twins."""
    from provider.core.radiometry import blocks
    from provider.core.lights import caps, coarse_truth, first_pass
    from provider.core.sh9 import clipping, equirect_pass, lens_fold
    if request.param == "c":
        if not (blocks.KERNEL and lens_fold.KERNEL and equirect_pass.KERNEL
                and coarse_truth.KERNEL and caps.KERNEL and first_pass.KERNEL):
            pytest.skip("the C kernels were not built (tests/core/kernels/test_kernels.py says how)")
    else:
        monkeypatch.setattr(blocks, "_decode_blocks", blocks._decode_blocks_py)
        monkeypatch.setattr(blocks, "KERNEL", True)
        monkeypatch.setattr(lens_fold, "_fold_kernel", lens_fold._fold_twin)
        monkeypatch.setattr(clipping, "_count_top", clipping._count_top_twin)
        monkeypatch.setattr(lens_fold, "KERNEL", True)
        monkeypatch.setattr(equirect_pass, "_equirect_rows", equirect_pass._equirect_rows_py)
        monkeypatch.setattr(equirect_pass, "KERNEL", True)
        monkeypatch.setattr(coarse_truth, "_truth_kernel", coarse_truth.truth_caps_twin)
        monkeypatch.setattr(caps, "_excess_kernel", caps.excess_rows_twin)
        monkeypatch.setattr(first_pass, "_first_pass_kernel", first_pass.first_pass_twin)
    return request.param


@pytest.fixture(scope="module")
def camera(tmp_path_factory):
    """An absolutely calibrated camera.json of the simulated filmic camera (the photometry
    tests': tests/photometrytools.py), made once per module."""
    from photometrytools import calibrated_camera
    return calibrated_camera(tmp_path_factory.mktemp("meter"))


@pytest.fixture(scope="session")
def room_probes(tmp_path_factory):
    """The analytic room's eight positioned probes (provider/bench/room.py, 64 rows): the
    probes file the probe-grid tests serve (tests/roomtools.py), written once a session."""
    from provider.bench import room
    return room.write_probes(tmp_path_factory.mktemp("room"), height=64)


# ---- the Unity tests' C# builds, once a session (tests/unitytools.py) -------------------------

@pytest.fixture(scope="session")
def build_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("unity_csharp")


@pytest.fixture(scope="session")
def live_exe(build_dir):
    """tests/csharp/LiveClient.cs with the package's runtime against the Unity stand-in."""
    from unitytools import CORE, CSHARP, HARNESS, RUNTIME, STANDIN, _compile
    return _compile(build_dir / "LiveClient.exe",
                    [*CORE, *RUNTIME, STANDIN, HARNESS, CSHARP / "LiveClient.cs"])


@pytest.fixture(scope="session")
def cube_exe(build_dir):
    """tests/csharp/CubeTest.cs: the package's reflection-cube bake under Mono."""
    from unitycubetools import compile_cube_test
    return compile_cube_test(build_dir / "CubeTest.exe")


@pytest.fixture(scope="session")
def calibrated(tmp_path_factory):
    """`shlight calibrate-lens` run once on chessboard photos of one known lens
    (tests/lensboardtools.py): (folder, lens file as a dict, the finished command)."""
    from lensboardtools import calibrate
    return calibrate(tmp_path_factory.mktemp("lens"))
