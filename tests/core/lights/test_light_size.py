"""Each light's angular radius (docs/contract.md §10, ``Light.angular_radius_deg``): the
radius of the uniform disc that casts its shadows, measured from the light's own pixels,
and carried everywhere lights go: the wire (``light_angular_radius_deg``), the schema, the
temporal filter, the relay, the exports that have a field for it, ``/latest.json`` and MQTT
(real servers and a real mosquitto on loopback; nothing asserts a duration).

Synthetic discs of known radius are drawn into equirects with exact coverage (16
sub-samples per pixel), on a dim uniform background, at several sizes.
"""
from __future__ import annotations

import json
import math
import os

import jsonschema
import numpy as np
import pytest

from provider.core.conventions import formats as cv
from provider.core.geometry import sh
from provider.core.lights.analysis import Light, angular_radius_deg
from provider.core.sh9.engine import SH9Result, compute_sh9
from provider.live.probe.temporal import LightingFilter
from provider.live.sources.relay import relayed_lights
from provider.live.wire.export import export_message
from provider.live.wire.message import coefficient_message, load_schema

from conftest import HDRI_DIR, HDRI_NAMES
from mqtttools import MOSQUITTO, Mosquitto, Subscriber
from servertools import ServeProcess, http_get, poll, run_cli

VALIDATOR = jsonschema.Draft202012Validator(load_schema())
SKY = str(HDRI_DIR / "sky.exr")
TOWARD = np.array([0.3, 0.8, -0.5]) / np.linalg.norm([0.3, 0.8, -0.5])


def disc_equirect(width: int, radius_deg: float, flux: float = 30.0, toward=TOWARD,
                  background: float = 0.5, sub: int = 4) -> np.ndarray:
    """(width/2, width, 3) float32: a uniform disc of ``radius_deg`` about ``toward`` (total
    flux ``flux`` in radiance × sr, slightly warm) on a uniform background; each pixel holds
    the disc's exact share of it (sub × sub samples)."""
    h = width // 2
    py, px = np.mgrid[0:h * sub, 0:width * sub] + 0.5
    theta, phi = math.pi * py / (h * sub), 2 * math.pi * (px / (width * sub) - 0.5)
    d = np.stack([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)], -1)
    inside = (d @ toward) >= math.cos(math.radians(radius_deg))
    cover = inside.reshape(h, sub, width, sub).mean(axis=(1, 3))
    radiance = flux / (2 * math.pi * (1 - math.cos(math.radians(radius_deg))))
    return (background + cover[..., None] * radiance * np.array([1.0, 0.9, 0.8])).astype(np.float32)


def the_light(image) -> Light:
    r = compute_sh9(image, lights="auto")
    assert len(r.lights) == 1
    light = r.lights[0]
    assert math.degrees(math.acos(min(1.0, light.direction @ TOWARD))) < 0.3
    return light


# ---- the measure --------------------------------------------------------------------------------

def test_a_uniform_disc_has_mean_squared_angle_a2_over_2():
    """The definition: a uniform disc of radius a sampled finely (a pixel's footprint 0) gives
    back a; a point in one pixel gives 0 once that pixel's footprint is removed."""
    a = math.radians(5.0)
    r = np.sqrt(np.random.default_rng(1).uniform(0, 1, 200_000)) * a   # uniform in the disc
    assert angular_radius_deg(np.ones_like(r), r, np.zeros_like(r)) == pytest.approx(5.0, rel=3e-3)
    assert angular_radius_deg([1.0], [0.0], [1e-4]) == 0.0
    assert angular_radius_deg([0.0], [0.1], [0.0]) == 0.0


@pytest.mark.parametrize("width", [256, 512, 1024])
@pytest.mark.parametrize("radius", [1.0, 3.0, 9.0, 20.0])
def test_discs_of_known_radius_are_recovered(width, radius):
    """A disc at least a pixel across: its radius within 2 % or 0.1 of a pixel (measured:
    −1 % at 20°: pixels at the rim, partly covered, are weighted by their excess over the
    detection level, a little less than their flux)."""
    pixel = 360.0 / width
    got = the_light(disc_equirect(width, radius)).angular_radius_deg
    assert abs(got - radius) <= max(0.02 * radius, 0.1 * pixel), (width, radius, got)


