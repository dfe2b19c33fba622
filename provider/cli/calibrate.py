"""``shlight calibrate-response``: a camera's response curve from a bracket of one view."""
from __future__ import annotations

import math
import os
import sys


def add_arguments(p) -> None:
    p.description = ("Recover a camera's inverse response (its tone curve, per channel) from "
                     "at least three 8-bit frames of one static view at known exposure times "
                     "(OpenCV's Debevec calibration), and write it as camera.json for "
                     "`shlight compute --camera` and `shlight serve --camera`. Keep the "
                     "camera still, the scene unchanged and the gain fixed; 1-2 EV between "
                     "frames, from mostly dark to mostly clipped, works best.")
    p.add_argument("frames", nargs="+", metavar="FRAME@SECONDS",
                   help="an 8-bit image and its exposure time, a decimal or a fraction "
                        "such as 1/60 (at least three); a JPEG/TIFF whose EXIF says its "
                        "ExposureTime needs no @SECONDS")
    p.add_argument("--lux", type=float, default=None, metavar="E",
                   help="absolute units: what an up-facing lux meter at the camera read "
                        "while the bracket was taken; camera.json then turns every later "
                        "frame's own exposure (time, f-number, ISO) into cd/m² "
                        "(docs/photometry.md)")
    p.add_argument("--checker", default=None, metavar="PHOTO",
                   help="an 8-bit photo by this camera of an X-Rite ColorChecker (24 "
                        "patches) under the light to measure: camera.json then holds the "
                        "camera's white balance and 3×3 colour matrix, applied by every "
                        "command that takes --camera (docs/photometry.md)")
    p.add_argument("--f-number", type=float, default=None, metavar="N",
                   help="with --lux: the aperture, where the frames' EXIF does not say it")
    p.add_argument("--iso", type=float, default=None, metavar="S",
                   help="with --lux: the ISO, where the frames' EXIF does not say it")
    p.add_argument("--projection", choices=["equirect", "fisheye"], default="equirect",
                   help="with --lux: how the frames map directions (default equirect)")
    p.add_argument("-o", "--output", required=True, metavar="CAMERA.json",
                   help="where to write the response; a PNG of the curve beside sRGB is "
                        "written next to it (CAMERA.png)")
    p.add_argument("--method", choices=["auto", "debevec", "robertson"], default="auto",
                   help="auto (default): the curve that explains the frames best, among "
                        "Debevec with well-spread samples at several smoothness weights and "
                        "OpenCV's Debevec and Robertson; debevec or robertson: OpenCV's alone")
    p.add_argument("--samples", type=int, default=None,
                   help="pixels sampled (auto: 1000, spread over the scene's radiance; "
                        "debevec: 150)")
    p.add_argument("--lambda", dest="lambda_", type=float, default=None,
                   help="debevec: smoothness, above 0 and at most 1e6 (default 50; grow it "
                        "with --samples, ~samples/3; auto chooses it)")


def run(args) -> int:
    from ..bench.response_plot import plot_response
    from ..core.errors import InputError
    from ..core.radiometry.response import DEBEVEC_LAMBDA, DEBEVEC_SAMPLES, calibrate
    from ..core.radiometry.response_fit import (calibrate_best, disagreement,
                                                frame_disagreement)
    from ..live.probe.camerafile import save_camera
    from .compute import exposure_of
    from .frames import read_exposed_frames
    camera, picture = check_arguments(args)
    print(f"reading {len(args.frames)} frames ...", file=sys.stderr, flush=True)
    images, exposures, paths = read_exposed_frames(args.frames, need_times=True,
                                                   command="calibrate-response")
    times, gain, f_number = exposure_of(exposures)
    f_number, iso = args.f_number or f_number, args.iso or exposures[0].iso
    check_frames(images, times, args.samples)
    print(f"calibrating ({args.method}) ...", file=sys.stderr, flush=True)
    if args.method == "auto":
        response = calibrate_best(images, times, samples=args.samples or 1000)
    else:
        kw = {}
        if args.method == "debevec":
            kw = dict(samples=args.samples or DEBEVEC_SAMPLES,
                      lambda_=DEBEVEC_LAMBDA if args.lambda_ is None else args.lambda_)
        response = calibrate(images, times, args.method, **kw)
        response.params["quality"] = {
            "curve": disagreement(response.table, images, times),
            "srgb": disagreement(CameraResponseSRGB(), images, times)}
    if not all(math.isfinite(v) and v > 0 for v in response.table.ravel()):
        raise InputError("the calibration gave a broken curve (not positive and finite): "
                         "are the frames one static view with these exposure times?")
    response.params["frames"] = [os.path.basename(p) for p in paths]
    response.params["frame_disagreement_stops"] = frame_disagreement(images, times, response)
    if args.lux is not None:
        response.params["absolute"] = absolute_scale(response, images, times, args.lux,
                                                     f_number, iso, args.projection)
    if args.checker is not None:            # the camera's colour (provider/cli/checker.py)
        from .checker import checker_params
        response.params.update(checker_params(response, args.checker))
    with camera.writing() as tmp:
        save_camera(response, tmp)
    with picture.writing() as tmp:
        plot_response(response, tmp)
    png = picture.path
    from .checker import checker_lines
    print("\n".join(summary_lines(response) + quality_lines(response)
                    + agreement_lines(response) + absolute_lines(response)
                    + checker_lines(response)))
    print(f"wrote {args.output} and {png}")
    warn_disagreement(response)
    return 0


