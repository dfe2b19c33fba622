"""Issue 41: one MQTT payload must not kill the lux meter. Every payload on ``--lux
mqtt://...`` is read under bounds (size, nesting, digits, 0 … 200,000 lux); a bad one is
counted, logged at most every 10 s and dropped, and the meter takes the next good reading.
Against a real mosquitto broker, in process and through ``shlight serve`` (/healthz)."""
from __future__ import annotations

import json
import logging
import math
import time

import paho.mqtt.client as mqtt
import pytest

from provider.core.errors import InputError
from provider.live.probe import luxmeter
from provider.live.probe.luxmeter import (MAX_LUX, FixedLux, LuxMeter, RefusedReading,
                                         checked_lux, parse_lux_source, parse_payload)
from mqtttools import Mosquitto
from servertools import ServeProcess, health, http_get, poll

from photometrytools import scene, write_bracket

TOPIC = "garden/lux"

#: What a broken sensor, a wrong topic or a hostile publisher may send, each with the words
#: of its one reason. The first two ended paho's network thread before (OverflowError,
#: RecursionError): no later reading was taken.
BAD_PAYLOADS = [
    (b"9" * 401, "a number of 401 characters"),
    (b"[" * 100_000, "a payload of 100,000 bytes"),
    (b"[" * 4000, "nested more than 8 deep"),          # under the size cap: the depth bound
    (b'{"lux": 5, "a": ' + b"[" * 20 + b"]" * 20 + b"}", "nested more than 8 deep"),
    (b"NaN", "NaN is not a number of lux"),
    (b"Infinity", "Infinity is not a number of lux"),
    (b"-Infinity", "-Infinity is not a number of lux"),
    (b"1e400", "1e400 is beyond a double"),
    (b"1e30", "above 200,000"),
    (b'{"lux": 1e30}', "above 200,000"),
    (b"-5", "negative"),
    (b"\xff\xfe\x00\x9c junk", "not UTF-8"),
    (b"1" * (1 << 20), "a payload of 1,048,576 bytes"),
    (b'"1234"', "a string is not a number of lux"),
    (b'{"lux": "1234"}', "a string is not a number of lux"),
    (b'{"lux": true}', "true/false is not a number of lux"),
    (b'{"lux": null}', "null is not a number of lux"),
    (b"[1234]", "an array is not a number of lux"),
    (b'{"temperature": 21.5}', "an object without a lux"),
    (b"", "neither a number nor JSON"),
    (b"12 lux", "neither a number nor JSON"),
    (b'{"lux": 500, "cct": 90}', "CCT"),
    (b'{"lux": 500, "cct": 3200, "duv": 0.5}', "Duv"),
]


@pytest.mark.parametrize("payload, words", BAD_PAYLOADS, ids=lambda v: repr(v[:24]) if
                         isinstance(v, bytes) else None)
def test_each_bad_payload_is_refused_with_one_reason(payload, words):
    with pytest.raises(RefusedReading) as refused:
        parse_payload(payload)
    reason = str(refused.value)
    assert words in reason and "\n" not in reason and len(reason) < 120, reason


def test_good_payloads_read_as_before():
    assert parse_payload(b"1234.5") == (1234.5, None)
    assert parse_payload(b'{"illuminance": 7}') == (7.0, None)
    assert parse_payload(b'{"lux": 0}') == (0.0, None)                  # night is a reading
    assert parse_payload(b'{"lux": 500, "cct": 3200, "duv": 0.002}') == (500.0, (3200.0, 0.002))
    # a Zigbee2MQTT message: other fields, brackets in a string, nesting within the bound
    z2m = {"illuminance_lux": 3100, "battery": 97, "linkquality": 120, "name": "[garden]",
           "update": {"state": "idle", "installed_version": 16777241}}
    assert parse_payload(json.dumps(z2m).encode()) == (3100.0, None)