def test_a_sun_is_small_and_a_softbox_is_about_nine_degrees():
    """A sun (0.27°, a flux of 60 against a background of 6): within half a pixel of its
    radius at every size, so a point (0) where pixels are larger than it (0.7° at 512) and
    0.27° within 0.03° at 2048. A 60 cm softbox at 2 m (8.5°): 8.5° within 2 %."""
    for width in (512, 1024, 2048):
        got = the_light(disc_equirect(width, 0.27, flux=60.0, sub=2 if width > 1024 else 4))
        assert abs(got.angular_radius_deg - 0.27) <= 0.5 * 360.0 / width, (width, got)
    sun = the_light(disc_equirect(2048, 0.27, flux=60.0, sub=2))
    assert sun.angular_radius_deg == pytest.approx(0.27, abs=0.03)
    box = math.degrees(math.atan(0.3 / 2.0))
    assert the_light(disc_equirect(512, box)).angular_radius_deg == pytest.approx(box, rel=0.02)


def test_the_nine_panoramas_give_sizes_that_fit_their_lights(hdri):
    """What the shared panoramas give (docs/shadows.md lists them): sky's sun is the
    smallest light (its 512×256 copy blurs the 0.27° sun over about a degree), every radius
    is under 30° and above its light's RMS spread (a disc's radius is √2 × its RMS angle,
    less the footprint)."""
    radii = {}
    for name in HDRI_NAMES:
        for light in compute_sh9(hdri(name), lights="auto").lights:
            radii.setdefault(name, []).append(light.angular_radius_deg)
            assert 0 < light.angular_radius_deg < 30
            assert light.angular_radius_deg <= math.sqrt(2) * light.spread_deg + 1e-9
    assert min(min(v) for v in radii.values()) == min(radii["sky"]) < 2.0
    assert max(radii["sky"]) < 2.0 and min(min(v) for k, v in radii.items() if k != "sky") > 5


# ---- on the wire ----------------------------------------------------------------------------

def _result(lights):
    ambient = np.zeros((9, 3))
    ambient[0] = 1.0
    full = ambient + sum((np.outer(sh.sh_basis(light.direction), light.irradiance)
                          for light in lights), np.zeros((9, 3)))
    return SH9Result(full, sh.irradiance_matrices(full), {}, lights, ambient)


def _light(direction, irradiance, radius, key=0):
    d = np.asarray(direction, np.float64)
    e = np.asarray(irradiance, np.float64)
    return Light(d / np.linalg.norm(d), e, e, 1.0, 4.0, key=key, angular_radius_deg=radius)


def test_messages_carry_one_radius_per_light_and_validate():
    msg = coefficient_message(compute_sh9(disc_equirect(512, 9.0), lights="auto"))
    VALIDATOR.validate(msg)
    assert msg["lights"] == 1 and msg["light_angular_radius_deg"][0] == pytest.approx(9.0, rel=0.02)
    none = coefficient_message(compute_sh9(disc_equirect(256, 9.0)))
    VALIDATOR.validate(none)
    assert none["lights"] == 0 and none["light_angular_radius_deg"] == []
    bad = dict(msg, light_angular_radius_deg=[-1.0])
    with pytest.raises(jsonschema.ValidationError):
        VALIDATOR.validate(bad)


def test_compute_prints_the_radius():
    res = run_cli("compute", SKY, "--lights", "auto")
    assert res.returncode == 0, res.stderr
    msg = json.loads(res.stdout)
    assert len(msg["light_angular_radius_deg"]) == msg["lights"] == 1
    assert 0 < msg["light_angular_radius_deg"][0] < 2


def test_the_temporal_filter_smooths_the_radius_like_the_irradiance():
    f = LightingFilter(time_constant=1.0, snap=0.5)
    f.update_result(_result([_light([1, 1, 0], [5, 5, 4], 2.0)]), 0.0)
    out, snapped = f.update_result(_result([_light([1, 1, 0], [5, 5, 4], 4.0)]), 0.1)
    w = 1 - math.exp(-0.1)
    assert not snapped
    assert out.lights[0].angular_radius_deg == pytest.approx(2.0 + w * 2.0)


