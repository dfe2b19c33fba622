"""The floor shadow of a floating sphere (provider/bench/shadows.py, docs/shadows.md): the
brute force against analytic answers, the light model (lights as discs of their measured
angular radius) against the brute force on synthetic and real panoramas, and the bench
section on the command line. Small maps (24 × 24 floor points) keep it fast.
"""
from __future__ import annotations

import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from provider.bench import shadows as bench

from conftest import HDRI_DIR

ROOT = Path(__file__).resolve().parents[2]
GRID = 24


@pytest.fixture(scope="module")
def shadow_of(hdri):
    """name -> bench.floor_shadow of that panorama on the quick grid, computed once."""
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = bench.floor_shadow(hdri(name), grid=GRID)
        return cache[name]
    return get


def disc_sky(radius_deg: float, elevation_deg: float = 50.0, flux: float = 30.0,
             background: float = 0.0, width: int = 512) -> np.ndarray:
    """An equirect holding one white uniform disc (exact coverage, 4 × 4 samples a pixel)
    toward azimuth +X at ``elevation_deg``, on a uniform ``background``."""
    e = math.radians(elevation_deg)
    return bench.disc_equirect(width, radius_deg, (math.cos(e), math.sin(e), 0.0), flux,
                               background, colour=(1.0, 1.0, 1.0))


def test_the_sphere_cone_and_the_disc_visibility_are_geometry():
    """Directly under the sphere along the key, the key is hidden (V = 0); far across it is
    seen (V = 1); a disc half inside the cone is half visible."""
    scene = bench.FloorScene(np.array([0.0, 1.0, 0.0]), height=3.0, grid=3)
    centre = 4                                       # the middle of a 3 × 3 map: the origin
    assert scene.occluded(np.array([[0.0, 1.0, 0.0]]))[centre, 0]
    point, disc = scene.visibility(np.array([[0.0, 1.0, 0.0]]), [1.0])
    assert point[centre, 0] == 0 and disc[centre, 0] == 0
    # from the origin the cone's half-angle is asin(1/3); a disc centred on its rim
    rim = math.asin(1 / 3)
    d = np.array([math.sin(rim), math.cos(rim), 0.0])
    _, disc = scene.visibility(d[None], [2.0])
    assert disc[centre, 0] == pytest.approx(0.5, abs=0.06)
    corner_far = bench.FloorScene(np.array([0.0, 1.0, 0.0]), height=3.0, half=30.0, grid=3)
    point, disc = corner_far.visibility(np.array([[0.0, 1.0, 0.0]]), [1.0])
    assert point[0, 0] == 1 and disc[0, 0] == 1


def test_a_lone_disc_is_shadowed_as_the_disc_model_says_and_better_than_a_point():
    """Nothing in the sky but a uniform 9° disc (a softbox). The light takes the disc's
    radiance above its detection level (16× the mean here: 89 % of its flux); against a
    truth where the sphere hides just that, the disc model agrees to the map's sampling.
    The rest of the disc stays in the ambient, which the ratio does not occlude: against
    the full truth the disc model is still within the target, and points, with their hard
    edge, miss by more than twice as much."""
    res = bench.floor_shadow(disc_sky(9.0), grid=GRID)
    assert res["lights"] == 1 and res["radii_deg"][0] == pytest.approx(9.0, rel=0.03)
    e = res["errors"]
    assert e["discs_vs_lights_only"][0] <= 0.01 and e["discs_vs_lights_only"][1] <= 0.04, e
    rms_disc, worst_disc = e["discs"]
    assert rms_disc <= bench.TARGET_RMS and worst_disc <= bench.TARGET_WORST, e
    assert e["points"][0] > 2 * rms_disc and e["points"][1] > 2 * worst_disc, e
    assert res["maps"]["true"].min() < 0.15          # an umbra: the disc is all the light


@pytest.mark.parametrize("name", ["apartment", "dawn", "night"])
def test_held_out_panoramas_where_discs_meet_the_target_and_beat_points(name, shadow_of):
    """The target (issue 30: ≤ 0.035 RMS and ≤ 0.15 at worst) met by the disc model on
    held-out panoramas (docs/shadows.md), where lights as points do worse (in RMS; their
    worst may be the same floor point, where the ambient, not a light, misses: night)."""
    assert name in bench.HELD_OUT
    res = shadow_of(name)
    rms, worst = res["errors"]["discs"]
    assert rms <= bench.TARGET_RMS and worst <= bench.TARGET_WORST, res["errors"]
    assert rms < res["errors"]["points"][0] and worst <= res["errors"]["points"][1]
    rms, worst = res["errors"]["discs_ao"]                # the shipped ratio keeps it
    assert rms <= bench.TARGET_RMS and worst <= bench.TARGET_WORST, res["errors"]


