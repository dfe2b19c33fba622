"""A simulated passthrough headset, and the issue's score of a passthrough model (tooling).

What a video see-through headset's camera records of a room whose radiance is an HDR
panorama, as pose-tagged views in nerfstudio's ``transforms.json`` (docs/passthrough.md):

* narrow pinhole views (90° wide, 320 × 240 by default) of a look-around: the yaw turns one
  and a half times, the pitch swings ±35°, a little roll; rendered at twice the size and
  area-averaged (the lens's blur);
* the pose written is not the pose rendered: ~1° of tracking error (a random rotation
  vector, 1° RMS);
* an auto exposure that lags: each view's target puts its mean radiance at 18 % grey, and
  the exposure moves half way there (in stops) per view;
* a drifting white balance: red and blue gains random-walk (3 % a view, within ±25 %);
* vignetting: sensor exposure × (1 − 0.35 ρ²), ρ from the centre over the half-diagonal;
* optionally (``parallax``, a fraction of the views) a near object: an ellipse over ~10 %
  of the view that shows what the sphere sees 15–30° to the side;
* a per-channel filmic tone curve that is not sRGB (:class:`~.camera_sim.CameraSim`, other
  parameters), 8-bit clipping, and JPEG at quality 85.

No exposure metadata is written unless asked (``metadata=True``: ``exposure_s`` with the
true exposure, up to one constant).

"Rooms other than the shared nine" (:func:`perturb_panorama`): a shared panorama turned by a
random yaw, mirrored left-right (odd seeds), re-tinted (per-channel gains, ±15 % RMS) and
re-lit region by region (four smooth blobs, each brightening or darkening by up to a stop
over ~30°): the same kind of light, in a room none of the tests has seen.

The score (:func:`score`) is the issue's: a hologram rendered with the model (sphere
radiance in the view's true directions → predicted code) against the code the headset
recorded for the real surface, both converted to light through the *true* response; a
view's bias is the median over its unclipped pixels (recorded codes 1..254 in every
channel) of that error in stops, worst channel by absolute value; the pixels' 90th
percentile is over every unclipped pixel of every view of the worst channel's |error|.
:func:`naive_model` is the baseline the issue measures against: decode as sRGB, exposure
by matching the mean to the sphere, no white balance.
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import cv2
import numpy as np

from ..core.passthrough.fit import sample_equirect
from ..core.passthrough.views import PassthroughView
from ..core.radiometry.response import srgb_decode
from .camera_sim import MID_GREY, CameraSim

#: The headset's curve: filmic like :class:`CameraSim`'s default, but another camera.
HEADSET_CAMERA = dict(exponent=(0.70, 0.66, 0.61), clip_stops=(3.2, 3.25, 3.15),
                      toe=(0.015, 0.012, 0.018))


def perturb_panorama(pano: np.ndarray, seed: int) -> np.ndarray:
    """A new room from a panorama (module doc): yaw, mirror, tint, regional re-lighting."""
    rng = np.random.default_rng(seed)
    p = np.maximum(np.nan_to_num(np.asarray(pano, np.float64)), 0.0)
    h, w = p.shape[:2]
    p = np.roll(p, int(rng.integers(w)), axis=1)
    if seed % 2:
        p = p[:, ::-1]
    p = p * np.exp(rng.normal(0.0, 0.15, 3))
    ys, xs = np.mgrid[0:h, 0:w]
    theta = math.pi * (ys + 0.5) / h
    phi = 2 * math.pi * ((xs + 0.5) / w - 0.5)
    d = np.stack([np.sin(phi) * np.sin(theta), np.cos(theta), -np.cos(phi) * np.sin(theta)], -1)
    log_scale = np.zeros((h, w))
    for _ in range(4):
        c = rng.normal(size=3)
        c /= np.linalg.norm(c)
        ang = np.arccos(np.clip(d @ c, -1, 1))
        log_scale += rng.uniform(-1, 1) * math.log(2) * np.exp(-0.5 * (ang / math.radians(30)) ** 2)
    return (p * np.exp(log_scale)[..., None]).astype(np.float32)


def look_rotation(yaw_deg: float, pitch_deg: float, roll_deg: float = 0.0) -> np.ndarray:
    """Camera-to-world rotation, OpenGL camera axes (looks down −Z, +Y up), that looks
    along yaw (from −Z toward +X) and pitch (up), rolled about the optical axis."""
    yaw, pitch, roll = (math.radians(v) for v in (yaw_deg, pitch_deg, roll_deg))
    f = np.array([math.sin(yaw) * math.cos(pitch), math.sin(pitch),
                  -math.cos(yaw) * math.cos(pitch)])
    x = np.cross(f, (0.0, 1.0, 0.0))
    x /= np.linalg.norm(x)
    z = -f
    y = np.cross(z, x)
    cr, sr = math.cos(roll), math.sin(roll)
    x, y = cr * x + sr * y, -sr * x + cr * y
    return np.stack([x, y, z], axis=1)


@dataclass
class HeadsetTruth:
    """What the simulation knows and a fit must find (and what the score needs)."""

    views: list                 # PassthroughView as written (the recorded poses)
    rotations: list             # true camera-to-world rotations
    exposure: np.ndarray        # (V,) sensor exposure per unit radiance
    wb_gains: np.ndarray        # (V, 3), green = 1
    radiance: list              # per view (h, w, 3): the real surface's radiance per pixel
    codes: list                 # per view (h, w, 3) uint8 as recorded (after JPEG)
    rho2: np.ndarray            # (h, w) squared radius over the half-diagonal
    camera: CameraSim


@dataclass
class HeadsetSim:
    """The simulated headset (module doc); every effect can be switched off for a test."""

    width: int = 320
    height: int = 240
    hfov_deg: float = 90.0
    n_views: int = 40
    pose_noise_deg: float = 1.0
    ae_lag: float = 0.5
    wb_step: float = 0.03
    vignetting: float = 0.35
    jpeg_quality: int = 85
    parallax: float = 0.0
    seed: int = 0
    camera: CameraSim = field(default_factory=lambda: CameraSim(**HEADSET_CAMERA))

    def render(self, pano: np.ndarray, out_dir: str, *, metadata: bool = False,
               per_frame_intrinsics: bool = False) -> HeadsetTruth:
        """Write ``out_dir/transforms.json`` and ``out_dir/images/view_NNN.jpg``."""
        rng = np.random.default_rng(self.seed)
        pano = np.maximum(np.nan_to_num(np.asarray(pano, np.float64)), 0.0)
        w, h = self.width, self.height
        fl = 0.5 * w / math.tan(math.radians(self.hfov_deg) / 2)
        cx, cy = 0.5 * w, 0.5 * h
        os.makedirs(os.path.join(out_dir, "images"), exist_ok=True)
        ys, xs = np.mgrid[0:h, 0:w]
        rho2 = ((xs + 0.5 - cx) ** 2 + (ys + 0.5 - cy) ** 2) / (0.25 * (w * w + h * h))
        ss = 2   # rendered at twice the size, area-averaged
        sy, sx = np.mgrid[0:h * ss, 0:w * ss]
        cam = np.stack([(sx + 0.5) / ss - cx, -((sy + 0.5) / ss - cy), -np.full(sx.shape, fl)],
                       -1)
        cam /= np.linalg.norm(cam, axis=-1, keepdims=True)
        frames, views, rotations, exposures, wbs, radiances, codes = [], [], [], [], [], [], []
        log_e = None
        log_wb = rng.normal(0, 0.08, 2)
        prng = np.random.default_rng(self.seed + 1000)   # the near objects' own stream
        for i in range(self.n_views):
            t = i / self.n_views
            rec = look_rotation(540.0 * t + rng.normal(0, 4),
                                35.0 * math.sin(2 * math.pi * 3 * t) + rng.normal(0, 3),
                                rng.normal(0, 3))
            rvec = rng.normal(0, math.radians(self.pose_noise_deg) / math.sqrt(3), 3)
            true = rec @ cv2.Rodrigues(rvec.reshape(3, 1))[0]
            L = sample_equirect(pano, cam @ true.T)
            if self.parallax and prng.random() < self.parallax:
                L = self._near_object(pano, cam @ true.T, L, prng)
            L = cv2.resize(L.astype(np.float32), (w, h), interpolation=cv2.INTER_AREA)
            L = L.astype(np.float64)
            target = math.log(MID_GREY / max(float(L.mean()), 1e-9))
            log_e = target if log_e is None else log_e + self.ae_lag * (target - log_e)
            log_wb = np.clip(log_wb + rng.normal(0, self.wb_step, 2), -0.25, 0.25)
            wb = np.array([math.exp(log_wb[0]), 1.0, math.exp(log_wb[1])])
            x = L * math.exp(log_e) * wb * (1 - self.vignetting * rho2)[..., None]
            z = self.camera.capture(x, 1.0)
            ok, buf = cv2.imencode(".jpg", z[..., ::-1],
                                   [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
            name = f"images/view_{i:03d}.jpg"
            with open(os.path.join(out_dir, name), "wb") as f:
                f.write(buf.tobytes())
            recorded = cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1]
            m = np.eye(4)
            m[:3, :3] = rec
            m[:3, 3] = rng.normal(0, 0.3, 3) + (0, 1.6, 0)   # standing, looking around
            frame = {"file_path": name, "transform_matrix": m.tolist(), "time": i / 30.0}
            if metadata:
                frame["exposure_s"] = math.exp(log_e) * 0.01   # one unknown constant
                frame["iso"] = 100
            if per_frame_intrinsics:
                frame.update(fl_x=fl, fl_y=fl, cx=cx, cy=cy, w=w, h=h)
            frames.append(frame)
            views.append(PassthroughView(file_path=name, path=os.path.join(out_dir, name),
                                         rotation=rec, position=m[:3, 3], fl_x=fl, fl_y=fl,
                                         cx=cx, cy=cy, w=w, h=h))
            rotations.append(true)
            exposures.append(math.exp(log_e))
            wbs.append(wb)
            radiances.append(L)
            codes.append(np.ascontiguousarray(recorded))
        doc = {"camera_model": "PINHOLE", "frames": frames}
        if not per_frame_intrinsics:
            doc.update(fl_x=fl, fl_y=fl, cx=cx, cy=cy, w=w, h=h)
        with open(os.path.join(out_dir, "transforms.json"), "w") as f:
            json.dump(doc, f, indent=1)
        return HeadsetTruth(views, rotations, np.array(exposures), np.array(wbs), radiances,
                            codes, rho2, self.camera)


    @staticmethod
    def _near_object(pano, dirs, L, rng):
        """Parallax: an ellipse over ~10 % of the view shows what the sphere sees 15–30° to
        the side (a near surface, seen from metres away from the 360° camera, is somewhere
        else on its sphere)."""
        h, w = L.shape[:2]
        cy, cx = rng.uniform(0.25, 0.75) * h, rng.uniform(0.25, 0.75) * w
        ry, rx = rng.uniform(0.15, 0.25) * h, rng.uniform(0.15, 0.25) * w
        ys, xs = np.mgrid[0:h, 0:w]
        inside = ((ys - cy) / ry) ** 2 + ((xs - cx) / rx) ** 2 <= 1
        turn = look_rotation(rng.choice([-1, 1]) * rng.uniform(15, 30), 0.0)
        shifted = sample_equirect(pano, dirs @ turn.T)
        return np.where(inside[..., None], shifted, L)


# -- the score -------------------------------------------------------------------------------

def _srgb_encode(x):
    x = np.clip(x, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * x ** (1 / 2.4) - 0.055)


def naive_model(truth: HeadsetTruth, sphere: np.ndarray):
    """The baseline as a predictor ``(view, radiance, rho2) -> codes``: frames decoded as
    sRGB, each view's exposure the ratio of its mean to the sphere's mean in its recorded
    directions, no white balance, no vignetting."""
    sphere = np.maximum(np.nan_to_num(np.asarray(sphere, np.float64)), 0.0)
    exposure = []
    for v, z in zip(truth.views, truth.codes):
        ys, xs = np.mgrid[0:v.h:2, 0:v.w:2]
        L = sample_equirect(sphere, v.directions(xs + 0.5, ys + 0.5))
        lin = srgb_decode(z[::2, ::2] / 255.0)
        exposure.append(float(lin.mean()) / max(float(L.mean()), 1e-12))

    def predict(i, radiance, rho2):
        return 255.0 * _srgb_encode(exposure[i] * radiance)
    return predict


def fitted_model(result):
    """A :class:`~provider.core.passthrough.fit.PassthroughResult` as a predictor."""
    return lambda i, radiance, rho2: result.predict_codes(radiance, i, rho2)


def score(truth: HeadsetTruth, predict) -> dict:
    """The issue's score of a predictor (module doc): per-view bias (stops) and the
    pixels' 90th percentile of the worst channel's |error|."""
    g = truth.camera.true_response().table
    codes = np.arange(256, dtype=np.float64)
    biases, pixels = [], []
    for i, (L, z) in enumerate(zip(truth.radiance, truth.codes)):
        pred = np.clip(predict(i, L, truth.rho2), 0.0, 255.0)
        ok = ((z >= 1) & (z <= 254)).all(-1)
        if not ok.any():
            continue
        err = np.stack([np.log2(np.interp(pred[..., c][ok], codes, g[:, c])
                                / np.interp(z[..., c][ok].astype(np.float64), codes, g[:, c]))
                        for c in range(3)], -1)
        biases.append(float(np.abs(np.median(err, axis=0)).max()))
        pixels.append(np.abs(err).max(-1))
    biases = np.array(biases)
    allpix = np.concatenate(pixels)
    return {"views_scored": int(len(biases)),
            "median_view_bias": float(np.median(biases)),
            "p90_view_bias": float(np.percentile(biases, 90)),
            "pixel_p90": float(np.percentile(allpix, 90))}


def measure(paths=None, n_views: int = 40, room_seed: int = 7, seed: int = 3,
            metadata: bool = False, progress=None) -> list[dict]:
    """The score of the fit and of the naive baseline, and the fit's ms per view (one core,
    reading excluded), for a perturbed room from each panorama (default: the shared nine)."""
    import tempfile
    import time
    from pathlib import Path
    from ..core.passthrough import PassthroughFit, read_transforms
    from ..core.passthrough.views import read_view_image
    from ..core.radiometry.images import read_image
    if paths is None:
        paths = sorted((Path(__file__).resolve().parents[1] / "data" / "hdri").glob("*.exr"))
    rows = []
    for path in paths:
        room = perturb_panorama(read_image(path), seed=room_seed)
        with tempfile.TemporaryDirectory() as folder:
            truth = HeadsetSim(n_views=n_views, seed=seed).render(room, folder,
                                                                  metadata=metadata)
            views = read_transforms(os.path.join(folder, "transforms.json"))
            images = [read_view_image(v) for v in views]
            t0 = time.perf_counter()
            fit = PassthroughFit(room)
            for v, img in zip(views, images):
                fit.add_view(v, img)
            result = fit.solve()
            ms = 1000 * (time.perf_counter() - t0) / n_views
        rows.append({"room": f"{Path(path).stem}~{room_seed}", "ms_per_view": ms,
                     "fit": score(truth, fitted_model(result)),
                     "naive": score(truth, naive_model(truth, room))})
        if progress:
            progress(f"  passthrough {rows[-1]['room']}: {ms:.0f} ms/view")
    return rows


KEYS = ("median_view_bias", "p90_view_bias", "pixel_p90")


def table(rows) -> list[str]:
    """The rows as a Markdown table (stops)."""
    lines = ["| room | ms/view | fit: median view | p90 view | pixel p90 | naive: median view "
             "| p90 view | pixel p90 |", "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        cells = [f"{r['fit'][k]:.3f}" for k in KEYS] + [f"{r['naive'][k]:.3f}" for k in KEYS]
        lines.append(f"| {r['room']} | {r['ms_per_view']:.0f} | " + " | ".join(cells) + " |")
    return lines


def bench_passthrough(hdri, out, args) -> list[dict]:
    """``shlight bench --sections passthrough``: writes passthrough.md."""
    from pathlib import Path
    from .common import _progress
    quick = getattr(args, "quick", False)
    paths = list(hdri)[:3] if quick else list(hdri)
    n_views = 20 if quick else 40
    rows = measure(paths, n_views=n_views, progress=_progress)
    lines = ["# Passthrough: the fit against the naive way (stops)", "",
             f"A simulated headset (provider/bench/headset_sim.py), {n_views} views of a "
             "perturbed room (room seed 7) per panorama, no exposure metadata; the issue's "
             "score: a view's bias (median over its unclipped pixels, worst channel), its "
             "90th percentile over views, the pixels' 90th percentile. Target: 0.1 / 0.2 / "
             "0.45. ms/view: the fit's sampling and solve on one core (docs/passthrough.md).",
             "", *table(rows)]
    Path(out, "passthrough.md").write_text("\n".join(lines) + "\n")
    return rows


def main(argv=None) -> int:
    import argparse
    from pathlib import Path
    p = argparse.ArgumentParser(description="the passthrough fit against the naive way, "
                                            "on perturbed rooms (stops)")
    p.add_argument("names", nargs="*", help="shared panoramas (default: all nine)")
    p.add_argument("--views", type=int, default=40)
    p.add_argument("--room-seed", type=int, default=7)
    p.add_argument("--metadata", action="store_true", help="views say their exposure")
    args = p.parse_args(argv)
    hdri = Path(__file__).resolve().parents[1] / "data" / "hdri"
    paths = [hdri / f"{n}.exr" for n in args.names] or None
    rows = measure(paths, args.views, args.room_seed, metadata=args.metadata)
    print("\n".join(table(rows)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
