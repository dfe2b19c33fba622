"""Colour and absolute scale through an 8-bit camera whose tone curve is not sRGB (issue
46; tooling, not product): what docs/photometry.md "Through an 8-bit camera" measures.

    python -m provider.bench.photometry_8bit

The camera is :class:`~provider.bench.camera_sim.CameraSim` with a shoulder that clips
2.5 EV above mid-grey, shot and read noise, 1.3× as sensitive as ISO 12232's nominal
camera; its frames go through a JPEG encoder and back (quality 95; chroma 4:4:4 and 4:2:0)
as a camera writes them. It is calibrated once on one room (±4 EV in 2 EV steps, f/2,
ISO 100, an exact up-facing lux meter), then other rooms are read from their exposure
alone. None of the rooms is one of the nine shared panoramas as it is: each is re-lit,
turned and tinted (:func:`~provider.bench.headset_sim.perturb_panorama`), or analytic.
"""
from __future__ import annotations

import sys

import cv2
import numpy as np

from ..core.radiometry.bracket import merge
from ..core.sh9.bracket_projection import project_bracket
from ..core.radiometry.colour_temperature import cct_duv, rgb_of_cct
from ..core.radiometry.images import read_image
from ..core.radiometry.photometry import NOMINAL_CD_M2, calibrate_absolute, luminance
from ..core.radiometry.response_fit import calibrate_best
from ..core.sh9.engine import SH9Projector
from .camera_sim import CameraSim
from .headset_sim import perturb_panorama
from .photometry import HDRI, HELD_OUT

#: The filmic camera of the measurements (and tests/core/radiometry/test_photometry_8bit.py).
CAMERA = dict(clip_stops=(2.5, 2.45, 2.55), shot=2e-4, read=2e-3)
CAMERA_K = 1.3 / NOMINAL_CD_M2
ROOM_CD_M2 = 60.0
CHROMA = {"4:4:4": cv2.IMWRITE_JPEG_SAMPLING_FACTOR_444,
          "4:2:0": cv2.IMWRITE_JPEG_SAMPLING_FACTOR_420}


def sphere_mean(hdr: np.ndarray) -> np.ndarray:
    """Solid-angle mean RGB of an equirect radiance map."""
    edges = np.linspace(0, np.pi, hdr.shape[0] + 1)
    row = np.cos(edges[:-1]) - np.cos(edges[1:])
    return (hdr.mean(axis=1) * row[:, None]).sum(axis=0) / row.sum()


def room(name: str, seed: int, kelvin: float | None = None) -> np.ndarray:
    """A room none of the shared panoramas is: ``name`` re-lit, turned and tinted by
    ``seed``, optionally tinted again to a blackbody's colour, at 60 cd/m² mean."""
    hdr = perturb_panorama(read_image(str(HDRI / f"{name}.exr")), seed).astype(np.float64)
    if kelvin is not None:
        hdr = hdr / sphere_mean(hdr) * rgb_of_cct(kelvin)
    return hdr * (ROOM_CD_M2 / float(luminance(hdr.reshape(-1, 3)).mean()))


def analytic_room(h: int = 256, w: int = 512) -> np.ndarray:
    """A room one frame holds whole (4 stops from its darkest to its brightest): a bright
    ceiling, a warm window toward +X, a darker floor; 60 cd/m² mean."""
    theta = np.pi * (np.arange(h) + 0.5) / h
    phi = 2 * np.pi * ((np.arange(w) + 0.5) / w - 0.5)
    y = np.cos(theta)[:, None] * np.ones(w)
    x = np.sin(theta)[:, None] * np.sin(phi)[None, :]
    lum = 1.0 + 3.0 * np.maximum(y, 0) + 2.0 * np.maximum(x, 0) ** 4
    hdr = lum[..., None] * np.array([1.0, 0.9, 0.8])
    hdr[..., 0] += 1.5 * np.maximum(x, 0) ** 4
    return hdr * (ROOM_CD_M2 / float(luminance(hdr.reshape(-1, 3)).mean()))


def exact_illuminance_up(hdr: np.ndarray) -> float:
    """What an up-facing lux meter reads: Σ Y(L) max(cos θ, 0) dω, exact per row."""
    h, w = hdr.shape[:2]
    edges = np.linspace(0, np.pi, h + 1)
    s2 = np.sin(np.minimum(edges, np.pi / 2)) ** 2
    row = 0.5 * (s2[1:] - s2[:-1]) * (2 * np.pi / w)
    return float(luminance((hdr * row[:, None, None]).sum(axis=(0, 1))))


def true_cct(hdr: np.ndarray) -> float:
    """CCT of the float panorama's L00 (the float path is exact)."""
    h, w = hdr.shape[:2]
    return cct_duv(SH9Projector(w, h, "equirect").project(hdr.astype(np.float32))
                   .coefficients[0])[0]


def capture(hdr, evs, n, iso, *, bias_ev=0.0, seed=0):
    """(frames, times, gain) of a bracket around the metered exposure (mean luminance to
    mid-grey, K = 12.5) × 2**bias_ev at f/n, ISO iso."""
    cam = CameraSim(gain=CAMERA_K * (iso / 100.0) / n ** 2, seed=seed, **CAMERA)
    t0 = 12.5 * n ** 2 / (float(luminance(hdr.reshape(-1, 3)).mean()) * iso) * 2 ** bias_ev
    frames, times = cam.bracket(hdr, t0, evs)
    return frames, times, iso / 100.0


