"""``shlight serve --mqtt``: publishing to a real mosquitto on loopback (docs/contract.md §11).

Topic PREFIX/PROBE, payload exactly the wire JSON, retained, QoS 0; a late subscriber gets
the latest lighting at once; the broker stopping, restarting or not reading never stops
the WebSocket clients, and publishing resumes by itself. Nothing asserts a duration.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
import signal

import jsonschema
import pytest

from provider.live.wire.message import load_schema

from mqtttools import MOSQUITTO, MOSQUITTO_PASSWD, Mosquitto, PausableRelay, Subscriber
from servertools import (ServeProcess, connect, health, http_get, poll, recv_json,
                         recv_until, run_cli)

pytestmark = pytest.mark.skipif(not os.path.exists(MOSQUITTO),
                                reason="no mosquitto (apt-get install mosquitto)")

HDRI = os.path.join(str(Path(__file__).resolve().parents[1]), "data", "hdri")
BRIDGE = os.path.join(HDRI, "bridge.exr")
VALIDATOR = jsonschema.Draft202012Validator(load_schema())


def sh9(msg: dict) -> bool:
    return msg.get("type") == "sh9"


def mqtt_metric(base: str, name: str) -> float:
    status, _, body = http_get(base + "/metrics")
    assert status == 200
    for line in body.decode().splitlines():
        if line.startswith(name + "{"):
            return float(line.rpartition(" ")[2])
    raise AssertionError(f"no {name} in /metrics")


def keep_reading(ws, count: int, after_seq: int) -> int:
    """Read until ``count`` sh9 messages newer than ``after_seq`` arrived, in order; the
    last seq."""
    last = after_seq
    for _ in range(count):
        msg = recv_until(ws, lambda m: sh9(m) and m["seq"] > last, timeout=10,
                         what="fresh lighting over WebSocket")
        last = msg["seq"]
    return last


def test_late_subscriber_gets_the_retained_latest_lighting(tmp_path):
    with Mosquitto(tmp_path) as broker, \
            ServeProcess("--probe", "room=demo", "--probe", f"desk={BRIDGE}",
                         "--probe-args", "desk=--keepalive 60",
                         "--mqtt", f"mqtt://127.0.0.1:{broker.port}/site/floor-1") as proc:
        poll(lambda: all(http_get(f"{proc.http}/latest.json?probe={p}")[0] == 200
                         for p in ("room", "desk")), timeout=30, what="lighting of both probes")
        with Subscriber(broker.port, "site/floor-1/#") as early:   # the broker has them now
            early.first("site/floor-1/desk")
            early.first("site/floor-1/room")
        assert mqtt_metric(proc.http, "shlight_mqtt_connected") == 1
        h = health(proc.http)["mqtt"]
        assert h["state"] == "connected" and h["prefix"] == "site/floor-1"
        assert h["broker"] == f"mqtt://127.0.0.1:{broker.port}/site/floor-1"
        # A subscriber that comes late gets each probe's latest lighting at once, retained.
        with Subscriber(broker.port, "site/floor-1/#") as late:
            payload = late.retained("site/floor-1/desk")
            status, _, latest = http_get(proc.http + "/latest.json?probe=desk")
            assert status == 200 and payload == latest          # exactly the wire JSON
            msg = json.loads(payload)
            VALIDATOR.validate(msg)
            assert msg["probe"] == "desk" and msg["stale"] is False
            payload = late.retained("site/floor-1/room")
            assert json.loads(payload)["probe"] == "room"
            # ... then the live messages, newer and newer.
            first = json.loads(payload)["seq"]
            poll(lambda: (late.latest_seq("site/floor-1/room") or 0) > first + 5,
                 what="live messages on site/floor-1/room")
        # The same bytes go to WebSocket clients.
        with connect(proc.url + "?probe=desk") as ws:
            recv_json(ws)
            text = ws.recv(timeout=10)
            assert text.encode() == latest
    assert "Traceback" not in proc.output


def test_broker_down_and_back(tmp_path):
    broker = Mosquitto(tmp_path).start()
    try:
        with ServeProcess("--source", "demo", "--change-threshold", "0", "--reconnect-max", "1",
                          "--mqtt", f"mqtt://127.0.0.1:{broker.port}/lab") as proc, \
                connect(proc.url) as ws:
            poll(lambda: mqtt_metric(proc.http, "shlight_mqtt_connected") == 1, timeout=30,
                 what="MQTT connected")
            recv_json(ws)
            last = keep_reading(ws, 5, -1)
            broker.stop()                                       # the broker goes away
            poll(lambda: mqtt_metric(proc.http, "shlight_mqtt_connected") == 0, timeout=30,
                 what="the broker to be seen down")
            h = health(proc.http)
            assert h["status"] == "degraded" and h["mqtt"]["state"] == "down"
            assert h["mqtt"]["error"]
            # WebSocket clients do not notice: fresh lighting keeps coming, in order.
            last = keep_reading(ws, 30, last)
            published = mqtt_metric(proc.http, "shlight_mqtt_messages_published_total")
            broker.start()                                      # back, without retained state
            poll(lambda: mqtt_metric(proc.http, "shlight_mqtt_connects_total") == 2,
                 timeout=30, what="reconnected to the broker")
            assert health(proc.http)["mqtt"]["state"] == "connected"
            seq_back = last
            with Subscriber(broker.port, "lab/default") as late:
                _, payload = late.first("lab/default")
                assert json.loads(payload)["seq"] >= seq_back
            assert mqtt_metric(proc.http, "shlight_mqtt_messages_published_total") > published
            keep_reading(ws, 5, last)
        assert proc.proc.returncode == 0 and "Traceback" not in proc.output, proc.output
        assert "MQTT: lost" in proc.output and "WebSocket clients are not affected" in proc.output
    finally:
        broker.stop()


def test_a_broker_that_stops_reading_delays_nobody(tmp_path):
    """The link to the broker backs up (it stops reading): WebSocket clients keep their
    full stream, the publisher keeps only the newest message per probe (skips the rest),
    and when the broker reads again it gets the current lighting, not a backlog."""
    with Mosquitto(tmp_path) as broker:
        relay = PausableRelay(broker.port)
        try:
            with ServeProcess("--source", "demo", "--fps", "60", "--change-threshold", "0",
                              "--mqtt", f"mqtt://127.0.0.1:{relay.port}/slow") as proc, \
                    connect(proc.url) as ws:
                poll(lambda: mqtt_metric(proc.http, "shlight_mqtt_connected") == 1,
                     timeout=30, what="MQTT connected")
                recv_json(ws)
                last = keep_reading(ws, 5, -1)
                relay.paused.set()
                skipped0 = mqtt_metric(proc.http, "shlight_mqtt_messages_skipped_total")
                # Read over WebSocket until the publisher has had to skip messages.
                for _ in range(100):
                    last = keep_reading(ws, 10, last)
                    if mqtt_metric(proc.http, "shlight_mqtt_messages_skipped_total") > \
                            skipped0 + 20:
                        break
                else:
                    raise AssertionError("the publisher never backed off")
                last = keep_reading(ws, 30, last)               # and WebSocket goes on
                relay.paused.clear()
                resumed_at = last
                with Subscriber(broker.port, "slow/default") as late:
                    poll(lambda: (late.latest_seq("slow/default") or -1) >= resumed_at,
                         timeout=30, what="current lighting through the broker again")
                assert mqtt_metric(proc.http, "shlight_mqtt_connected") == 1
            assert "Traceback" not in proc.output
        finally:
            relay.close()


@pytest.mark.skipif(not os.path.exists(MOSQUITTO_PASSWD), reason="no mosquitto_passwd")
def test_mqtts_with_a_private_ca_and_a_password(tmp_path):
    from tlstools import make_certificate
    cert, key = make_certificate(tmp_path)
    with Mosquitto(tmp_path, tls=(cert, key), users={"lamp": "p@ss word"}) as broker:
        url = f"mqtts://lamp:p%40ss%20word@localhost:{broker.port}/secure"
        with ServeProcess("--source", BRIDGE, "--mqtt", url, "--mqtt-ca", str(cert)) as proc:
            poll(lambda: mqtt_metric(proc.http, "shlight_mqtt_connected") == 1, timeout=30,
                 what="connected over TLS")
            assert health(proc.http)["mqtt"]["broker"] == \
                f"mqtts://lamp@localhost:{broker.port}/secure"   # no password shown
            # The broker holds the lighting once a subscriber has seen it go through (before
            # that, "connected" may come before the first frame is lit: nothing retained yet).
            with Subscriber(broker.port, "secure/#", tls_ca=cert, username="lamp",
                            password="p@ss word", host="localhost") as early:
                early.first("secure/default")
            with Subscriber(broker.port, "secure/#", tls_ca=cert, username="lamp",
                            password="p@ss word", host="localhost") as late:
                payload = late.retained("secure/default")
                assert json.loads(payload)["probe"] == "default"
            assert "p@ss" not in proc.output and "p%40ss" not in proc.output
        # A wrong password: refused, said so, and WebSocket clients are served anyway.
        with ServeProcess("--source", BRIDGE, "--mqtt", url.replace("word@", "wrong@"),
                          "--mqtt-ca", str(cert)) as proc:
            poll(lambda: "refused" in health(proc.http)["mqtt"]["error"], timeout=30,
                 what="the refusal to be reported")
            assert mqtt_metric(proc.http, "shlight_mqtt_connected") == 0
            with connect(proc.url) as ws:
                recv_json(ws)
                assert recv_until(ws, sh9)["probe"] == "default"
            proc.proc.send_signal(signal.SIGTERM)
            assert proc.proc.wait(30) == 0, proc.output


@pytest.mark.parametrize("argv, words", [
    (["--mqtt", "http://127.0.0.1/x"], "expected mqtt://"),
    (["--mqtt", "mqtt:///prefix"], "no broker host"),
    (["--mqtt", "mqtt://127.0.0.1:99999/p"], "out of range"),
    (["--mqtt", "mqtt://127.0.0.1/a/+/b"], "may not contain"),
    (["--mqtt", "mqtt://127.0.0.1/a?x=1"], "no ?query"),
    (["--mqtt-ca", "/etc/hostname"], "--mqtt-ca needs --mqtt"),
    (["--mqtt", "mqtt://127.0.0.1/p", "--mqtt-ca", "/etc/hostname"], "for mqtts://"),
    (["--mqtt", "mqtts://127.0.0.1/p", "--mqtt-ca", "/no/such.pem"], "--mqtt-ca /no/such.pem"),
])
def test_bad_mqtt_options_are_one_line(argv, words):
    res = run_cli("serve", *argv)
    assert res.returncode == 2 and "Traceback" not in res.stderr, res.stderr
    last = res.stderr.strip().splitlines()[-1]
    assert last.startswith("shlight serve: error:") and words in last, res.stderr


def test_dashboard_shows_the_mqtt_state(tmp_path):
    dashboard = pytest.importorskip("test_dashboard")
    from browsertools import ARGS
    if dashboard.sync_playwright is None or not os.path.exists(dashboard.CHROMIUM):
        pytest.skip("needs playwright and chromium (see tests/live/server/test_dashboard.py)")
    broker = Mosquitto(tmp_path).start()
    try:
        with ServeProcess("--source", "demo", "--reconnect-max", "1",
                          "--mqtt", f"mqtt://127.0.0.1:{broker.port}/dash") as proc, \
                dashboard.sync_playwright() as pw:
            browser = pw.chromium.launch(executable_path=dashboard.CHROMIUM,
                                         args=ARGS)
            try:
                with dashboard.open_dashboard(browser, proc.http + "/") as page:
                    page.wait_for_selector('#s-mqtt[data-state="connected"]', timeout=15000)
                    assert f"mqtt://127.0.0.1:{broker.port}/dash" in page.text_content("#s-mqtt")
                    assert page.is_visible("#mqtt-row dt")
                    broker.stop()
                    page.wait_for_selector('#s-mqtt[data-state="down"]', timeout=20000)
                    broker.start()
                    page.wait_for_selector('#s-mqtt[data-state="connected"]', timeout=30000)
                    assert page.text_content("#conn") == "live"
            finally:
                browser.close()
    finally:
        broker.stop()
