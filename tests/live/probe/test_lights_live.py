"""Lights in the live service (docs/contract.md §10): the probe's tracker, smoothing and the change
gate, the relay, and the messages real clients receive (real servers on loopback, see
tests/servertools.py; nothing asserts a duration)."""
from __future__ import annotations

import os
from pathlib import Path

import jsonschema
import numpy as np
import pytest

from provider.core.geometry import sh
from provider.core.sh9.engine import SH9Result
from provider.core.lights.analysis import Light
from provider.live.wire.message import load_schema
from provider.live.probe.temporal import ChangeGate, LightingFilter, light_model

import reference as ref
from servertools import ServerThread, connect, recv_json, recv_until, run_cli

HDRI = os.path.join(str(Path(__file__).resolve().parents[2]), "data", "hdri")
SKY = os.path.join(HDRI, "sky.exr")
BRIDGE = os.path.join(HDRI, "bridge.exr")
VALIDATOR = jsonschema.Draft202012Validator(load_schema())


def sh9(msg: dict) -> bool:
    return msg.get("type") == "sh9"


def check_lights(msg: dict) -> None:
    """Schema-valid, and the §10 fields consistent: 3k numbers each, unit directions, and
    ambient + the lights' SH9 projection = the full coefficients."""
    VALIDATOR.validate(msg)
    k = msg["lights"]
    d = np.reshape(msg["light_directions"], (k, 3))
    irr = np.reshape(msg["light_irradiance"], (k, 3))
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-9)
    ambient = np.reshape(msg["ambient_coefficients"], (9, 3))
    full = ambient + sum((np.outer(ref.basis(dk), Ik) for dk, Ik in zip(d, irr)), np.zeros((9, 3)))
    coeffs = np.reshape(msg["coefficients"], (9, 3))
    assert np.abs(full - coeffs).max() <= 1e-9 * np.abs(coeffs).max()
    np.testing.assert_allclose(np.reshape(msg["ambient_matrices"], (3, 4, 4)),
                               sh.irradiance_matrices(ambient), rtol=1e-12, atol=1e-12)


def test_demo_messages_carry_lights_that_follow_the_scene():
    """`shlight serve --lights auto --max-lights 2` on the demo: every message carries the
    §10 fields, schema-valid and consistent; the sun is a light throughout and the lamp
    comes and goes as it switches."""
    with ServerThread("--source", "demo", "--lights", "auto", "--max-lights", "2",
                      "--change-threshold", "0") as srv:
        with connect(srv.url) as ws:
            assert recv_json(ws)["type"] == "hello"
            counts = []
            for _ in range(150):          # ~5 s of the demo: the lamp switches at least once
                msg = recv_until(ws, sh9)
                check_lights(msg)
                assert msg["light_error"] < msg["sh9_error"]
                counts.append(msg["lights"])
    assert min(counts) >= 1 and {1, 2} <= set(counts)


def test_a_still_image_gets_its_lights_in_the_first_message():
    """A served image: the first message has the lights `shlight compute` prints (the tracker
    starts with the per-frame choice: there is no history to be stable against)."""
    res = run_cli("compute", SKY, "--lights", "auto")
    assert res.returncode == 0, res.stderr
    import json
    ref_msg = json.loads(res.stdout)
    with ServerThread("--source", SKY, "--fps", "5", "--lights", "auto") as srv:
        with connect(srv.url) as ws:
            recv_json(ws)
            msg = recv_until(ws, sh9)
            check_lights(msg)
            assert msg["lights"] == ref_msg["lights"] == 1
            for k in ("light_directions", "light_irradiance", "ambient_coefficients"):
                np.testing.assert_allclose(msg[k], ref_msg[k], rtol=1e-12, atol=1e-12)


def test_without_lights_messages_say_none_and_carry_the_full_sh9():
    with ServerThread("--source", BRIDGE, "--fps", "5") as srv:
        with connect(srv.url) as ws:
            recv_json(ws)
            msg = recv_until(ws, sh9)
            check_lights(msg)
            assert msg["lights"] == 0 and msg["light_directions"] == []
            assert msg["ambient_coefficients"] == msg["coefficients"]
            assert "light_error" not in msg


