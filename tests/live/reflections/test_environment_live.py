"""``shlight serve --environment``: live reflection cubes beside SH9 (docs/contract.md §12,
"Transport"), on real servers and real WebSocket, HTTP and MQTT clients on loopback.

The SH9 path does not change with reflections on (every frame still makes its sh9
message, counted over a window, not timed); cubes reach only the clients that ask, framed
once, newest only for a slow client; GET /environment.ktx2 and MQTT carry the same bytes;
bad requests get one clear error and the server keeps serving.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
import time

import jsonschema
import pytest

from provider.live.wire.message import load_schema

from mqtttools import MOSQUITTO, Mosquitto, Subscriber
from servertools import (MjpegCamera, ServerThread, ServeProcess, connect, health, http_get,
                         jpeg_panorama, metric, poll, run_cli)

VALIDATOR = jsonschema.Draft202012Validator(load_schema())
BRIDGE = os.path.join(str(Path(__file__).resolve().parents[2]), "data", "hdri", "bridge.exr")


def read(ws, timeout: float = 10.0):
    """The next frame: ("json", dict) or ("binary", bytes)."""
    data = ws.recv(timeout=timeout)
    return ("binary", data) if isinstance(data, bytes) else ("json", json.loads(data))


def read_until(ws, done, timeout: float = 120.0) -> list:
    """Frames until ``done(frames)``; AssertionError at the deadline (long: the cube's
    thread runs at nice 10, and beside a CPU hog its first cube came after more than 20 s)."""
    frames, deadline = [], time.monotonic() + timeout
    while not done(frames):
        left = deadline - time.monotonic()
        if left <= 0:
            raise AssertionError(f"timed out; got {[_short(f) for f in frames[-6:]]}")
        try:
            frames.append(read(ws, timeout=left))
        except TimeoutError:
            continue
    return frames


def _short(frame):
    kind, value = frame
    return (kind, len(value)) if kind == "binary" else (value.get("type"), value.get("seq"))


def of_type(frames, kind: str) -> list[dict]:
    return [v for k, v in frames if k == "json" and v.get("type") == kind]


def cubes(frames) -> list[tuple[dict, bytes]]:
    """(environment message, KTX2 bytes) pairs; asserts each message is followed at once
    by its binary frame of ``byte_length`` bytes."""
    out = []
    for i, (kind, value) in enumerate(frames):
        if kind == "binary":
            assert i > 0 and frames[i - 1][0] == "json" and \
                frames[i - 1][1].get("type") == "environment", "a binary frame not announced"
        elif value.get("type") == "environment":
            if i + 1 < len(frames):
                nxt_kind, data = frames[i + 1]
                assert nxt_kind == "binary", "environment message not followed by its cube"
                assert len(data) == value["byte_length"]
                out.append((value, data))
    return out


def key_value(ktx2: bytes, key: str) -> str:
    start = ktx2.index(key.encode() + b"\0") + len(key) + 1
    return ktx2[start:ktx2.index(b"\0", start)].decode()


def subscribe(ws, **fields) -> None:
    ws.send(json.dumps({"type": "subscribe", **fields}))


def counts(srv, name: str = "default") -> dict:
    def read_counts():
        p = srv.server.probes[name]
        return {"delivered": p.capture.frames, "processed": p.frames_processed, "seq": p.seq,
                "cubes": p.environment.updates if p.environment else 0}
    return srv.call(read_counts)


# ---- the SH9 path is unchanged --------------------------------------------------------------

@pytest.mark.parametrize("reflections", [False, True], ids=["sh9-only", "with-cubes"])
def test_every_frame_still_makes_its_sh9_message_with_reflections_on(reflections):
    """A 12 fps source sending every frame (--change-threshold 0): over a window of 36
    frames, each frame delivered is projected and makes exactly one sh9 message, which a
    client receives, whether or not busy 32² cubes are made at 10 Hz beside it (the counts
    are the same with and without: the cube never holds an sh9 message back)."""
    extra = ["--environment", "--environment-size", "32", "--environment-hz", "10"] \
        if reflections else []
    with ServerThread("--fps", "12", "--change-threshold", "0", *extra) as srv, \
            connect(srv.url) as ws:
        subscribe(ws, probe="default", environment=reflections)
        read_until(ws, lambda f: len(of_type(f, "sh9")) >= 3 and  # warmed up: the cube built
                   (not reflections or any(k == "binary" for k, _ in f)), timeout=60)
        before = counts(srv)
        frames = read_until(ws, lambda f: len(of_type(f, "sh9")) >= 36, timeout=30)
        after = counts(srv)
        got = [m["seq"] for m in of_type(frames, "sh9")]
        assert got == list(range(got[0], got[0] + len(got))), "the client missed sh9 messages"
        delivered = after["delivered"] - before["delivered"]
        processed = after["processed"] - before["processed"]
        sent = after["seq"] - before["seq"]
        assert abs(delivered - processed) <= 1, (delivered, processed)   # one may be in flight
        assert sent == processed, (sent, processed)
        assert delivered >= 30
        if reflections:
            assert after["cubes"] - before["cubes"] >= 2
            assert len(cubes(frames)) >= 2
        else:
            assert after["cubes"] == 0 and not cubes(frames)


# ---- WebSocket: opt-in, encoded once, newest only ---------------------------------------------

def test_cubes_go_to_the_clients_that_ask_and_match_http():
    with ServerThread("--fps", "10", "--environment", "--environment-hz", "5") as srv, \
            connect(srv.url) as plain, connect(srv.url) as first, connect(srv.url) as second:
        hello = read(plain)[1]
        assert hello["type"] == "hello" and hello["environment"] == ["default"]
        assert VALIDATOR.is_valid(hello)
        for ws in (first, second):
            subscribe(ws, environment=True)
        got = {}
        for name, ws in (("first", first), ("second", second)):
            frames = read_until(ws, lambda f: len(cubes(f)) >= 3)
            reply = of_type(frames, "subscribed")[0]
            assert reply["environment"] is True
            sh9_seqs = {m["seq"] for m in of_type(frames, "sh9")}
            for message, data in cubes(frames):
                VALIDATOR.validate(message)
                assert (message["format"], message["encoding"]) == ("rgba16f", "ktx2")
                assert message["size"] == 32 and message["mips"] == len(message["roughness"])
                assert key_value(data, "shlight.sh9_seq") == str(message["sh9_seq"])
                assert key_value(data, "shlight.seq") == str(message["seq"])
                # the cube belongs to an sh9 message this client already has
                assert message["sh9_seq"] in sh9_seqs or message["sh9_seq"] < min(sh9_seqs)
            got[name] = {m["seq"]: data for m, data in cubes(frames)}
        common = set(got["first"]) & set(got["second"])
        assert common and all(got["first"][s] == got["second"][s] for s in common)
        # The client that never asked got lighting only, and is not even visited.
        frames = read_until(plain, lambda f: len(of_type(f, "sh9")) >= 10)
        assert all(k == "json" and v["type"] in ("sh9",) for k, v in frames)
        assert srv.call(lambda: len(srv.server.environment.clients)) == 2
        # GET /environment.ktx2: the same bytes as the WebSocket cube of the same seq.
        newest = max(got["first"])

        def same_seq():
            status, headers, body = http_get(srv.http + "/environment.ktx2?probe=default")
            return status == 200 and (int(headers["X-Shlight-Seq"]), body)
        seq, body = poll(same_seq, what="the cube over HTTP")
        if seq in got["first"]:
            assert body == got["first"][seq]
        assert seq >= newest and body[:12] == b"\xabKTX 20\xbb\r\n\x1a\n"
        h = health(srv.http)
        assert h["probes"]["default"]["environment"]["updates"] >= 3
        assert h["environment"]["clients"] == 2
        assert metric(srv.http, "shlight_environment_updates_total", probe="default") >= 3
        assert metric(srv.http, "shlight_environment_update_bytes", probe="default") == len(body)
        assert metric(srv.http, "shlight_environment_sent_bytes_total") > 6 * len(body)
        assert metric(srv.http, "shlight_environment_compute_seconds", probe="default") > 0


def test_a_slow_client_gets_the_newest_cube_only():
    """A client that stops reading while ten 1 MB cubes are made (128² at up to 10 Hz: more
    than the 1 MiB message limit that websockets sets by default) is neither
    cut off nor flooded afterwards: it gets fewer cubes than were made, the newest last.
    (The pause lasts until ten are made and the server has replaced one it could not send,
    however slow the machine and however much the loopback's socket buffers hold: on one CI
    machine they held all ten; --send-timeout is long enough for that.)"""
    with ServerThread("--fps", "20", "--environment", "--environment-hz", "10",
                      "--environment-size", "128", "--send-timeout", "600") as srv, \
            connect(srv.url, max_queue=1, max_size=None) as ws:
        subscribe(ws, environment=True)
        # the 128² projector: 3 s here, 85 s beside two CPU hogs (the cube thread runs at nice 10)
        first = read_until(ws, lambda f: len(cubes(f)) >= 1, timeout=240)
        start = counts(srv)["cubes"]
        skipped = srv.call(lambda: srv.server.environment.skipped)
        poll(lambda: counts(srv)["cubes"] - start >= 10          # not reading
             and srv.call(lambda: srv.server.environment.skipped) > skipped,
             timeout=240, what="ten cubes made and one skipped")
        made = counts(srv)["cubes"] - start
        frames = read_until(ws, lambda f: len(cubes(f)) >= 2
                            and cubes(f)[-1][0]["seq"] >= start + made - 1, timeout=60)
        received = [m["seq"] for m, _ in cubes(first) + cubes(frames)]
        assert made >= 10
        assert received == sorted(set(received))
        assert received[-1] >= start + made - 1                          # the newest last
        assert len(received) < received[-1] - received[0] + 1, received  # skipped, not queued


# ---- bad input: one clear error, the server keeps serving ---------------------------------------

def test_environment_requests_to_probes_without_cubes_get_one_error():
    with ServerThread("--probe", "a=demo", "--probe", "b=demo", "--probe-args",
                      "b=--environment --environment-hz 5", "--fps", "10") as srv, \
            connect(srv.url) as ws:
        hello = read(ws)[1]
        assert hello["environment"] == ["b"]
        subscribe(ws, probe="a", environment=True)
        frames = read_until(ws, lambda f: of_type(f, "error"))
        error = of_type(frames, "error")[0]
        assert error["error"] == "environment_off"
        assert "probe a makes no reflection cubes" in error["detail"] and "b" in error["detail"]
        assert of_type(frames, "subscribed")[0]["environment"] is False
        subscribe(ws, environment="yes")
        error = of_type(read_until(ws, lambda f: of_type(f, "error")), "error")[0]
        assert error["error"] == "bad_request" and "true or false" in error["detail"]
        # still subscribed to a's lighting; b's cubes come once asked for
        subscribe(ws, probe="b", environment=True)
        frames = read_until(ws, lambda f: len(cubes(f)) >= 1)
        assert not of_type(frames, "error")
        assert cubes(frames)[0][0]["probe"] == "b"
        for query, code, error in (("probe=a", 404, "environment_off"),
                                   ("probe=nope", 404, "unknown_probe")):
            status, _, body = http_get(f"{srv.http}/environment.ktx2?{query}")
            assert status == code and json.loads(body)["error"] == error
        assert http_get(srv.http + "/environment.ktx2?probe=b")[0] == 200
        assert set(health(srv.http)["probes"]) == {"a", "b"}     # still serving both
        read_until(ws, lambda f: len(of_type(f, "sh9")) >= 2)


def test_a_server_without_reflections_says_so_and_keeps_the_lighting():
    with ServerThread("--fps", "10") as srv, connect(srv.url) as ws:
        assert read(ws)[1]["environment"] == []
        subscribe(ws, environment=True)
        frames = read_until(ws, lambda f: of_type(f, "error") and len(of_type(f, "sh9")) >= 3)
        assert of_type(frames, "error")[0]["error"] == "environment_off"
        assert not cubes(frames)
        status, _, body = http_get(srv.http + "/environment.ktx2")
        assert status == 404 and json.loads(body)["error"] == "environment_off"


def test_subscribing_before_the_first_frame_gets_the_first_cube():
    with MjpegCamera(jpeg_panorama(128, lamp=True), fps=10) as camera:
        camera.mode = "down"
        with ServerThread("--source", camera.url, "--environment", "--reconnect-max",
                          "0.5") as srv, connect(srv.url) as ws:
            subscribe(ws, environment=True)
            frames = read_until(ws, lambda f: of_type(f, "subscribed"))
            assert of_type(frames, "subscribed")[0]["environment"] is True
            status, _, body = http_get(srv.http + "/environment.ktx2")
            assert status == 503 and json.loads(body)["error"] == "no_environment_yet"
            camera.mode = "stream"
            frames = read_until(ws, lambda f: len(cubes(f)) >= 1)
            assert not of_type(frames, "error")
            assert http_get(srv.http + "/environment.ktx2")[0] == 200


def test_8bit_cubes_reuse_the_sh9_pass_decode():
    """A changing 8-bit stream: when a cube is due, SH9's decoding pass also fills the cube's
    work image, and the cube is made from it (counted in /healthz), one decode for both."""
    import threading
    frames = [jpeg_panorama(256, lamp=True), jpeg_panorama(256, value=(90, 110, 140))]
    with MjpegCamera(frames[0], fps=15) as camera:
        stop = threading.Event()

        def flip():
            i = 0
            while not stop.wait(0.2):
                i += 1
                camera.frame = frames[i % 2]
        flipper = threading.Thread(target=flip, daemon=True)
        flipper.start()
        try:
            with ServerThread("--source", camera.url, "--environment", "--environment-size",
                              "16", "--environment-hz", "4", "--change-threshold", "0") as srv:
                poll(lambda: health(srv.http)["probes"]["default"]["environment"]
                     ["shared_decode"] >= 2, timeout=30, what="cubes from SH9's decode")
                env = health(srv.http)["probes"]["default"]["environment"]
                assert env["errors"] == 0 and env["updates"] >= env["shared_decode"]
        finally:
            stop.set()
            flipper.join(5)


@pytest.mark.parametrize("args, says", [
    (["--environment-size", "48"], "power of two from 8 to 256"),
    (["--environment-size", "512"], "power of two from 8 to 256"),
    (["--environment-hz", "0"], "updates per second"),
    (["--environment-hz", "nan"], "updates per second"),
    (["--probe", "x=demo", "--probe-args", "x=--environment-size 7"], "power of two"),
])
def test_serve_refuses_bad_environment_options_in_one_line(args, says):
    done = run_cli("serve", "--environment", *args, timeout=60)
    assert done.returncode == 2
    assert says in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert "Traceback" not in done.stderr


# ---- MQTT ---------------------------------------------------------------------------------------

@pytest.mark.skipif(not os.path.exists(MOSQUITTO), reason="no mosquitto")
def test_mqtt_retains_the_same_cube_bytes(tmp_path):
    with Mosquitto(tmp_path) as broker, \
            ServeProcess("--source", BRIDGE, "--environment",
                         "--mqtt", f"mqtt://127.0.0.1:{broker.port}/site") as proc:
        poll(lambda: http_get(proc.http + "/environment.ktx2")[0] == 200, timeout=30,
             what="the first cube")
        _, _, body = http_get(proc.http + "/environment.ktx2")
        with Subscriber(broker.port, "site/+/environment") as early:   # the broker has it
            early.first("site/default/environment")
        with Subscriber(broker.port, "site/#") as late:      # joins after it was published
            payload = late.retained("site/default/environment")
            assert payload == body
            retained, lighting = late.first("site/default")
            assert json.loads(lighting)["type"] == "sh9"
        assert key_value(payload, "shlight.probe") == "default"


def test_a_bracket_feeds_the_cube_from_one_steady_slot():
    """Exposure brackets: only the slot of median exposure makes cubes (not one slot after
    another, which would make the cube's highlights flicker); plain frames always."""
    import numpy as np
    from provider.live.reflections.cube import feeds_cube
    from provider.live.sources import Frame
    image = np.zeros((32, 64, 3), np.uint8)
    bracket = (1 / 60, 1 / 4000, 1 / 250, 1 / 1000, 1 / 15)      # median: 1/250, slot 2
    fed = [feeds_cube(Frame(image, 0.0, info={"slot": k, "bracket": bracket}))
           for k in range(5)]
    assert fed == [False, False, True, False, False]
    assert feeds_cube(Frame(image, 0.0, info={"exposure_s": 0.01}))
    assert not feeds_cube(Frame(None, 0.0, lighting=object()))
