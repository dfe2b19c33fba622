"""Photometry on the simulated camera (issue 31; tooling, not product): absolute lux from a
still's own exposure on held-out brackets, a bracket's span, the clipped sun closed by a lux
meter, and colour temperature. Prints the numbers and draws docs/photometry.png:

    python -m provider.bench.photometry --out docs

The camera is :class:`~provider.bench.camera_sim.CameraSim` (filmic per-channel curve, shot
and read noise) with its own sensitivity 1.3× an ideal ISO 12232 camera's; each panorama is
scaled to a mean luminance of 60 cd/m². The camera is calibrated once (apartment, ±4 EV,
f/2, ISO 100, the exact up-facing illuminance as the lux meter's reading), then every other
panorama is bracketed at other apertures and ISOs and read from its exposure alone.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from ..core.geometry import sh
from ..core.geometry.projections import Equirect
from ..core.radiometry.bracket import merge
from ..core.sh9.bracket_projection import project_bracket
from ..core.radiometry.colour_temperature import cct_duv
from ..core.radiometry.images import read_image
from ..core.radiometry.photometry import NOMINAL_CD_M2, calibrate_absolute, luminance
from ..core.radiometry.response_fit import calibrate_best
from ..core.sh9.engine import SH9Projector
from ..core.sh9.meter import UP, close_clipped, up_weights
from .camera_sim import CameraSim, auto_exposure

HDRI = Path(__file__).resolve().parent.parent / "data" / "hdri"
NOISE = dict(shot=5e-5, read=2e-4)
CAMERA_K = 1.3 / NOMINAL_CD_M2
ROOM_CD_M2 = 60.0
#: (f-number, ISO, exposure bias in EV against the meter): frames that differ in code values.
HELD_OUT = ((5.6, 400, 0.0), (2.8, 800, 0.7), (8.0, 200, -1.3))
BRACKET = (-6, -4, -2, 0, 2, 4)


def _scene(name):
    hdr = np.maximum(read_image(str(HDRI / f"{name}.exr")), 0).astype(np.float64)
    return hdr * (ROOM_CD_M2 / float(luminance(hdr.reshape(-1, 3)).mean()))


def _truth_lux(hdr):
    cos = up_weights(Equirect(hdr.shape[1], hdr.shape[0]))[0]
    return float(luminance(np.tensordot(cos, hdr, axes=([0, 1], [0, 1]))))


def _bracket(hdr, evs, n, iso, seed=0, bias_ev=0.0):
    cam = CameraSim(gain=CAMERA_K * (iso / 100.0) / n ** 2, seed=seed, **NOISE)
    t0 = 12.5 * n ** 2 / (float(luminance(hdr.reshape(-1, 3)).mean()) * iso) * 2 ** bias_ev
    return cam.bracket(hdr, t0, evs)


def _calibrated(frames, times, lux: float):
    """The camera calibrated as `calibrate-response BRACKET --lux` does (the ±4 EV bracket
    at f/2, ISO 100, the meter's ``lux``): its response with the absolute scale, and a
    projector built on it."""
    response = calibrate_best(frames, times)
    projector = SH9Projector(512, 256, "equirect", response=response)
    merged = merge(frames, times, response, gain=1.0).radiance
    response.params["absolute"] = calibrate_absolute(projector.up_illuminance(merged),
                                                     lux, 2.0, 100)
    return response, SH9Projector(512, 256, "equirect", response=response)


def absolute(names):
    """{(scene, f-number, ISO): (illuminance_lux read, truth, clipped_light_fraction)}."""
    hdr = _scene("apartment")
    frames, times = _bracket(hdr, (-4, -2, 0, 2, 4), 2.0, 100)
    response, projector = _calibrated(frames, times, _truth_lux(hdr))
    out = {}
    for name in names:
        hdr = _scene(name)
        for n, iso, bias in HELD_OUT:
            frames, times = _bracket(hdr, BRACKET, n, iso, seed=3, bias_ev=bias)
            r = project_bracket(projector, frames, times, gain=iso / 100.0, f_number=n)
            out[(name, n, iso)] = (r.stats["illuminance_lux"], _truth_lux(hdr),
                                   r.stats["clipped_light_fraction"])
    return response.params["absolute"], out


def span(names):
    """{scene: (±6/±4 level change with trusted weights, with the plain hat)} (green L00)."""
    cam = CameraSim(clip_stops=(2.5, 2.45, 2.55), shot=2e-4, read=2e-3)
    projector = SH9Projector(512, 256, "equirect")
    out = {}
    for name in names:
        hdr = np.maximum(read_image(str(HDRI / f"{name}.exr")), 0)
        t0 = auto_exposure(hdr)
        frames, times = cam.bracket(hdr, t0, (-4, -2, 0, 2, 4))
        response = calibrate_best(frames, times)
        plain = type(response)(response.table, method=response.method,
                               params={k: v for k, v in response.params.items()
                                       if not k.startswith("trusted_codes")})
        change = []
        for r in (response, plain):
            levels = [projector.project(merge(*cam.bracket(hdr, t0, evs, seed=1), r)
                                        .radiance).coefficients[0, 1]
                      for evs in ((-4, -2, 0, 2, 4), (-6, -4, -2, 0, 2, 4, 6))]
            change.append(levels[1] / levels[0] - 1)
        out[name] = tuple(change)
    return out


#: How the simulated meter is used in :func:`sun`: (label, where it faces, reads CCT/Duv).
#: "up": +Y; "sun": held toward the true sun, told ``--lux-facing sun`` (the closure faces
#: the largest clipped blob); "az,el": held toward the true sun, its direction said 5° off
#: (a user's aim).
METER_CASES = (("up, lux", "up", False), ("up, lux + CCT", "up", True),
               ("sun, lux + CCT", "sun", True), ("AZ,EL, lux", "az,el", False),
               ("AZ,EL, lux + CCT", "az,el", True))
AIM_ERROR_DEG = 5.0
#: The up-facing illuminance each panorama of :func:`sun` is scaled to (lux).
DAYLIGHT_UP_LUX = 20000.0


def _meter_reading(hdr, normal):
    """(lux, (CCT K, Duv)) a meter with ``normal`` reads: Σ Y(L) max(d·n, 0) dω over the
    panorama's pixels, and the CCT/Duv of the light it sees (a chroma meter)."""
    _, omega, dirs = up_weights(Equirect(hdr.shape[1], hdr.shape[0]))
    rgb = np.tensordot(np.maximum(dirs @ normal, 0) * omega, hdr.astype(np.float64),
                       axes=([0, 1], [0, 1]))
    return float(luminance(rgb)), cct_duv(rgb)


def sun(names):
    """{scene: (RMS irradiance error of one auto-exposed frame, then with the meter of each
    :data:`METER_CASES`)}. The true sun is the panorama's brightest pixel; the meter's
    reading is exact (its own tolerance is not simulated). Each panorama is scaled to an
    outdoor day's :data:`DAYLIGHT_UP_LUX` (a sun is told from a lamp by daylight)."""
    cam = CameraSim()
    response = cam.true_response()
    weights = up_weights(Equirect(512, 256))
    projector = SH9Projector(512, 256, "equirect")
    out = {}
    for name in names:
        hdr = np.maximum(read_image(str(HDRI / f"{name}.exr")), 0).astype(np.float32)
        hdr *= np.float32(DAYLIGHT_UP_LUX / _truth_lux(hdr))
        truth = sh.sphere_irradiance(projector.project(hdr).coefficients)
        t = auto_exposure(hdr)
        frame = cam.capture(hdr, t)
        radiance = response.linearise(frame, t)
        clipped = (frame == 255).any(axis=2)
        clip_level = response.linearise(np.full((1, 1, 3), 255, np.uint8), t).reshape(3)
        brightest = np.unravel_index(np.argmax(luminance(hdr)), hdr.shape[:2])
        sun_direction = weights[2][brightest]
        # the direction the user says: the sun's, tilted AIM_ERROR_DEG toward the zenith
        tilt = np.cross(np.cross(sun_direction, UP), sun_direction)
        tilt /= max(np.linalg.norm(tilt), 1e-12)
        a = np.radians(AIM_ERROR_DEG)
        said = np.cos(a) * sun_direction + np.sin(a) * tilt
        closed = [radiance]
        for _, facing, chroma in METER_CASES:
            lux, cct = _meter_reading(hdr, UP if facing == "up" else sun_direction)
            r, _ = close_clipped(radiance, clipped, weights, lux,
                                 facing={"up": None, "sun": "sun", "az,el": said}[facing],
                                 colour=cct if chroma else None, codes=frame,
                                 clip_level=clip_level)
            closed.append(r)
        errs = []
        for r in closed:
            e = sh.sphere_irradiance(projector.project(r).coefficients)
            errs.append(float(np.sqrt(np.mean((e - truth) ** 2)) / np.sqrt(np.mean(truth ** 2))))
        out[name] = tuple(errs)
    return out


#: The analytic suns of docs/photometry.md (elevation °, aerosol optical depth at 500 nm):
#: a high warm sun, a sunset, and others (:mod:`provider.bench.sun_sky`).
SUN_SKIES = ((35.0, 0.5), (4.0, 0.25), (60.0, 0.25), (15.0, 0.5), (8.0, 0.5), (2.0, 0.25))


def _jpeg(frame: np.ndarray) -> np.ndarray:
    """The frame through a JPEG at quality 95 (Pillow, 4:2:0), as a camera's still."""
    import io

    from PIL import Image
    data = io.BytesIO()
    Image.fromarray(frame).save(data, "JPEG", quality=95)
    return np.asarray(Image.open(io.BytesIO(data.getvalue())).convert("RGB"))


def sun_skies(cases=SUN_SKIES):
    """{(elevation, aerosol): (RMS irradiance error of one JPEG closed by an up-facing
    plain lux meter, its ``meter_colour``, the same with a chroma meter's CCT and Duv)}:
    the camera calibrated once on the apartment re-lit (``perturb_panorama``, ±4 EV, f/2,
    ISO 100), each sky shot at f/8, ISO 200 (the test's rooms: tests/core/radiometry/test_sun_colour.py)."""
    from ..core.sh9.meter import project_with_meter
    from .headset_sim import perturb_panorama
    from .sun_sky import HAZY, sunny_sky
    room = perturb_panorama(_scene("apartment"), seed=7).astype(np.float64)
    room *= ROOM_CD_M2 / float(luminance(room.reshape(-1, 3)).mean())
    frames, times = _bracket(room, (-4, -2, 0, 2, 4), 2.0, 100, seed=1)
    frames = [_jpeg(f) for f in frames]
    response, projector = _calibrated(frames, times, _truth_lux(room))
    out = {}
    for elevation, tau in cases:
        hdr, _ = sunny_sky(512, 256, elevation, atmosphere={**HAZY,
                                                           "aerosol_turbidity_500nm": tau})
        truth = sh.sphere_irradiance(projector.project(hdr.astype(np.float32),
                                                       units="cd/m²").coefficients)
        (frame,), (t,) = _bracket(hdr, (0,), 8.0, 200, seed=1)
        frame = _jpeg(frame)
        lux, cct = _meter_reading(hdr, UP)
        errors, said = [], "neutral"
        for colour in (None, cct):
            r, closure = project_with_meter(projector, [frame], [t], 2.0, 8.0, lux,
                                            colour=colour)
            e = sh.sphere_irradiance(r.coefficients)
            errors.append(float(np.sqrt(np.mean((e - truth) ** 2)) / np.sqrt(np.mean(truth ** 2))))
            said = closure.colour_source if colour is None else said
        out[(elevation, tau)] = (errors[0], said, errors[1])
    return out


def blackbody_rgb(t_k: float) -> np.ndarray:
    """Linear Rec. 709 RGB of a blackbody (CIE 1931 2°, no adaptation), max 1, from
    colour-science (the test extra: the reference, never the product's code)."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import colour as cs
        cmfs = cs.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
        xyz = cs.sd_to_XYZ(cs.sd_blackbody(t_k), cmfs)
        rgb = cs.XYZ_to_RGB(xyz, cs.RGB_COLOURSPACES["ITU-R BT.709"], None,
                            chromatic_adaptation_transform=None)
    return rgb / rgb.max()


def colour(names, temperatures=(2700, 4000, 6500)):
    """{(scene, K): CCT read} of brackets (−6…+2 EV) of blackbody-tinted panoramas."""
    cam = CameraSim()
    projector = SH9Projector(512, 256, "equirect")
    out = {}
    for name in names:
        hdr = np.maximum(read_image(str(HDRI / f"{name}.exr")), 0).astype(np.float64)
        edges = np.linspace(0, np.pi, hdr.shape[0] + 1)
        row = np.cos(edges[:-1]) - np.cos(edges[1:])
        mean = (hdr.mean(axis=1) * row[:, None]).sum(axis=0) / row.sum()
        for t_k in temperatures:
            tinted = (hdr / mean * blackbody_rgb(t_k)).astype(np.float32)
            frames, times = cam.bracket(tinted, auto_exposure(tinted), (-6, -4, -2, 0, 2))
            c = projector.project(merge(frames, times, cam.true_response()).radiance)
            read = cct_duv(c.coefficients[0])
            out[(name, t_k)] = read[0] if read else float("nan")
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m provider.bench.photometry")
    p.add_argument("--out", default="docs", help="folder for photometry.png")
    args = p.parse_args(argv)
    Path(args.out).mkdir(parents=True, exist_ok=True)      # the picture's folder, made
    scenes = ["bridge", "city", "dawn", "forest", "lab", "night", "sky", "venice"]
    print("absolute units (held-out brackets, -6..+4 EV, exposure from the stills alone):",
          file=sys.stderr)
    cal, abs_ = absolute(scenes)
    print(f"calibration: C = {cal['cd_m2']:.4g} ({cal['vs_iso12232']:.3f}× ISO 12232 "
          "nominal; the simulated camera is 1/1.3 = 0.769×)")
    for (name, n, iso), (read, truth, clipped) in abs_.items():
        print(f"  {name:8s} f/{n:<4g} ISO {iso:<4d} illuminance_lux {read:10.1f}  truth "
              f"{truth:10.1f}  {100 * (read / truth - 1):+6.1f} %  clipped light "
              f"{100 * clipped:5.1f} %")
    spans = span(["apartment", "forest", "venice"])
    print("a bracket's span (±6 against ±4 EV, green L00, noisy camera clipping at +2.5 EV):")
    for name, (trusted, plain) in spans.items():
        print(f"  {name:9s} trusted-range weights {100 * trusted:+5.2f} %   plain hat "
              f"{100 * plain:+5.2f} %")
    skies = sun_skies()
    print("analytic clear skies, one JPEG, up-facing meter, RMS irradiance error: plain lux "
          "(meter_colour); with CCT and Duv:")
    for (elevation, tau), (plain, said, chroma) in skies.items():
        print(f"  sun {elevation:4.0f}° aerosol {tau:4.2f}  {100 * plain:5.1f} % ({said})  "
              f"{100 * chroma:5.1f} %")
    suns = sun(["sky", "dawn", "bridge", "city"])
    print("one auto-exposed frame, RMS irradiance error over all normals: without a meter; "
          "with one " + "; ".join(c[0] for c in METER_CASES) + ":")
    for name, errs in suns.items():
        print(f"  {name:7s} " + "  ".join(f"{100 * e:5.1f} %" for e in errs))
    cols = colour(["apartment", "forest", "city"])
    print("colour temperature of blackbody-tinted scenes (bracket −6…+2 EV):")
    for (name, t_k), read in cols.items():
        print(f"  {name:9s} {t_k:5d} K  read {read:7.0f} K  {100 * (read / t_k - 1):+5.2f} %")
    _plot(abs_, suns, cols, Path(args.out) / "photometry.png")
    return 0


def _plot(abs_, suns, cols, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(14, 4.2))
    names = sorted({k[0] for k in abs_})
    for j, (n, iso, _) in enumerate(HELD_OUT):
        err = [100 * (abs_[(s, n, iso)][0] / abs_[(s, n, iso)][1] - 1) for s in names]
        ax[0].bar(np.arange(len(names)) + 0.27 * (j - 1), err, 0.27, label=f"f/{n:g}, ISO {iso}")
    ax[0].axhspan(-5, 5, color="green", alpha=0.1)
    ax[0].set_ylim(-8, 8)
    for i, s_ in enumerate(names):
        worst = min(100 * (abs_[k][0] / abs_[k][1] - 1) for k in abs_ if k[0] == s_)
        if worst < -8:      # the sun clipped in every frame: a lux meter's job (middle)
            ax[0].annotate(f"{worst:.0f} %\nsun clipped\nin every frame", (i, -7.5),
                           ha="center", va="bottom", fontsize=7)
    ax[0].set_xticks(range(len(names)), names, rotation=30)
    ax[0].set_ylabel("illuminance_lux error (%)")
    ax[0].set_title("lux from EXIF alone (calibrated at f/2, ISO 100)")
    ax[0].legend(fontsize=8)
    s = list(suns)
    labels = ("one frame",) + tuple(c[0] for c in METER_CASES)
    width = 0.8 / len(labels)
    for j, label in enumerate(labels):
        ax[1].bar(np.arange(len(s)) + width * (j - (len(labels) - 1) / 2),
                  [100 * suns[k][j] for k in s], width, label=label)
    ax[1].set_ylim(0, 40)
    ax[1].axhline(10, color="green", ls="--", lw=1)
    ax[1].set_xticks(range(len(s)), s)
    ax[1].set_ylabel("RMS irradiance error (%)")
    ax[1].set_title("a clipped sun closed by a lux meter")
    ax[1].legend(fontsize=7)
    temps = sorted({k[1] for k in cols})
    for name in sorted({k[0] for k in cols}):
        ax[2].plot(temps, [100 * (cols[(name, t)] / t - 1) for t in temps], "o-", label=name)
    ax[2].axhspan(-2, 2, color="green", alpha=0.1)
    ax[2].set_xlabel("blackbody (K)")
    ax[2].set_ylabel("cct_k error (%)")
    ax[2].set_title("colour temperature of the ambient")
    ax[2].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