def test_relay_passes_the_lights_on():
    with ServerThread("--probe", f"edge={SKY}", "--fps", "5", "--lights", "auto") as up:
        with connect(up.url) as ws_up:
            recv_json(ws_up)
            upstream = recv_until(ws_up, sh9)
        with ServerThread("--probe", f"pc={up.url}?probe=edge") as pc, connect(pc.url) as ws:
            recv_json(ws)
            msg = recv_until(ws, lambda m: sh9(m) and not m["stale"], timeout=20)
            check_lights(msg)
            assert msg["source"] == "relay" and msg["lights"] == upstream["lights"] == 1
            for k in ("light_directions", "light_irradiance", "ambient_coefficients",
                      "light_error"):
                assert msg[k] == upstream[k], k


# ---- smoothing and the change gate --------------------------------------------------------------

def _result(ambient, lights):
    """An SH9Result whose full SH9 is ambient + the lights' projection (like the engine's)."""
    full = ambient + sum((np.outer(sh.sh_basis(l.direction), l.irradiance) for l in lights),
                        np.zeros((9, 3)))
    return SH9Result(full, sh.irradiance_matrices(full), {}, lights, ambient)


def _light(direction, irradiance, key):
    d = np.asarray(direction, np.float64)
    return Light(d / np.linalg.norm(d), np.asarray(irradiance, np.float64),
                 np.asarray(irradiance, np.float64), 1.0, 4.0, key=key)


def test_smoothing_moves_lights_smoothly_and_snaps_when_the_set_changes():
    """Same lights (keys): direction and irradiance move by the smoothing weight, like the
    coefficients. Another set (a light appears, goes or is swapped): everything snaps to
    the new frame in that frame, never a blend of two sets."""
    ambient = np.zeros((9, 3))
    ambient[0] = 2.0
    sun0 = _light([1, 1, 0], [5, 5, 4], key=0)
    sun1 = _light([1, 1, 0.1], [5.2, 5.2, 4.2], key=0)
    f = LightingFilter(time_constant=1.0, snap=0.5)
    out, snapped = f.update_result(_result(ambient, [sun0]), 0.0)
    assert snapped and out.lights[0].direction.tolist() == sun0.direction.tolist()
    out, snapped = f.update_result(_result(ambient * 1.01, [sun1]), 0.1)
    assert not snapped
    w = 1 - np.exp(-0.1)
    np.testing.assert_allclose(out.lights[0].irradiance,
                               sun0.irradiance + w * (sun1.irradiance - sun0.irradiance))
    d = out.lights[0].direction
    assert np.linalg.norm(d) == pytest.approx(1.0)
    moved = np.degrees(np.arccos(min(1.0, d @ sun0.direction)))
    assert 0 < moved < np.degrees(np.arccos(sun1.direction @ sun0.direction))
    np.testing.assert_allclose(out.ambient_coefficients, ambient * (1 + 0.01 * w))
    lamp = _light([-1, 0.2, 0], [3, 1, 0.3], key=1)
    new = _result(ambient * 1.01, [sun1, lamp])           # a lamp switched on: a new light
    out, snapped = f.update_result(new, 0.2)
    assert snapped and len(out.lights) == 2
    np.testing.assert_array_equal(out.coefficients, new.coefficients)
    np.testing.assert_array_equal(out.ambient_coefficients, new.ambient_coefficients)
    out, snapped = f.update_result(_result(ambient * 1.01, [sun1]), 0.3)   # and off again
    assert snapped and len(out.lights) == 1


def test_the_change_gate_notices_a_change_only_the_lights_show():
    """The full SH9 unchanged, but its split into ambient + lights changed (a light taken
    out of the ambient): that is a new message."""
    ambient = np.zeros((9, 3))
    ambient[0] = 2.0
    sun = _light([0, 1, 0], [4, 4, 4], key=0)
    with_sun = _result(ambient, [sun])
    in_ambient = SH9Result(with_sun.coefficients, with_sun.matrices, {}, [], with_sun.coefficients)
    g = ChangeGate(0.002, keepalive=10.0)
    g.mark_sent(in_ambient.coefficients, 0.0, light_model(in_ambient))
    assert not g.changed(in_ambient.coefficients, light_model(in_ambient))
    assert g.changed(with_sun.coefficients, light_model(with_sun))
    g.mark_sent(with_sun.coefficients, 0.1, light_model(with_sun))
    brighter = _result(ambient - 0.0, [_light([0, 1, 0], [4.4, 4.4, 4.4], key=0)])
    assert g.changed(brighter.coefficients, light_model(brighter))
    # lights off: the gate behaves exactly as before (coefficients only)
    plain = SH9Result(with_sun.coefficients, with_sun.matrices, {})
    assert light_model(plain) is None