@pytest.mark.parametrize("name", ["city", "venice", "forest"])
def test_where_discs_miss_the_miss_is_the_spheres_ambient_occlusion(name, shadow_of):
    """The held-out panoramas where discs miss the target: against a truth in which the
    sphere hides only the lights' own pixels the disc model is within the target (the
    light's shape is not what misses); what the sphere hides of the rest of the room is.
    The shipped ratio with the occluder's ambient occlusion (discs + occluder AO) meets
    the target, with under half the discs' RMS."""
    res = shadow_of(name)
    e = res["errors"]
    assert e["discs"][0] > bench.TARGET_RMS or e["discs"][1] > bench.TARGET_WORST
    assert e["discs_vs_lights_only"][0] <= bench.TARGET_RMS
    assert e["discs_vs_lights_only"][1] <= bench.TARGET_WORST
    assert e["ambient_occlusion"][0] > bench.TARGET_RMS
    assert e["discs_ao"][0] <= bench.TARGET_RMS and e["discs_ao"][1] <= bench.TARGET_WORST
    assert e["discs_ao"][0] < e["discs"][0] / 2


def test_sh9_alone_misses_the_sun_shadow(hdri):
    """sky: SH9 alone draws no shadow (RMS above 0.2, worst above 0.75); discs are within the
    RMS target and their worst is half the points' (the sun's penumbra)."""
    res = bench.floor_shadow(hdri("sky"), grid=GRID)
    e = res["errors"]
    assert e["sh9"][0] > 0.2 and e["sh9"][1] > 0.75
    assert e["discs"][0] <= bench.TARGET_RMS and e["discs"][1] < 0.6 * e["points"][1]


@pytest.mark.bench
def test_the_bench_section_writes_its_table_and_picture(tmp_path):
    hdri = tmp_path / "hdri"
    hdri.mkdir()
    for name in ("sky", "city"):
        shutil.copy(HDRI_DIR / f"{name}.exr", hdri / f"{name}.exr")
    r = subprocess.run([sys.executable, "-m", "provider.cli", "bench", "--sections", "shadows",
                        "--quick", "--hdri", str(hdri), "--out", str(tmp_path / "out")],
                       capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert r.returncode == 0, r.stdout + r.stderr
    table = (tmp_path / "out" / "shadows.md").read_text()
    assert "| sky | 1 (" in table and "| city | 0 (none)" in table
    city = next(line for line in table.splitlines() if line.startswith("| city | 0"))
    assert city.endswith("| met |")                   # judged on the shipped ratio
    assert "discs + occluder AO (shipped)" in table
    assert "| 8.5 | " in table                          # the synthetic discs' radii
    png = (tmp_path / "out" / "shadows.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


def test_the_shipped_ratio_meets_the_target_on_every_held_out_panorama(shadow_of):
    """The issue's target (≤ 0.035 RMS and ≤ 0.15 at worst of the shipped ratio: discs +
    occluder AO) on each of the seven held-out panoramas (docs/shadows.md)."""
    for name in bench.HELD_OUT:
        rms, worst = shadow_of(name)["errors"]["discs_ao"]
        assert rms <= bench.TARGET_RMS and worst <= bench.TARGET_WORST, (name, rms, worst)


def test_bridge_is_a_chain_of_discs_whose_streak_beats_one_disc(hdri, shadow_of):
    """bridge's bright region is one thin strip of sky through the zenith (every detection
    level gives the same connected region). It becomes a chain: every light slot holds a
    segment of that one source, and its shadow, a streak, is within the target where one
    disc of the same region (the chain not allowed: one light) misses it."""
    res = shadow_of("bridge")
    e = res["errors"]
    assert res["lights"] == bench.MAX_LIGHTS
    assert e["discs_ao"][0] <= bench.TARGET_RMS and e["discs_ao"][1] <= bench.TARGET_WORST
    assert e["discs_vs_lights_only"][0] <= bench.TARGET_RMS
    one = bench.floor_shadow(hdri("bridge"), grid=GRID, max_lights=1)
    assert one["lights"] == 1 and one["errors"]["discs_ao"][0] > bench.TARGET_RMS
    assert e["discs_ao"][0] < 0.6 * one["errors"]["discs_ao"][0]
    from provider.core.geometry.projections import Equirect
    from provider.core.lights.extractor import LightExtractor
    from provider.core.sh9.engine import compute_sh9
    image = hdri("bridge")
    h, w = image.shape[:2]
    result = compute_sh9(image, lights="auto", max_lights=4, error_estimate=False)
    assert len({light.source for light in result.lights}) == 1
    assert {light.chain for light in result.lights} == {4}
    analysis = LightExtractor(Equirect(w, h), max_lights=4).analyse(np.maximum(image, 0),
                                                                     result.coefficients)
    assert len(analysis.candidates) >= 4 and len({c.group for c in analysis.candidates}) == 1
