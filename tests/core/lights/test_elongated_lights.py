"""An elongated light (a bridge's slot of sky, a tube lamp) becomes a chain of discs
(provider/core/lights/analysis.py: elongation, chain_count, split_chain; docs/shadows.md,
"Elongated lights"), and a round one stays one light, as before.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from provider.bench.shadows import disc_equirect, strip_equirect
from provider.core.geometry import sh
from provider.core.lights import analysis
from provider.core.lights.tracking import LightTracker
from provider.core.sh9.engine import compute_sh9

TOWARD = np.array([0.3, 0.8, -0.5]) / np.linalg.norm([0.3, 0.8, -0.5])
ALONG = np.array([1.0, 0.0, 0.0]) - TOWARD[0] * TOWARD    # the strip's axis, ⊥ TOWARD
ALONG /= np.linalg.norm(ALONG)
LENGTH, WIDTH = 60.0, 3.0             # degrees: 20 times as long as it is wide


def strip(width: int = 512) -> np.ndarray:
    return strip_equirect(width, LENGTH, WIDTH, TOWARD, ALONG, flux=30.0, background=0.5)


def angle_deg(a, b) -> float:
    return math.degrees(math.acos(min(1.0, abs(float(np.dot(a, b))
                                              / np.linalg.norm(a) / np.linalg.norm(b)))))


def test_a_uniform_strip_has_the_elongation_of_its_sides():
    """elongation() of a uniform L × W strip's pixels: L/W across its sides, L/√12 RMS
    along it; a disc's is 1."""
    rng = np.random.default_rng(3)
    u = rng.uniform(-0.5, 0.5, (20000, 2)) * np.radians([LENGTH / 3, WIDTH])
    t, a = TOWARD, ALONG
    dirs = t + u[:, :1] * a + u[:, 1:] * np.cross(t, a)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    ratio, major, position = analysis.elongation(dirs, np.ones(len(dirs)), t)
    assert ratio == pytest.approx(LENGTH / 3 / WIDTH, rel=0.03)
    assert major == pytest.approx(math.radians(LENGTH / 3) / math.sqrt(12), rel=0.02)
    assert np.corrcoef(position, u[:, 0])[0, 1] ** 2 > 0.999
    r = np.sqrt(rng.uniform(0, 1, 20000)) * math.radians(5)
    p = rng.uniform(0, 2 * math.pi, 20000)
    disc = t + (r * np.cos(p))[:, None] * a + (r * np.sin(p))[:, None] * np.cross(t, a)
    assert analysis.elongation(disc, np.ones(len(disc)), t)[0] == pytest.approx(1.0, abs=0.05)


def test_chain_count_follows_length_over_width_within_the_free_lights():
    px = math.radians(1.4)
    assert analysis.chain_count(1.5, math.radians(10), px, 4) == 1          # round: whole
    assert analysis.chain_count(analysis.ELONGATION - 0.1, math.radians(10), px, 4) == 1
    assert analysis.chain_count(20.0, math.radians(10), px, 4) == 4         # the free lights
    assert analysis.chain_count(20.0, math.radians(10), px, 1) == 1         # none free
    assert analysis.chain_count(5.0, math.radians(10), px, 4) == 4
    assert analysis.chain_count(20.0, math.radians(0.8), px, 4) == 1        # 2 px long: a blob


def test_a_thin_strip_becomes_a_chain_that_keeps_its_flux_centroid_and_irradiance():
    """A uniform 60° × 3° strip with three lights allowed: three segments of one source
    (one key, one candidate), in a row along it 20° apart, each of the radius its own
    20° × 3° piece has; together they hold the whole region's flux, its flux centroid
    and its irradiance on every normal that sees all of it (what the single light gave);
    ambient + the lights' SH9 is still the full SH9."""
    from provider.core.geometry.projections import Equirect
    from provider.core.lights.extractor import LightExtractor
    image = strip()
    a = LightExtractor(Equirect(512, 256), max_lights=3).analyse(
        image, compute_sh9(image, error_estimate=False).coefficients)
    a.rank()
    chosen = a.greedy()
    assert len(chosen) == 1
    chain, whole = a.result(chosen), a.result(chosen, max_lights=1)
    assert len(whole.lights) == 1 and whole.lights[0].chain == 1
    single = whole.lights[0]
    assert len(chain.lights) == 3
    assert {(light.source, light.key, light.level, light.chain) for light in chain.lights} \
        == {(single.source, single.key, single.level, 3)}
    flux = sum(light.flux for light in chain.lights)
    np.testing.assert_allclose(flux, single.flux, rtol=1e-9)
    centroid = sum(float(light.flux @ analysis.LUMA) * light.direction for light in chain.lights)
    # the segments' flux-weighted directions sum to the region's (to the mid pixels' centres)
    assert angle_deg(sum(light.irradiance @ analysis.LUMA * light.direction
                         for light in chain.lights), single.direction) < 1e-6
    assert angle_deg(centroid, single.direction) < 0.5
    assert angle_deg(single.direction, TOWARD) < 0.3
    # in a row along the strip, 20° apart, each a 20° × 3° piece
    offsets = sorted(math.degrees(math.atan2(light.direction @ ALONG, light.direction @ TOWARD))
                     for light in chain.lights)
    np.testing.assert_allclose(np.diff(offsets), LENGTH / 3, atol=1.0)
    piece = math.sqrt(((LENGTH / 3) ** 2 + WIDTH ** 2) / 6)       # √(2·m2) of a uniform piece
    for light in chain.lights:
        assert light.angular_radius_deg == pytest.approx(piece, rel=0.05)
        assert angle_deg(np.cross(TOWARD, ALONG), light.direction) == pytest.approx(90, abs=0.5)
    # irradiance: for normals that see the whole strip the chain gives what the light did
    normals = np.array([TOWARD, (TOWARD + [0, 0.3, 0]) / np.linalg.norm(TOWARD + [0, 0.3, 0])])
    E_chain = sum(np.outer(normals @ light.direction, light.irradiance) for light in chain.lights)
    np.testing.assert_allclose(E_chain, np.outer(normals @ single.direction, single.irradiance),
                               rtol=1e-9)
    # the contract's invariant: ambient + Σ I_k Y(d_k) = the full SH9
    lights_sh = sum(sh.sh_basis(light.direction)[:, None] * light.irradiance[None]
                    for light in chain.lights)
    np.testing.assert_allclose(chain.ambient + lights_sh, a.coefficients, atol=1e-9)
    # and the chain models the strip's irradiance better than one disc did
    assert chain.light_error < 0.5 * whole.light_error