def jpeg(frame: np.ndarray, chroma: str) -> np.ndarray:
    """An RGB frame through a JPEG encoder (quality 95) and back."""
    ok, data = cv2.imencode(".jpg", np.ascontiguousarray(frame[..., ::-1]),
                            [cv2.IMWRITE_JPEG_QUALITY, 95,
                             cv2.IMWRITE_JPEG_SAMPLING_FACTOR, CHROMA[chroma]])
    return np.ascontiguousarray(cv2.imdecode(data, cv2.IMREAD_UNCHANGED)[..., ::-1])


def calibrated(chroma: str):
    """The camera calibrated once on one room, with its absolute scale."""
    hdr = room("apartment", 11)
    frames, times, gain = capture(hdr, (-4, -2, 0, 2, 4), 2.0, 100)
    frames = [jpeg(f, chroma) for f in frames]
    response = calibrate_best(frames, times)
    projector = SH9Projector(hdr.shape[1], hdr.shape[0], "equirect")
    merged = merge(frames, times, response, gain=gain).radiance
    response.params["absolute"] = calibrate_absolute(projector.up_illuminance(merged),
                                                     exact_illuminance_up(hdr), 2.0, 100)
    return response


def lux(response, chroma, rooms=(("forest", 1), ("lab", 2), ("venice", 3), ("night", 4))):
    """{(room, f-number, ISO): illuminance_lux error} of 7-shot ±6 EV brackets."""
    out = {}
    for name, seed in rooms:
        hdr = room(name, seed)
        projector = SH9Projector(hdr.shape[1], hdr.shape[0], "equirect", response=response)
        for n, iso, bias in HELD_OUT:
            frames, times, gain = capture(hdr, (-6, -4, -2, 0, 2, 4, 6), n, iso, bias_ev=bias,
                                          seed=3)
            r = project_bracket(projector, [jpeg(f, chroma) for f in frames], times,
                                gain=gain, f_number=n)
            out[(name, n, iso)] = r.stats["illuminance_lux"] / exact_illuminance_up(hdr) - 1
    return out


def single(response, chroma, settings=((5.6, 400), (2.8, 1600), (11.0, 100))):
    """{(f-number, ISO): illuminance_lux error} of one still of the analytic room."""
    hdr = analytic_room()
    projector = SH9Projector(hdr.shape[1], hdr.shape[0], "equirect", response=response)
    out = {}
    for n, iso in settings:
        (frame,), (t,), gain = capture(hdr, (0,), n, iso, seed=4)
        r = projector.project(jpeg(frame, chroma), exposure_s=t, gain=gain, f_number=n)
        out[(n, iso)] = r.stats["illuminance_lux"] / exact_illuminance_up(hdr) - 1
    return out


def colour(response, chroma, rooms=(("forest", 1), ("venice", 3), ("night", 4), ("city", 5),
                                    ("lab", 2)), kelvins=(2700, 4000, 5000, 6500)):
    """{(room, K): (cct_k error, clipped_light_fraction)} of −4, 0, +4 EV brackets."""
    out = {}
    for name, seed in rooms:
        for k in kelvins:
            hdr = room(name, seed, k)
            projector = SH9Projector(hdr.shape[1], hdr.shape[0], "equirect", response=response)
            frames, times, gain = capture(hdr, (-4, 0, 4), 4.0, 200, seed=5)
            r = project_bracket(projector, [jpeg(f, chroma) for f in frames], times,
                                gain=gain, f_number=4.0)
            read = cct_duv(r.coefficients[0])[0]
            out[(name, k)] = (read / true_cct(hdr) - 1, r.stats["clipped_light_fraction"])
    return out


def main(argv=None) -> int:
    for chroma in CHROMA:
        print(f"JPEG chroma {chroma}:")
        response = calibrated(chroma)
        print(f"  calibrated: trusted codes {response.params['trusted_codes']}, per channel "
              f"{response.params['trusted_codes_rgb']}, "
              f"{response.params['absolute']['vs_iso12232']:.3f}× nominal (truth 0.769×)")
        errs = lux(response, chroma)
        print("  7-shot ±6 EV, lux error: " + ", ".join(
            f"{k[0]} f/{k[1]:g} ISO {k[2]} {100 * v:+.1f} %" for k, v in errs.items()))
        print(f"    worst {100 * max(abs(v) for v in errs.values()):.1f} %")
        errs = single(response, chroma)
        print("  one still of the analytic room, lux error: " + ", ".join(
            f"f/{k[0]:g} ISO {k[1]} {100 * v:+.1f} %" for k, v in errs.items()))
        cols = colour(response, chroma)
        print("  −4/0/+4 EV of tinted rooms, cct_k error (clipped light): " + ", ".join(
            f"{k[0]} {k[1]} K {100 * v:+.1f} % ({100 * c:.0f} %)" for k, (v, c) in cols.items()))
        print(f"    worst {100 * max(abs(v) for v, _ in cols.values()):.1f} %, without lab "
              f"{100 * max(abs(v) for k, (v, _) in cols.items() if k[0] != 'lab'):.1f} %")
        sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