def agreement_lines(response) -> list[str]:
    """Each frame's light against the others' merge, in stops (camera.json
    ``params.frame_disagreement_stops``)."""
    stops = response.params.get("frame_disagreement_stops") or []
    names = response.params.get("frames") or [f"frame {i}" for i in range(len(stops))]
    known = [v for v in stops if v is not None]
    if not known:
        return []
    return ["each frame's light against the other frames' merge (stops; its exposure "
            "time, f-number and ISO as given): "
            + ", ".join(f"{n} {'?' if v is None else f'{v:+.3f}'}"
                        for n, v in zip(names, stops))
            + f"; they agree within {max(abs(v) for v in known):.3f} stops"]


def warn_disagreement(response) -> None:
    """One warning per frame further than FRAME_DISAGREEMENT_WARN_STOPS from the others."""
    from ..core.radiometry.response_fit import FRAME_DISAGREEMENT_WARN_STOPS as LIMIT
    from .feedback import say
    stops = response.params.get("frame_disagreement_stops") or []
    for name, v in zip(response.params.get("frames") or [], stops):
        if v is not None and abs(v) > LIMIT:
            say("calibrate-response", "warning",
                f"{name} is {v:+.2f} stops ({2 ** v - 1:+.0%}) from the other frames' light: "
                "its exposure time, f-number or ISO is not what the camera did (a rounded "
                "or wrong EXIF, a frame of another bracket?); the curve"
                + (" and the absolute scale carry" if response.params.get("absolute")
                   else " carries") + " it")


def absolute_scale(response, images, times, lux, f_number, iso, projection) -> dict:
    """camera.json ``params.absolute``: the bracket merged with its own curve (gain =
    ISO/100), its exact up-facing illuminance (over the pixels), against the lux meter's
    reading."""
    from ..core.errors import InputError
    from ..core.radiometry.bracket import merge
    from ..core.radiometry.photometry import calibrate_absolute
    from ..core.sh9.engine import SH9Projector
    if not f_number or not iso:
        raise InputError("--lux needs the bracket's f-number and ISO: the frames' EXIF does "
                         "not say " + " and ".join(n for n, v in (("FNumber", f_number),
                                                                  ("ISO", iso)) if not v)
                         + " (give --f-number N and --iso S)")
    height, width = images[0].shape[:2]
    projector = SH9Projector(width, height, projection)
    radiance = merge(images, times, response, gain=iso / 100.0).radiance
    return calibrate_absolute(projector.up_illuminance(radiance), lux, f_number, iso)


def absolute_lines(response) -> list[str]:
    a = response.params.get("absolute")
    if not a:
        return ["units: relative (no --lux: give a lux meter's reading for cd/m² and lux)"]
    return [f"absolute scale: {a['cd_m2']:.4g} cd/m² per N²·g(z)/(t·ISO/100) from "
            f"{a['lux']:g} lux at f/{a['f_number']:g}, ISO {a['iso']:g} "
            f"({a['vs_iso12232']:.2f}× the ISO 12232 nominal camera)"]


