"""three.js r187 lit by the provider's live reflection cube: client.js subscribes with
{"environment": true} and reads the KTX2 binary frame; client-three.js's connectEnvironment
hands three a PMREM of the provider's own mips (scene.environment). Real ``shlight serve
--environment``, real headless Chromium, three's own shaders (tests/node/node_modules).

Checked: the half floats the page holds are the served ones; a mirror sphere seen by three's
camera shows a one-sided scene's +X cap on its right, +Y on top, −Z only at its rim; three's
own environment reading (the prefiltered radiance its BRDF is given, getIBLRadiance) equals the
provider's prefiltered radiance at the roughness three used, toward the direction three used,
on the one-sided scene and a real panorama; rotations turn the cube as they turn the SH9.
"""
from __future__ import annotations

import os

import cv2
import numpy as np
import pytest

from provider.verify.cubemap import sample

from browsertools import NEEDS_BROWSER, ROOT, browser, page_of, three_version  # noqa: F401
from envtools import (SETUP, THREE_URL, json_rows, png_of, reflected_directions, relative_error,
                      served_cube, write_caps)
from servertools import ServeProcess

pytestmark = NEEDS_BROWSER

#: Three's reading of scene.environment against the provider's chain read the way three reads
#: it (its mip l = the chain at roughness 1 − √(1 − l/L), trilinear at lod L·r(2 − r)): only
#: resampling, RGBA16F and the texture unit differ. |three − reference| / |reference| (the
#: 95th percentile is largest at roughness 1, where the provider's 2×2 mip is resampled to
#: three's 8×8 one and then filtered again: measured 0.076):
MEDIAN_TOL, P95_TOL = 0.01, 0.09
#: ... and against the provider's PF at three's roughness itself, at roughnesses near three's
#: own mips (0.293, 0.5, 1 with L = 4): what a three.js user gets, the layout's between-mip
#: interpolation included (three's own PMREMGenerator has the same layout).
PF_MEDIAN_TOL, PF_P95_TOL = 0.03, 0.12
#: Three's PMREM for a 32² provider cube: face 128, L = 4 (client-three.js pmremSchedule).
THREE_L = 4


def _start(browser, proc, extra=None):
    ctx = page_of(browser, proc.http + "/healthz")
    page = ctx.__enter__()
    page.evaluate(SETUP, [THREE_URL.format(version=three_version()), proc.http, extra])
    page.wait_for_function("window.t.conn.texture !== null && window.t.conn.latest !== null",
                           timeout=60000)
    return ctx, page


def _three_lod_reference(mips, d, rough):
    """The provider's chain read as three reads its PMREM of it: lod L·r(2 − r) between
    three's mips l, each the chain at roughness 1 − √(1 − l/L)."""
    lod = np.clip(THREE_L * rough * (2 - rough), 0, THREE_L)
    lo = np.minimum(np.floor(lod), THREE_L - 1)
    w = (lod - lo)[:, None]
    at = lambda l: sample(mips, d, (1 - np.sqrt(1 - l / THREE_L)) * (len(mips) - 1))  # noqa: E731
    return (1 - w) * at(lo) + w * at(lo + 1)


def _compare(page, mips, roughness):
    """(relative error against three's reading of the chain, against PF(r) itself, r used)."""
    normals = json_rows(page.evaluate("window.t.render('normal', 0)"))
    shown = json_rows(page.evaluate(f"window.t.render('radiance', {roughness})"))
    inside = (normals[..., 3] > 0) & (np.linalg.norm(normals[..., :2], axis=-1) < 0.85)
    n = normals[inside][:, :3]
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    rough = shown[inside][:, 3]
    d = reflected_directions(n, rough)
    rel = relative_error(shown[inside][:, :3], _three_lod_reference(mips, d, rough))
    rel_pf = relative_error(shown[inside][:, :3], sample(mips, d, rough * (len(mips) - 1)))
    print(f"roughness {roughness}: three's reading median {np.median(rel):.4f} "
          f"p95 {np.quantile(rel, 0.95):.4f}; PF(r) median {np.median(rel_pf):.4f} "
          f"p95 {np.quantile(rel_pf, 0.95):.4f}")
    return rel, rel_pf, rough