def test_the_relay_keeps_the_radius_and_reads_an_old_upstream_as_points():
    msg = coefficient_message(_result([_light([0, 1, 0], [2, 2, 2], 3.5),
                                       _light([1, 0, 0], [1, 1, 1], 0.0, key=1)]))
    lights, _, note = relayed_lights(msg)
    assert [light.angular_radius_deg for light in lights] == [3.5, 0.0] and note is None
    old = {k: v for k, v in msg.items() if k != "light_angular_radius_deg"}
    assert [light.angular_radius_deg for light in relayed_lights(old)[0]] == [0.0, 0.0]
    lights, _, note = relayed_lights(dict(msg, light_angular_radius_deg=[]))
    assert "point lights" in note
    for bad, words in (([1.0], "holds 1 values"), ([1.0, 91.0], "above 90"),
                       ([1.0, "x"], "not a number")):
        with pytest.raises(ValueError, match=words):
            relayed_lights(dict(msg, light_angular_radius_deg=bad))


def test_exports_carry_it_where_the_format_has_a_field():
    """unity: mainLight.angularDiameter (HDRP's, degrees) = 2 × the key light's radius;
    glTF's KHR_lights_punctual has no field, so the gltf export has none."""
    msg = coefficient_message(_result([_light([0, 1, 0], [1, 1, 1], 1.0),
                                       _light([1, 1, 0], [5, 5, 5], 4.5, key=1)]))
    unity = export_message(msg, "unity")
    assert unity["mainLight"]["angularDiameter"] == 9.0
    gltf = export_message(msg, "gltf")
    assert "angular" not in json.dumps(gltf["KHR_lights_punctual"]).lower()
    old = {k: v for k, v in msg.items() if k != "light_angular_radius_deg"}
    assert "angularDiameter" not in export_message(old, "unity")["mainLight"]
    with pytest.raises(cv.InputError, match="2 numbers"):
        export_message(dict(msg, light_angular_radius_deg=[1.0, 2.0, 3.0]), "unity")


@pytest.mark.skipif(not os.path.exists(MOSQUITTO), reason="no mosquitto (apt-get install mosquitto)")
def test_latest_json_and_mqtt_pass_the_radius_through(tmp_path):
    """`shlight serve --lights auto --mqtt ...` on sky: /latest.json, the retained MQTT
    payload and `shlight compute` agree on the light's radius; /latest.json?to=unity carries
    it as angularDiameter."""
    ref = json.loads(run_cli("compute", SKY, "--lights", "auto").stdout)
    with Mosquitto(tmp_path) as broker, \
            ServeProcess("--probe", f"sky={SKY}", "--probe-args", "sky=--keepalive 60",
                         "--lights", "auto",
                         "--mqtt", f"mqtt://127.0.0.1:{broker.port}/site") as proc:
        poll(lambda: http_get(f"{proc.http}/latest.json?probe=sky")[0] == 200, timeout=30,
             what="the sky probe's lighting")
        # /latest.json can answer before the publisher's first message reaches the broker;
        # a subscription made before it gets it live (retain flag 0), one after, retained
        with Subscriber(broker.port, "site/#") as early:            # the broker has it now
            early.first("site/sky")
        with Subscriber(broker.port, "site/#") as sub:
            payload = json.loads(sub.retained("site/sky"))
        status, _, body = http_get(f"{proc.http}/latest.json?probe=sky")
        latest = json.loads(body)
        status_u, _, body_u = http_get(f"{proc.http}/latest.json?probe=sky&to=unity")
    assert status == status_u == 200
    for msg in (payload, latest):
        VALIDATOR.validate(msg)
        assert msg["light_angular_radius_deg"] == pytest.approx(ref["light_angular_radius_deg"],
                                                                rel=1e-9)
    assert json.loads(body_u)["mainLight"]["angularDiameter"] == pytest.approx(
        2 * ref["light_angular_radius_deg"][0], rel=1e-9)