def test_a_reading_is_bounded_by_what_a_lux_meter_reads():
    assert checked_lux(MAX_LUX) == MAX_LUX and checked_lux(0) == 0.0
    for bad in (MAX_LUX * 1.001, 1e30, -1e-9, math.nan, math.inf, 10 ** 400, True, "5"):
        with pytest.raises(RefusedReading):
            checked_lux(bad)
    meter = LuxMeter("test")
    assert not meter.set(1e30) and meter.lux() is None
    assert meter.errors == 1 and "above 200,000" in meter.health()["last_rejection"]
    with pytest.raises(InputError, match=r"at most 200000 lux, got 1e\+39"):
        FixedLux(1e39)                                  # serve --lux 1e39


def test_refusals_are_logged_at_most_every_ten_seconds(caplog):
    meter = LuxMeter("test")
    started = time.monotonic()
    with caplog.at_level(logging.WARNING, logger="shlight.luxmeter"):
        for _ in range(500):
            meter.refuse("NaN is not a number of lux")
    lines = [r for r in caplog.records if "refused" in r.getMessage()]
    # one line, then one per LOG_EVERY_S the loop took (a loaded machine may take longer)
    assert 1 <= len(lines) <= 1 + (time.monotonic() - started) / luxmeter.LOG_EVERY_S
    assert "NaN is not a number of lux (1 so far)" in lines[0].getMessage()
    assert meter.errors == 500


class _Publisher:
    """A paho client publishing on the broker; QoS 1 so that each payload has reached the
    broker, in order, before the next is sent."""

    def __init__(self, port: int):
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2)
        self.client.connect("127.0.0.1", port)
        self.client.loop_start()

    def send(self, payload) -> None:
        self.client.publish(TOPIC, payload, qos=1).wait_for_publish(timeout=30)

    def until(self, payload, predicate, what: str):
        """Publish ``payload`` again until ``predicate()`` (the meter subscribes late)."""
        def sent_and_seen():
            self.client.publish(TOPIC, payload)
            return predicate()
        return poll(sent_and_seen, timeout=60, interval=0.2, what=what)

    def close(self) -> None:
        self.client.loop_stop()
        self.client.disconnect()


def _flood(publisher: _Publisher, rounds: int) -> int:
    """Every bad payload ``rounds`` times (the 1 MB one once); how many were sent."""
    sent = 0
    for i in range(rounds):
        for payload, _ in BAD_PAYLOADS:
            if len(payload) > 100_000 and i:
                continue
            publisher.send(payload)
            sent += 1
    return sent


def test_a_flood_of_malformed_payloads_leaves_the_meter_reading(tmp_path):
    with Mosquitto(tmp_path) as broker:
        meter = parse_lux_source(f"mqtt://127.0.0.1:{broker.port}/{TOPIC}")
        meter.start()
        publisher = _Publisher(broker.port)
        try:
            publisher.until(b"100", lambda: meter.lux() == 100.0, "the meter's first reading")
            sent = _flood(publisher, rounds=10)
            publisher.send(b'{"lux": 2000}')
            # the thread survived every payload: it takes the good one after them, in order
            poll(lambda: meter.lux() == 2000.0, timeout=60, what="the good reading after "
                 "the flood")
            state = meter.health()
            assert state["state"] == "reading" and state["lux"] == 2000.0
            assert state["rejected"] == sent and state["broker"] == "connected"
            assert state["last_rejection"] == "a Duv that is not a number within ±0.05"
        finally:
            publisher.close()
            meter.stop()


class _BrokenMeter(luxmeter.MqttLuxMeter):
    """A meter whose reading code fails as a bug would (not a refusal): the callback
    boundary must hold it."""

    def on_payload(self, payload: bytes) -> bool:
        if payload == b"bug":
            raise RecursionError("maximum recursion depth exceeded")
        return super().on_payload(payload)