def check_arguments(args):
    """Everything about the options, before any frame is read (exit 2, nothing written);
    the two outputs, camera.json and its picture (:func:`.outputs.output_file`)."""
    from ..core.errors import InputError
    from ..core.radiometry.photometry import (F_NUMBER_RANGE, ISO_RANGE, LUX_RANGE,
                                              check_physical)
    if args.lux is not None:
        check_physical("--lux", args.lux, LUX_RANGE, " lux")
    for name, v, bounds in (("--f-number", args.f_number, F_NUMBER_RANGE),
                            ("--iso", args.iso, ISO_RANGE)):
        if v is not None and args.lux is None:
            raise InputError(f"{name} is for --lux (the absolute scale)")
        if v is not None:
            check_physical(name, v, bounds)
    if args.checker is not None and not os.path.isfile(args.checker):
        raise InputError(f"--checker {args.checker}: no such photo")
    if len(args.frames) < 3:
        raise InputError(f"calibration needs at least 3 frames of one static view, got "
                         f"{len(args.frames)}")
    if args.lambda_ is not None:
        if args.method != "debevec":
            raise InputError(f"--lambda is Debevec's smoothness; --method {args.method} "
                             + ("chooses it from the frames" if args.method == "auto"
                                else "has none") + " (use --method debevec)")
        from ..core.radiometry.response import DEBEVEC_LAMBDA_MAX
        if not (math.isfinite(args.lambda_) and 0 < args.lambda_ <= DEBEVEC_LAMBDA_MAX):
            raise InputError("--lambda must be a finite number above 0 and at most "
                             f"{DEBEVEC_LAMBDA_MAX:g} "
                             f"(Debevec's smoothness: default 50, about --samples / 3), got "
                             f"{args.lambda_:g}")
    if args.samples is not None:
        if args.method == "robertson":
            raise InputError("--samples is for --method auto or debevec (robertson uses "
                             "every pixel)")
        if args.samples < 10:
            raise InputError(f"--samples must be at least 10, got {args.samples}")
    from .outputs import frame_inputs, output_file
    inputs = frame_inputs(args.frames, "an input frame")
    camera = output_file(args.output, inputs=inputs, product="response",
                         extension=".json")
    png = os.path.splitext(args.output)[0] + ".png"
    if os.path.abspath(png) == os.path.abspath(args.output):
        raise InputError(f"-o {args.output}: the curve's picture is written beside the "
                         f"response as CAMERA.png; name the response .json, e.g. -o "
                         f"{os.path.splitext(args.output)[0]}.json")
    picture = output_file(png, inputs=inputs, product="curve's picture",
                          name=f"-o {args.output}: its picture {png}",
                          example=f"-o {os.path.splitext(args.output)[0]}-camera.json")
    return camera, picture


def check_frames(images, times, samples) -> None:
    """Frames that cannot give a curve: refused before calibrating."""
    import numpy as np
    from ..core.errors import InputError
    from ..core.radiometry.response import check_bracket
    images, times, bits = check_bracket(images, times)
    if bits != 8:
        raise InputError("calibration needs 8-bit frames (OpenCV's CalibrateDebevec/"
                         "Robertson are 8-bit only)")
    if max(times) / min(times) < 2.0:
        raise InputError("calibration needs exposure times at least 1 EV apart (got "
                         + ", ".join(f"{t:g} s" for t in times) + ")")
    pixels = images[0].shape[0] * images[0].shape[1]
    if samples is not None and samples > pixels:
        raise InputError(f"--samples {samples} is more than the {pixels} pixels of a frame")
    usable = [np.count_nonzero((im > 0) & (im < 255)) for im in images]
    if sum(usable) == 0:
        raise InputError("no frame has a usable code (all are black or clipped white): "
                         "expose from mostly dark to mostly clipped, not beyond")
    order = np.argsort(times)
    means = [float(images[i].mean()) for i in order]
    if means[-1] - means[0] < 1.0:
        raise InputError("the frames do not get brighter with exposure time (identical "
                         "frames, or the times do not match them): one static view at "
                         "different exposure times is needed")


def CameraResponseSRGB():
    from ..core.radiometry.response import CameraResponse
    return CameraResponse.srgb().table