def test_client_reads_the_binary_cube_as_served(browser, tmp_path):
    pano = tmp_path / "caps.hdr"
    write_caps(pano)
    with ServeProcess("--source", str(pano), "--environment", "--keepalive", "60") as proc:
        mips, seq = served_cube(proc.http)
        ctx, page = _start(browser, proc)
        try:
            page.wait_for_function(f"window.t.conn.environment.seq >= {seq}", timeout=30000)
            held = page.evaluate("""() => { const e = window.t.conn.environment;
              return { size: e.size, mipCount: e.mipCount, roughness: e.roughness, frame: e.frame,
                       seq: e.seq, probe: e.probe, u16: e.mips[0].faces[0] instanceof Uint16Array,
                       f32: e.floatFaces(1)[0] instanceof Float32Array,
                       mips: e.mips.map((m, k) => e.floatFaces(k).map((f) => Array.from(f))) }; }""")
            assert held["size"] == 32 and held["mipCount"] == 5 and held["frame"] == "rh-y-up"
            assert held["roughness"] == [0, 0.25, 0.5, 0.75, 1] and held["probe"] == "default"
            assert held["u16"] and held["f32"]
            mips, seq = served_cube(proc.http)
            if held["seq"] == seq:      # the scene is still: every texel is what was served
                for k, m in enumerate(mips):
                    got = np.asarray(held["mips"][k]).reshape(6, m.shape[1], m.shape[1], 4)
                    np.testing.assert_array_equal(got[..., :3], m)
                    assert (got[..., 3] == 1).all()
            bad = page.evaluate("""() => { const c = window.t.c; const out = [];
              for (const bytes of [new ArrayBuffer(10), new Uint8Array(200).buffer]) {
                try { c.parseEnvironmentKtx2(bytes); out.push("parsed"); } catch (e) { out.push(e.message); } }
              return out; }""")
            assert bad == ["not a KTX2 file (too short)", "not a KTX2 file"]
        finally:
            ctx.__exit__(None, None, None)


def test_mirror_sphere_shows_each_cap_where_threes_camera_sees_it(browser, tmp_path):
    """Red cap at +X, green at +Y, blue at −Z: seen from +Z, a mirror sphere shows red on its
    right, green on top, blue only at its rim (−Z is behind it), nothing on the left or
    bottom; turned by a rotation (+X → +Y, +Y → −X), red moves to the top, green to the left."""
    pano = tmp_path / "caps.hdr"
    write_caps(pano)
    with ServeProcess("--source", str(pano), "--environment", "--keepalive", "60") as proc:
        mips, _ = served_cube(proc.http)
        ctx, page = _start(browser, proc)
        try:
            img = json_rows(page.evaluate("window.t.render('shaded', 0)"))
            S = img.shape[0]
            c, r = S // 2, int(0.42 * S)          # 0.84 of the radius: reflection 65° off the axis
            right, top, left, bottom = img[c, c + r, :3], img[c - r, c, :3], img[c, c - r, :3], img[c + r, c, :3]
            assert right[0] > 1 and right[1:].max() < 0.05 * right[0], right
            assert top[1] > 1 and top[[0, 2]].max() < 0.05 * top[1], top
            # the left and bottom reflect −X and −Y (toward −Z): dark but for the blue cap's
            # blurred edge (three reads a mirror at roughness ≥ 0.045, lod ≥ 0.4)
            assert left.max() < 0.05 * right[0] and bottom.max() < 0.05 * right[0], (left, bottom)
            centre = img[c - 3:c + 4, c - 3:c + 4, :3].mean(axis=(0, 1))
            assert centre.max() < 0.01 * right[0], centre    # it reflects +Z: black
            rim = img[c, int(0.02 * S) + 1:int(0.06 * S), 2]     # left rim: grazing, toward −Z
            assert rim.max() > 1, rim
            if os.environ.get("SHLIGHT_DOCS_SCREENSHOT"):
                pictures(page, "caps")
            rel, _, _ = _compare(page, mips, 0.0)
            assert np.median(rel) < MEDIAN_TOL and np.quantile(rel, 0.95) < P95_TOL, \
                (np.median(rel), np.quantile(rel, 0.95))

            # The rotation (the provider's frame → the world) turns the cube as the SH9.
            page.evaluate("window.t.conn.setRotation([0,-1,0, 1,0,0, 0,0,1])")
            img = json_rows(page.evaluate("window.t.render('shaded', 0)"))
            top, left = img[c - r, c, :3], img[c, c - r, :3]
            assert top[0] > 1 and top[1:].max() < 0.05 * top[0], top
            assert left[1] > 1 and left[[0, 2]].max() < 0.05 * left[1], left
            assert img[c, c + r, :3].max() < 0.05 * top[0]
        finally:
            ctx.__exit__(None, None, None)


def pictures(page, name):
    """docs/three_environment_<name>.png: mirror, glossy (0.35) and rough (0.75) spheres."""
    tiles = [png_of(page.evaluate(f"window.t.show('shaded', {r})")) for r in (0.0, 0.35, 0.75)]
    cv2.imwrite(str(ROOT / "docs" / f"three_environment_{name}.png"),
                cv2.cvtColor(np.hstack(tiles), cv2.COLOR_RGBA2BGRA))


