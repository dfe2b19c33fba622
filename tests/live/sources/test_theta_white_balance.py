"""Issue 31 live: a Theta bracketing over OSC holds its white balance (auto → daylight, given
back on close), reports its aperture, and with an absolutely calibrated camera.json the merged
lighting is in cd/m² (the fake OSC camera of tests/fakecams renders a simulated filmic camera
at the exposure it was set to)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from provider.bench.camera_sim import CameraSim
from provider.core.sh9.engine import SH9Projector
from provider.live.wire.message import validate

from fakecams.osc_camera import FakeOscCamera
from radiometrytools import sh9, small
from servertools import ServerThread, connect, poll, recv_json, recv_until

#: The camera constant written into camera.json (cd/m² per N²·g/(t·ISO/100)).
C = 0.5


def test_theta_bracket_holds_white_balance_and_is_absolute(tmp_path):
    hdr = small("apartment")
    cam = CameraSim()
    theta = FakeOscCamera(hdr, camera=cam, options={"whiteBalance": "auto", "aperture": 2.8})
    response = cam.true_response().to_dict()
    response["params"]["absolute"] = {"cd_m2": C, "f_number": 2.0, "iso": 100.0, "lux": 1.0}
    path = tmp_path / "camera.json"
    path.write_text(json.dumps(response))
    try:
        with ServerThread("--source", theta.spec, "--camera", str(path),
                          "--bracket", "-4,-2,0,2,4", "--change-threshold", "0") as srv, \
                connect(srv.url) as ws:
            recv_json(ws)
            msg = recv_until(ws, lambda m: sh9(m) and m["radiometry"] == "merged", timeout=40)
            validate(msg)
            held = [c.get("whiteBalance") for c in theta.set_calls if "whiteBalance" in c]
            assert held and held[0] == "daylight"
            assert theta.options["whiteBalance"] == "daylight"
        poll(lambda: theta.options["whiteBalance"] == "auto", what="white balance given back")
    finally:
        theta.close()
    # the frame's own aperture (2.8), not the calibration's (2.0), and cd/m²
    assert msg["coefficient_units"] == "cd/m²" and msg["f_number"] == pytest.approx(2.8)
    truth = SH9Projector(128, 64).project(hdr).coefficients[0]
    ratio = np.array(msg["coefficients"][:3]) / truth
    assert ratio == pytest.approx(C * 2.8 ** 2, rel=0.05)
    assert msg["illuminance_lux"] > 0 and np.isfinite(msg["ev100"])
    assert msg["cct_k"] > 0
