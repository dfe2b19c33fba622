"""``shlight serve --passthrough``: the live route ``/capture`` (issue 42, item 3).

A simulated headset (provider/bench/headset_sim.py: a filmic curve that is not sRGB, a lagging
auto exposure, a drifting white balance, vignetting, JPEG, 1° pose error) looks around a
room none of the tests has seen, served as the probe's sphere; its views go over a real
WebSocket to a real server, each a ``view`` message and its JPEG, and every answer comes back
on the same socket. The second pass of the same views is scored by the issue's done-when."""
from __future__ import annotations

import json

import numpy as np
import pytest

from provider.bench.headset_sim import HeadsetSim, perturb_panorama, score
from provider.core.passthrough.fit import codes_of
from provider.core.radiometry.response import CameraResponse
from provider.live.probe.passthrough import sphere_of

from conftest import load_hdri
from servertools import ServerThread, connect, health, http_get, metric, recv_json, recv_until

#: The issue's done-when (stops): median view bias, 90th-percentile view bias, pixels' p90.
DONE_WHEN = {"median_view_bias": 0.10, "p90_view_bias": 0.20, "pixel_p90": 0.45}
ROOM, ROOM_SEED = "apartment", 11
N_VIEWS = 24
#: Each view's fit may take seconds on a loaded 2-core machine (a warm solve of all views).
ANSWER_S = 30.0


@pytest.fixture(scope="module")
def room():
    """A room none of the shared nine is as it stands: a shared panorama, perturbed."""
    return perturb_panorama(load_hdri(ROOM), seed=ROOM_SEED)


@pytest.fixture(scope="module")
def sphere(room, tmp_path_factory):
    """The room as an EXR file: the probe's source."""
    path = tmp_path_factory.mktemp("sphere") / "room.exr"
    write_exr(path, room)
    return str(path)


def write_exr(path, pano) -> None:
    """``pano`` as an OpenEXR file, written aside and renamed (a file source never reads
    half a file)."""
    import os

    import OpenEXR
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    aside = path.with_name("next-" + path.name)
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(pano, np.float32)}) as f:
        f.write(str(aside))
    os.replace(aside, path)


@pytest.fixture(scope="module")
def headset(room, tmp_path_factory):
    """Small views of the room, no exposure metadata: (messages, JPEGs, truth)."""
    folder = tmp_path_factory.mktemp("headset")
    truth = HeadsetSim(n_views=N_VIEWS, width=160, height=120, seed=5).render(room, str(folder))
    doc = json.loads((folder / "transforms.json").read_text())
    top = {k: doc[k] for k in ("fl_x", "fl_y", "cx", "cy", "w", "h")}
    messages, jpegs = [], []
    for frame in doc["frames"]:
        matrix = np.asarray(frame["transform_matrix"]).ravel().tolist()   # 16 numbers
        messages.append(json.dumps({"type": "view", "transform_matrix": matrix,
                                    "time": frame["time"], **top}))
        jpegs.append((folder / frame["file_path"]).read_bytes())
    return messages, jpegs, truth


def serve(sphere, *extra):
    return ServerThread("--source", sphere, "--fps", "5", "--passthrough",
                        "--passthrough-hz", "0", *extra)


def capture_url(srv, **query):
    q = "&".join(f"{k}={v}" for k, v in query.items())
    return srv.url.rstrip("/") + "/capture" + (f"?{q}" if q else "")


def wait_for_sphere(srv):
    """The probe has a frame (the sphere the fit compares with)."""
    from servertools import poll
    poll(lambda: srv.call(lambda: next(iter(srv.server.probes.values())).image is not None),
         what="the probe's first frame")


def send_view(ws, message, jpeg) -> dict:
    ws.send(message)
    ws.send(jpeg)
    return recv_until(ws, lambda m: m.get("type") in ("passthrough", "error"), ANSWER_S,
                      "an answer to the view")


