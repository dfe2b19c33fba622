"""``shlight calibrate-response``: a camera's response curve from a bracket of one view."""
from __future__ import annotations

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
                        "such as 1/60 (at least three)")
    p.add_argument("-o", "--output", required=True, metavar="CAMERA.json",
                   help="where to write the response; a PNG of the curve beside sRGB is "
                        "written next to it (CAMERA.png)")
    p.add_argument("--method", choices=["debevec", "robertson"], default="debevec",
                   help="OpenCV calibration (default debevec; robertson measured 5-7 %% off)")
    p.add_argument("--samples", type=int, default=None,
                   help="Debevec: pixels sampled (default 150)")
    p.add_argument("--lambda", dest="lambda_", type=float, default=None,
                   help="Debevec: smoothness (default 50; grow it with --samples, ~samples/3)")


def run(args) -> int:
    from ..bench.response_plot import plot_response
    from ..core.errors import InputError
    from ..core.response import DEBEVEC_LAMBDA, DEBEVEC_SAMPLES, calibrate
    from ..live.camerafile import save_camera
    from .frames import read_frames
    if len(args.frames) < 3:
        raise InputError(f"calibration needs at least 3 frames of one static view, got "
                         f"{len(args.frames)}")
    print(f"reading {len(args.frames)} frames ...", file=sys.stderr, flush=True)
    images, times, paths = read_frames(args.frames, need_times=True)
    kw = {}
    if args.method == "debevec":
        kw = dict(samples=args.samples or DEBEVEC_SAMPLES,
                  lambda_=DEBEVEC_LAMBDA if args.lambda_ is None else args.lambda_)
    print(f"calibrating ({args.method}) ...", file=sys.stderr, flush=True)
    response = calibrate(images, times, args.method, **kw)
    response.params["frames"] = [os.path.basename(p) for p in paths]
    save_camera(response, args.output)
    png = os.path.splitext(args.output)[0] + ".png"
    plot_response(response, png)
    print("\n".join(summary_lines(response)))
    print(f"wrote {args.output} and {png}")
    return 0


def summary_lines(response) -> list[str]:
    """The recovered curve, in a few lines a person can judge."""
    s = response.summary()
    times = s["exposure_times"] or []
    p = response.params
    how = (f"{p.get('samples')} samples, lambda {p.get('lambda'):g}"
           if response.method == "debevec" else f"{p.get('max_iter')} iterations")
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