def quality_lines(response) -> list[str]:
    """How well the curve explains its own frames, per code range, beside sRGB."""
    q = response.params.get("quality")
    if not q:
        return []
    lines = ["how well the curve explains its frames (pixels well exposed in two neighbouring "
             "frames: disagreement of g(z)/t, median / 90th percentile):",
             "  codes        curve                sRGB            samples"]
    from ..core.radiometry.response_fit import CODE_RANGES
    for name, lo, hi in CODE_RANGES:
        c, s = q["curve"][name], q["srgb"][name]
        if not c["pairs"]:
            lines.append(f"  {lo:3d}-{hi:3d}  (no pixel pairs: {name})")
            continue
        lines.append(f"  {lo:3d}-{hi:3d}  {c['median'] * 100:6.1f} % / {c['p90'] * 100:6.1f} %  "
                     f"{s['median'] * 100:6.1f} % / {s['p90'] * 100:6.1f} %  {c['pairs']:9d}"
                     f"  {name}")
    trusted = response.params.get("trusted_codes")
    if trusted:
        own = response.params.get("trusted_codes_rgb")
        each = (" (r " + ", g ".join(f"{a}-{b}" for a, b in own[:2]) + f", b {own[2][0]}-"
                f"{own[2][1]} alone)") if own else ""
        lines.append(f"trusted codes {trusted[0]}-{trusted[1]} in every channel{each}: enough "
                     "pixel pairs, well explained; beyond them the curve is extrapolated, "
                     "monotone, and a bracket's merge weighs those codes 1000× less")
    fit = response.params.get("fit")
    if fit:
        lines.append("chosen: " + fit["method"] + (f" lambda {fit['lambda']:g}"
                                                    if fit["lambda"] is not None else "")
                     + (f", {fit['extrapolated']} extrapolated" if fit.get("extrapolated")
                        else "")
                     + " (scores, lower is better: " + ", ".join(
                         f"{k} {v:.3f}" for k, v in fit["candidates"].items()) + ")")
        if fit.get("beats_srgb") is False:
            worse = [name for name, _, _ in CODE_RANGES if q["curve"][name]["pairs"] >= 50
                     and (q["curve"][name]["median"] > q["srgb"][name]["median"]
                          or q["curve"][name]["p90"] > q["srgb"][name]["p90"])]
            lines.append("warning: no fit explains these frames at least as well as sRGB "
                         "in every code range (worse in: " + ", ".join(worse) + "); check "
                         "that the frames are one static view and the times are right")
    return lines


def summary_lines(response) -> list[str]:
    """The recovered curve, in a few lines a person can judge."""
    s = response.summary()
    times = s["exposure_times"] or []
    p = response.params
    if p.get("fit"):
        how = f"{p.get('samples')} samples, best of {len(p['fit']['candidates'])} fits"
    elif response.method == "debevec":
        how = f"{p.get('samples')} samples, lambda {p.get('lambda'):g}"
    else:
        how = f"{p.get('max_iter')} iterations"
    lines = [f"{response.method} calibration from {len(times)} frames, "
             f"{_fmt_time(min(times))} to {_fmt_time(max(times))} ({how})",
             "inverse response g(code): sensor exposure, mid-grey (code 118) = 0.18",
             "  code        r          g          b       sRGB"]
    for i, z in enumerate(s["codes"]):
        lines.append(f"  {z:4d} " + " ".join(f"{s['table'][c][i]:10.5f}" for c in "rgb")
                     + f" {s['srgb'][i]:10.5f}")
    lines += [f"differs from sRGB by {s['error_vs_srgb'] * 100:.1f} % RMS over codes 16-250"
              + (" (decoding this camera as sRGB would be wrong)"
                 if s["error_vs_srgb"] > 0.05 else ""),
              f"channels differ by up to {s['channel_spread'] * 100:.1f} % (codes 16-250)",
              f"codes 1 to 254 span {s['dynamic_range_stops']:.1f} stops"]
    if s["repaired_codes"] and any(s["repaired_codes"]):
        lines.append("codes made monotone (r, g, b): " + ", ".join(map(str, s["repaired_codes"]))
                     + " (extreme codes no sample reached)")
    return lines


def _fmt_time(t: float) -> str:
    return f"1/{1 / t:.0f} s" if t < 0.5 else f"{t:g} s"