def test_views_sent_twice_are_answered_and_the_second_pass_meets_the_done_when(
        sphere, headset):
    messages, jpegs, truth = headset
    with serve(sphere) as srv:
        wait_for_sphere(srv)
        with connect(srv.url) as lighting, connect(capture_url(srv)) as ws:
            hello = recv_json(ws)
            assert hello["type"] == "hello" and hello["route"] == "/capture"
            camera = None
            answers = []
            for _ in range(2):
                answers = []
                for message, jpeg in zip(messages, jpegs):
                    ws.send(message)
                    ws.send(jpeg)
                    while True:
                        msg = recv_until(ws, lambda m: m["type"] in (
                            "passthrough", "passthrough_camera", "error"), ANSWER_S, "answer")
                        if msg["type"] == "passthrough_camera":
                            camera = msg["camera"]
                            continue
                        break
                    assert msg["type"] == "passthrough", msg
                    assert not msg.get("dropped"), msg      # one view at a time: none dropped
                    answers.append(msg)
            # the probe kept serving its lighting clients while the views were fitted
            sh9 = 0
            while True:
                try:
                    if json.loads(lighting.recv(timeout=0.5)).get("type") == "sh9":
                        sh9 += 1
                except TimeoutError:
                    break
            assert sh9 >= 2
            h = health(srv.http)
    assert camera is not None, "no passthrough_camera message"
    assert h["passthrough"]["views"] == 2 * N_VIEWS and h["passthrough"]["solves"] >= 2
    for a in answers:
        assert a["exposure"] > 0 and len(a["wb_gains"]) == 3 and a["wb_gains"][1] == 1.0
        assert np.isfinite(a["ev100"]) and a["residual_stops"] < 0.5
    # the model a consumer renders through: the last curve, each view's answer
    response = CameraResponse.from_dict(camera)
    vig = response.params["vignetting"]
    table = response.table

    def predict(i, radiance, rho2):
        a = answers[i]
        x = radiance * a["exposure"] * np.asarray(a["wb_gains"])
        x = x * np.exp(vig["v1"] * rho2 + vig["v2"] * rho2 ** 2)[..., None]
        return codes_of(table, x)
    got = score(truth, predict)
    p = h["passthrough"]
    print("live second pass:", got, f"{1000 * p['fit_seconds'] / p['views']:.0f} ms a view "
          f"(decode, sampling, solves), {p['solves']} solves")
    for key, limit in DONE_WHEN.items():
        assert got[key] <= limit, (key, got)


def test_capture_is_refused_without_passthrough(sphere):
    from websockets.exceptions import InvalidStatus
    with ServerThread("--source", sphere, "--fps", "5") as srv:
        with pytest.raises(InvalidStatus) as err:
            connect(capture_url(srv))
        assert err.value.response.status_code == 404
        assert b"--passthrough" in err.value.response.body
        with connect(srv.url) as ws:                   # the lighting route is unchanged
            assert recv_json(ws)["type"] == "hello"


def test_capture_needs_the_token(sphere, headset):
    from websockets.exceptions import InvalidStatus
    messages, jpegs, _ = headset
    with serve(sphere, "--token", "s3cret") as srv:
        wait_for_sphere(srv)
        with pytest.raises(InvalidStatus) as err:
            connect(capture_url(srv))
        assert err.value.response.status_code == 401
        with pytest.raises(InvalidStatus) as err:
            connect(capture_url(srv, token="wrong"))
        assert err.value.response.status_code == 401
        with connect(capture_url(srv, token="s3cret")) as ws:
            assert recv_json(ws)["route"] == "/capture"
            assert send_view(ws, messages[0], jpegs[0])["type"] == "passthrough"
        # a browser page of another origin is refused as on every route
        with pytest.raises(InvalidStatus) as err:
            connect(capture_url(srv, token="s3cret"), origin="http://evil.example")
        assert err.value.response.status_code == 403