def test_an_error_in_the_callback_never_reaches_paho(tmp_path):
    from provider.live.wire.mqtt_link import parse_mqtt_url
    with Mosquitto(tmp_path) as broker:
        meter = _BrokenMeter(parse_mqtt_url(f"mqtt://127.0.0.1:{broker.port}/{TOPIC}",
                                            "--lux", default_topic=None))
        meter.start()
        publisher = _Publisher(broker.port)
        try:
            publisher.until(b"100", lambda: meter.lux() == 100.0, "the meter's first reading")
            for _ in range(3):
                publisher.send(b"bug")
            publisher.send(b"250")
            poll(lambda: meter.lux() == 250.0, timeout=60, what="the reading after the bugs")
            assert meter.errors == 3
            assert meter.last_error == "RecursionError: maximum recursion depth exceeded"
        finally:
            publisher.close()
            meter.stop()


def test_serve_healthz_shows_the_meter_through_a_flood_and_a_broker_restart(
        camera, tmp_path):  # noqa: F811
    hdr = scene("sky")
    (frame,) = write_bracket(tmp_path, "sun", hdr, (0,), n=8.0, iso=100, ext="jpg")
    with Mosquitto(tmp_path) as broker:
        publisher = _Publisher(broker.port)
        try:
            with ServeProcess("--source", str(frame), "--camera", str(camera), "--lux",
                              f"mqtt://127.0.0.1:{broker.port}/{TOPIC}", "--fps", "5") as proc:
                def meter():
                    return health(proc.http)["probes"]["default"]["meter"]
                poll(lambda: health(proc.http)["probes"]["default"]["state"] == "live",
                     timeout=60, what="the probe to go live")
                first = meter()            # no reading yet: said, and the service degraded
                assert first["state"] == "waiting" and first["lux"] is None
                assert health(proc.http)["status"] == "degraded"
                publisher.until(b"100", lambda: meter()["lux"] == 100.0, "the first reading")
                sent = _flood(publisher, rounds=3)
                publisher.send(b'{"lux": 2000}')
                state = poll(lambda: (m := meter())["lux"] == 2000.0 and m, timeout=60,
                             what="the good reading after the flood in /healthz")
                assert state["state"] == "reading" and state["rejected"] == sent
                assert 0 <= state["age_s"] < state["max_age_s"]
                assert state["broker"] == "connected" and state["readings"] >= 2
                assert state["last_rejection"] == "a Duv that is not a number within ±0.05"

                def latest():
                    status, _, body = http_get(proc.http + "/latest.json")
                    msg = json.loads(body) if status == 200 else {}
                    return msg.get("meter_lux") == pytest.approx(2000.0) and msg
                poll(latest, timeout=60, what="a message closed with the good reading")
                poll(lambda: health(proc.http)["status"] == "ok", timeout=60,
                     what="the service ok with the meter reading")

                broker.stop()              # the broker goes away: said, then it is back
                down = poll(lambda: (m := meter())["broker"] == "down" and m, timeout=60,
                            what="the meter's broker down in /healthz")
                assert down["broker_error"]
                broker.start()
                publisher.until(b"300", lambda: meter()["lux"] == 300.0,
                                "a reading after the broker's restart")
                assert meter()["broker"] == "connected"
            assert "Traceback" not in proc.output, proc.output
            refusals = [line for line in proc.output.splitlines() if "refused:" in line]
            assert refusals and len(refusals) < sent, proc.output   # rate-limited
        finally:
            publisher.close()


def test_serve_refuses_a_fixed_reading_no_meter_reads(camera):  # noqa: F811
    from servertools import run_cli
    p = run_cli("serve", "--source", "demo", "--camera", str(camera), "--lux", "1e39")
    assert p.returncode == 2 and "Traceback" not in p.stderr, p.stderr
    (line,) = p.stderr.strip().splitlines()
    assert "--lux must be a positive number of at most 200000 lux, got 1e+39" in line