def test_the_chain_takes_only_the_lights_left_free():
    """Two lights allowed: the strip becomes two segments; four: four."""
    image = strip()
    for k in (2, 4):
        lights = compute_sh9(image, lights="auto", max_lights=k, error_estimate=False).lights
        assert len(lights) == k and {light.chain for light in lights} == {k}


def test_a_round_disc_is_not_split():
    """A uniform 8.5° disc (a softbox) with four lights allowed is one light of its radius."""
    lights = compute_sh9(disc_equirect(512, 8.5), lights="auto", max_lights=4,
                         error_estimate=False).lights
    assert len(lights) == 1 and lights[0].chain == 1
    assert lights[0].angular_radius_deg == pytest.approx(8.5, rel=0.02)


def test_live_the_tracker_keeps_the_chain_and_its_key():
    """Through the tracker (hysteresis), frame after frame: the same three segments under
    one key, and at most the tracker's own max_lights."""
    from provider.core.geometry.projections import Equirect
    from provider.core.lights.extractor import LightExtractor
    image = strip()
    x = LightExtractor(Equirect(512, 256), max_lights=3)
    coefficients = compute_sh9(image, error_estimate=False).coefficients
    tracker = LightTracker()
    first = x.extract(image, coefficients, tracker=tracker)
    second = x.extract(image, coefficients, tracker=tracker)
    assert len(first.lights) == len(second.lights) == 3
    assert len({light.key for light in second.lights}) == 1
    assert [light.key for light in first.lights] == [light.key for light in second.lights]
    narrow = LightTracker(max_lights=2)
    assert len(x.extract(image, coefficients, tracker=narrow).lights) == 2


@pytest.mark.parametrize("along", [(1.0, 0.0, 0.0), (0.1, 1.0, 0.0)])
def test_a_chain_is_ordered_along_a_fixed_sense(along):
    """The segments of a chain come in a fixed sense of the world frame, not of the axis's
    arbitrary sign: toward increasing azimuth (Y × d) for a strip lying east-west, upward
    for one lying up-down; so the wire slots of a chain do not swap between frames."""
    t = TOWARD
    a = np.asarray(along) - (np.asarray(along) @ t) * t
    a /= np.linalg.norm(a)
    lights = compute_sh9(strip_equirect(512, LENGTH, WIDTH, t, a, flux=30.0, background=0.5),
                         lights="auto", max_lights=3, error_estimate=False).lights
    assert len(lights) == 3
    east = np.array([t[2], 0.0, -t[0]])
    key = east if abs(a @ east) / np.linalg.norm(east) >= 0.5 else np.array([0.0, 1.0, 0.0])
    steps = [float((q.direction - p.direction) @ key) for p, q in zip(lights, lights[1:])]
    assert all(step > 0 for step in steps), steps


def test_a_chain_served_whole_reports_the_error_of_what_is_served():
    """A 60° × 4° strip and a 3° disc with two lights allowed: the strip may be a chain
    but no light is left free, so it is served whole (chain 1). The reported light_error
    after the engine's processing of the ambient (here order-1 truncation) is the exact
    error of the lights served plus the processed ambient, not that of the chain the
    strip could have been."""
    from provider.core.geometry.projections import Equirect
    from provider.core.lights.extractor import LightExtractor
    image = (strip_equirect(512, LENGTH, 4.0, TOWARD, ALONG, flux=30.0, background=0.5)
             + disc_equirect(512, 3.0, toward=(-0.6, 0.3, 0.7), flux=30.0, background=0.0))
    coefficients = compute_sh9(image, error_estimate=False).coefficients
    x = LightExtractor(Equirect(512, 256), max_lights=2)
    served = x.extract(image, coefficients, process=lambda c: sh.truncate_order(c, 1))
    a = x.analyse(image, coefficients)
    assert len(served.lights) == 2 and {light.chain for light in served.lights} == {1}
    assert max(a.candidates[light.source].most_segments for light in served.lights) > 1
    # exact: the processed ambient's irradiance + each served light as a directional light
    E = sh.irradiance(served.ambient, x.normals) + analysis.model_irradiance(
        np.zeros((9, 3)), served.lights, x.normals)
    exact = math.sqrt(float(np.sum((E - a.truth) ** 2)) / float(np.sum(a.truth ** 2)))
    assert served.light_error == pytest.approx(exact, rel=1e-6)