def test_bad_views_get_one_clear_answer_and_the_connection_lives_on(sphere, headset):
    messages, jpegs, _ = headset
    good = json.loads(messages[0])
    m = np.asarray(good["transform_matrix"]).reshape(4, 4)
    m[:3, :3] *= 1.5                                        # scaled: not a rotation
    scaled = dict(good, transform_matrix=m.tolist())
    outside = dict(good, cx=500.0)
    with serve(sphere, "--passthrough-max-jpeg-bytes", "20000") as srv:
        wait_for_sphere(srv)
        with connect(capture_url(srv)) as ws:
            recv_json(ws)

            def answer():
                return recv_until(ws, lambda m: m["type"] in ("passthrough", "error"),
                                  ANSWER_S, "an answer")
            ws.send("{not json")
            e = answer()
            assert e["error"] == "bad_json", e
            ws.send(json.dumps(scaled))
            e = answer()
            assert e["error"] == "bad_view" and "not a rotation" in e["detail"], e
            ws.send(json.dumps(outside))
            e = answer()
            assert e["error"] == "bad_view" and "principal point" in e["detail"], e
            ws.send(b"\xff\xd8\xff" + b"\0" * 100)          # a binary without a view
            e = answer()
            assert e["error"] == "bad_request" and "follow a view" in e["detail"], e
            ws.send(messages[0])
            ws.send(b"PNG? no: just bytes")
            e = answer()
            assert e["error"] == "not_jpeg", e
            ws.send(messages[0])
            ws.send(b"\xff\xd8\xff" + b"\0" * 30000)        # past the JPEG cap
            e = answer()
            assert e["error"] == "too_large" and "20000" in e["detail"], e
            ws.send(messages[0])
            ws.send(jpegs[0][:-400])                        # a JPEG cut short
            e = answer()
            assert e["error"] == "bad_view", e
            ws.send(json.dumps({"type": "subscribe"}))
            e = answer()
            assert e["error"] == "unknown_type", e
            # and after all that, a good view is fitted on the same connection
            ok = send_view(ws, messages[0], jpegs[0])
            assert ok["type"] == "passthrough" and ok["exposure"] > 0, ok
        status, _, body = http_get(srv.http + "/healthz")
        assert status == 200
        errors = json.loads(body)["passthrough"]["errors"]
        assert errors["bad_view"] == 3 and errors["not_jpeg"] == 1
        assert metric(srv.http, "shlight_passthrough_errors_total", error="too_large") == 1


def test_views_faster_than_the_rate_are_dropped_with_a_count(sphere, headset):
    messages, jpegs, _ = headset
    with ServerThread("--source", sphere, "--fps", "5", "--passthrough",
                      "--passthrough-hz", "0.01") as srv:
        wait_for_sphere(srv)
        with connect(capture_url(srv)) as ws:
            recv_json(ws)
            first = send_view(ws, messages[0], jpegs[0])
            assert not first.get("dropped") and first["exposure"] > 0
            # the next views come far sooner than 1 / 0.01 s: each is answered "dropped"
            for i in (1, 2, 3):
                d = send_view(ws, messages[i], jpegs[i])
                assert d["dropped"] is True and d["reason"] == "rate", d
                assert d["dropped_views"] == i
        assert metric(srv.http, "shlight_passthrough_views_dropped_total", reason="rate") == 3


def test_views_that_come_while_the_fit_is_busy_are_dropped_not_queued(sphere, headset):
    messages, jpegs, _ = headset
    n = 8
    with serve(sphere) as srv:
        wait_for_sphere(srv)
        with connect(capture_url(srv)) as ws:
            recv_json(ws)
            # a burst, as a headset at 30-60 Hz sends: the first view's fit (decoding, the
            # sphere's blurs, sampling) is still running when the next ones arrive
            for message, jpeg in zip(messages[:n], jpegs[:n]):
                ws.send(message)
                ws.send(jpeg)
            answers = [recv_until(ws, lambda m: m["type"] == "passthrough", ANSWER_S,
                                  "an answer") for _ in range(n)]
            busy = [a for a in answers if a.get("dropped")]
            fitted = [a for a in answers if not a.get("dropped")]
            # every view answered once: fitted, or dropped with its reason and a count
            assert len(fitted) >= 1 and busy, answers
            assert all(a["reason"] == "busy" for a in busy)
            assert max(a["dropped_views"] for a in answers) == len(busy)
            assert sorted(a["time"] for a in answers) == sorted(
                json.loads(m)["time"] for m in messages[:n])
            # and the socket goes on: the next view, sent alone, is fitted
            assert not send_view(ws, messages[n], jpegs[n]).get("dropped")
        h = health(srv.http)["passthrough"]
        assert h["dropped"]["busy"] == len(busy) and h["views"] == n + 1


def test_an_8_bit_probe_frame_is_the_sphere_through_its_curve(headset, tmp_path):
    """A JPEG panorama (8-bit codes, decoded as sRGB without --camera) is a sphere too: the
    view is fitted against its linear light, not its codes."""
    import cv2
    from provider.core.radiometry.response import srgb_decode
    messages, jpegs, _ = headset
    pano = np.zeros((128, 256, 3), np.uint8)
    pano[:] = np.linspace(40, 220, 256, dtype=np.uint8)[None, :, None]   # a ramp of light
    path = tmp_path / "pano.jpg"
    cv2.imwrite(str(path), pano)
    with serve(str(path)) as srv:
        wait_for_sphere(srv)
        sphere = srv.call(lambda: sphere_of(next(iter(srv.server.probes.values()))))
        with connect(capture_url(srv)) as ws:
            recv_json(ws)
            a = send_view(ws, messages[0], jpegs[0])
    assert a["type"] == "passthrough" and not a.get("dropped"), a
    # the sphere is the frame's linear light: sRGB-decoded codes, not the codes
    want = srgb_decode(pano[64, ::16, 1] / 255.0)
    assert np.allclose(sphere[64, ::16, 1], want, rtol=0.02, atol=2e-3)