@pytest.mark.parametrize("roughness", [0.3, 0.5, 0.6, 1.0])
def test_three_reads_the_providers_prefiltered_radiance(browser, roughness):
    """A real panorama (bridge): at each pixel of a sphere, what three's own shader reads from
    scene.environment (getIBLRadiance) equals the provider's prefiltered radiance PF at the
    roughness three used (its material.roughness, with its geometry roughness) toward three's
    direction normalize(mix(R, N, r⁴)), read as three reads its layout (MEDIAN_TOL, P95_TOL),
    and near three's own mip roughnesses as PF(r) itself (PF_MEDIAN_TOL, PF_P95_TOL)."""
    pano = ROOT / "tests" / "data" / "hdri" / "bridge.exr"
    with ServeProcess("--source", str(pano), "--environment", "--keepalive", "60") as proc:
        mips, _ = served_cube(proc.http)
        ctx, page = _start(browser, proc)
        try:
            rel, rel_pf, rough = _compare(page, mips, roughness)
            assert abs(np.median(rough) - max(roughness, 0.045)) < 0.03
            assert np.median(rel) < MEDIAN_TOL and np.quantile(rel, 0.95) < P95_TOL, \
                (np.median(rel), np.quantile(rel, 0.95))
            if roughness != 0.6:         # between three's mips 0.5 and 1: its layout's approximation
                assert np.median(rel_pf) < PF_MEDIAN_TOL and np.quantile(rel_pf, 0.95) < PF_P95_TOL, \
                    (np.median(rel_pf), np.quantile(rel_pf, 0.95))
            if roughness == 1.0 and os.environ.get("SHLIGHT_DOCS_SCREENSHOT"):
                pictures(page, "bridge")
        finally:
            ctx.__exit__(None, None, None)


def _quaternion(R):
    """Unit quaternion {x, y, z, w} of a rotation matrix (as an XRRigidTransform's orientation)."""
    w = np.sqrt(max(1 + np.trace(R), 1e-12)) / 2
    return {"x": (R[2, 1] - R[1, 2]) / (4 * w), "y": (R[0, 2] - R[2, 0]) / (4 * w),
            "z": (R[1, 0] - R[0, 1]) / (4 * w), "w": w}


def test_registration_from_a_marker_pose_turns_the_cube_and_the_sh(browser, tmp_path):
    """A known registration: the provider saw the marker at R_camera←marker (a message's
    `registration`, docs/contract.md §13), the headset's tracker sees it at R_world←marker
    (an XRRigidTransform-like quaternion, and a tracker with +Y as the marker's normal), with
    R_world←camera taking the room's +X to the world's +Y: the mirror sphere shows the red
    (+X) cap on top, and the SH turned by the same rotation sees at +Y what the room had at +X."""
    from provider.core.geometry import sh
    pano = tmp_path / "caps.hdr"
    write_caps(pano)
    R_cm = sh.rotation_from_euler(yaw_deg=35, pitch_deg=-20, roll_deg=10)
    R_wc = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])          # +X → +Y, +Y → −X
    R_wm = R_wc @ R_cm
    y_normal = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0.0]])       # MARKER_AXES["y-normal"]
    with ServeProcess("--source", str(pano), "--environment", "--keepalive", "60") as proc:
        served_cube(proc.http)
        ctx, page = _start(browser, proc)
        try:
            got = page.evaluate("""([Rcm, q, Rwt]) => { const t = window.t;
              const none = t.conn.setMarkerPose(q);          // no registration yet: false
              t.conn.latest.message.registration = { rotation: Rcm };
              const ok = t.conn.setMarkerPose(q);
              const composed = t.conn.rotation;
              const tracker = t.c.registrationRotation(Rwt, { rotation: Rcm }, { markerAxes: "y-normal" });
              const L = t.conn.latest.coefficients, M = t.c.matricesFromCoefficients;
              const turned = M(t.c.rotateCoefficients(L, composed));
              return { none, ok, composed, tracker, eY: t.c.irradiance(turned, [0, 1, 0]),
                       eX: t.c.irradiance(M(L), [1, 0, 0]) }; }""",
                                 [R_cm.reshape(-1).tolist(), _quaternion(R_wm),
                                  (R_wm @ y_normal.T).reshape(-1).tolist()])
            assert got["none"] is False and got["ok"] is True
            np.testing.assert_allclose(np.reshape(got["composed"], (3, 3)), R_wc, atol=1e-6)
            np.testing.assert_allclose(np.reshape(got["tracker"], (3, 3)), R_wc, atol=1e-6)
            np.testing.assert_allclose(got["eY"], got["eX"], rtol=1e-4)
            assert got["eY"][0] > 5 * max(got["eY"][1:])                  # red light from +Y
            img = json_rows(page.evaluate("window.t.render('shaded', 0)"))
            S = img.shape[0]
            c, r = S // 2, int(0.42 * S)
            top, left, right = img[c - r, c, :3], img[c, c - r, :3], img[c, c + r, :3]
            assert top[0] > 1 and top[1:].max() < 0.05 * top[0], top        # red (+X) on top
            assert left[1] > 1 and left[[0, 2]].max() < 0.05 * left[1], left  # green (+Y) left
            assert right.max() < 0.05 * top[0], right
        finally:
            ctx.__exit__(None, None, None)