def test_serve_refuses_bad_passthrough_options_in_one_line():
    from servertools import refused, run_cli
    res = run_cli("serve", "--passthrough", "--passthrough-max-jpeg-bytes", "10")
    refused(res, "--passthrough-max-jpeg-bytes")
    res = run_cli("serve", "--passthrough", "--passthrough-hz", "-1")
    refused(res, "--passthrough-hz")


def test_a_views_estimate_between_solves_is_the_solves_own(room, tmp_path):
    """What the route answers between two solves (``PassthroughFit.estimate``: the view
    alone under the last curve) agrees with what the joint solve says of that view."""
    from provider.core.passthrough import PassthroughFit, read_transforms
    from provider.core.passthrough.views import read_view_image
    HeadsetSim(n_views=12, width=160, height=120, seed=5).render(room, str(tmp_path))
    fit = PassthroughFit(room)
    for view in read_transforms(tmp_path / "transforms.json"):
        fit.add_view(view, read_view_image(view))
    result = fit.solve()
    for i in (0, 5, 11):
        exposure, wb, resid, samples = fit.estimate(i)
        # the same medians over nearly the same samples (the flattest of this view, not of
        # all): 0.004 stop apart here; 0.02 leaves room for another BLAS's rounding
        assert abs(np.log2(exposure / result.exposure[i])) < 0.02
        assert np.abs(np.log2(wb / result.wb_gains[i])).max() < 0.02
        assert samples > 30 and resid < 0.5


def test_capture_refuses_an_unknown_probe_and_headsets_past_the_cap(sphere):
    from websockets.exceptions import InvalidStatus
    with serve(sphere, "--passthrough-headsets", "1") as srv:
        with pytest.raises(InvalidStatus) as err:
            connect(capture_url(srv, probe="nope"))
        assert err.value.response.status_code == 404
        assert b"no probe 'nope'" in err.value.response.body
        with connect(capture_url(srv, probe="default")) as ws:
            assert recv_json(ws)["probe"] == "default"
            with pytest.raises(InvalidStatus) as err:
                connect(capture_url(srv))
            assert err.value.response.status_code == 503
        # the headset left: its place is free again
        from servertools import poll
        poll(lambda: srv.call(lambda: srv.server.passthrough.headsets) == 0,
             what="the headset's place freed")
        with connect(capture_url(srv)) as ws:
            assert recv_json(ws)["route"] == "/capture"


def test_the_sphere_follows_the_room_when_its_light_changes(room, headset, tmp_path):
    """The room's light doubles (a lamp turned up) while a headset looks around. Its camera
    auto-exposes, so it records the same codes at half the exposure: the very same JPEGs
    (HeadsetSim renders linear light through its exposure). Views that come after the probe's
    new frame are compared with it, and answered with half the exposure; with the first
    sphere kept they would be answered as before (a 1-stop error on every hologram)."""
    messages, jpegs, truth = headset
    brighter = tmp_path / "brighter"
    twin = HeadsetSim(n_views=N_VIEWS, width=160, height=120, seed=5).render(2 * room,
                                                                            str(brighter))
    assert (brighter / json.loads((brighter / "transforms.json").read_text())["frames"][3]
            ["file_path"]).read_bytes() == jpegs[3]
    # the same float64 arithmetic on a room exactly twice as bright: no sum reordered
    np.testing.assert_allclose(twin.exposure, np.asarray(truth.exposure) / 2, rtol=1e-9)

    path = tmp_path / "room.exr"
    write_exr(path, room)
    with serve(str(path), "--passthrough-sphere-every", "0") as srv:
        wait_for_sphere(srv)
        probe = next(iter(srv.server.probes.values()))
        with connect(capture_url(srv)) as ws:
            assert recv_json(ws)["type"] == "hello"
            for _ in range(2):      # the second pass: answered from a settled curve
                before = [send_view(ws, m, j) for m, j in zip(messages, jpegs)]
            seq = srv.call(lambda: probe.image_seq)
            write_exr(path, 2 * room)
            from servertools import poll
            poll(lambda: srv.call(lambda: probe.image_seq) > seq, 30,
                 what="the probe's frame of the brighter room")
            after = [send_view(ws, m, j) for m, j in zip(messages, jpegs)]
        updates = health(srv.http)["passthrough"]["sphere_updates"]
    ok = [i for i in range(N_VIEWS) if before[i].get("exposure") and after[i].get("exposure")]
    assert len(ok) >= N_VIEWS - 2, (before, after)
    stops = np.log2([after[i]["exposure"] / before[i]["exposure"] for i in ok])
    # The same codes against a sphere twice as bright: exactly a stop by the model (scale
    # equivariant medians and solves); 0.1 stop leaves room for the curve still moving a
    # little between the passes' solves.
    print(f"the room 1 stop brighter: answered {np.median(stops):+.3f} stop "
          f"(views {stops.min():+.3f}..{stops.max():+.3f}), {updates} sphere updates")
    assert abs(np.median(stops) + 1.0) < 0.1, stops
    assert updates >= 1


def test_a_frames_radiance_scale_is_what_its_coefficients_carry():
    """``radiance_scale`` (what the live sphere is multiplied by) turns a frame's plain linear
    light into its coefficients' units: ``--exposure``, 1/(t·gain) and an absolute curve's
    C·N², exactly as ``project`` applies them."""
    from provider.core.sh9.engine import SH9Projector
    response = CameraResponse.srgb(8)
    response.params["absolute"] = {"cd_m2": 12.5, "f_number": 2.0}
    rng = np.random.default_rng(4)
    frame = rng.integers(20, 240, (64, 128, 3), dtype=np.uint8)
    projector = SH9Projector(128, 64, exposure=1.5, response=response)
    got = projector.project(frame, exposure_s=1 / 60, gain=2.0, f_number=4.0).coefficients
    scale = projector.radiance_scale(1 / 60, 2.0, 4.0)
    assert scale == pytest.approx(1.5 * 60 / 2.0 * 12.5 * 16)
    lin = response.linearise(frame) * np.float32(scale)
    want = SH9Projector(128, 64).project(lin).coefficients
    # float32 sums of the same light in two orders (a table with the scale in it, or the
    # scale after): 1e-5 of the coefficients holds on any BLAS
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5 * np.abs(want).max())


def test_the_live_sphere_is_in_the_units_of_the_probes_coefficients(room, tmp_path):
    """``--exposure 4`` scales a probe's SH9 by 4: the sphere the headsets are fitted against
    is scaled alike, so that a hologram lit by that SH9 through the fitted exposure is right
    (before, the sphere was the file's values: every hologram 2 stops off)."""
    path = tmp_path / "room.exr"
    write_exr(path, room)
    with serve(str(path), "--exposure", "4") as srv:
        wait_for_sphere(srv)
        sphere = srv.call(lambda: sphere_of(next(iter(srv.server.probes.values()))))
    # one float32 product a pixel (no resampling: an equirect at most 512 rows), no sums
    np.testing.assert_allclose(sphere, 4 * np.asarray(room, np.float32), rtol=1e-6)


def test_the_live_sphere_is_in_the_frame_and_units_of_the_coefficients(room, tmp_path):
    """``--rotate`` turns a probe's coefficients into the world's frame; the sphere the
    headsets and the light at points are compared with is turned alike, and scaled alike:
    its own SH9 is the probe's (up to resampling the panorama once)."""
    from provider import compute_sh9
    path = tmp_path / "room.exr"
    write_exr(path, room)
    with serve(str(path), "--rotate", "90,20,0", "--exposure", "2") as srv:
        wait_for_sphere(srv)
        probe = next(iter(srv.server.probes.values()))
        sphere = srv.call(lambda: sphere_of(probe))
        latest = json.loads(http_get(srv.http + "/latest.json")[2])
    ours = compute_sh9(sphere.astype(np.float32)).coefficients.reshape(-1)
    theirs = np.asarray(latest["coefficients"])
    # one bilinear resampling of a 256-row panorama at 512 rows: 0.5 % of the ambient term
    np.testing.assert_allclose(ours, theirs, atol=5e-3 * np.abs(theirs[:3]).max())
    unturned = compute_sh9(2 * np.asarray(room, np.float32)).coefficients.reshape(-1)
    assert np.abs(unturned - theirs).max() > 0.1 * np.abs(theirs[:3]).max()   # it did turn
