"""`shlight` command line: compute | serve | validate-shaders | bench.

User errors (bad files, bad options) print one clear line to stderr and exit with status
2; they never show a traceback.
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np

from . import __version__
from .engine import InputError


def _floats(text: str, n: int, what: str):
    try:
        vals = [float(v) for v in text.replace(";", ",").split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"{what}: expected {n} comma-separated numbers")
    if len(vals) != n:
        raise argparse.ArgumentTypeError(f"{what}: expected {n} numbers, got {len(vals)}")
    return vals


def add_engine_arguments(p: argparse.ArgumentParser) -> None:
    """Projection and engine options shared by `compute`, `serve` and `bench`."""
    g = p.add_argument_group("projection and engine options")
    g.add_argument("--projection", default="equirect",
                   choices=["equirect", "fisheye", "dual-fisheye", "cubemap"],
                   help="image geometry (default: equirect, 2:1)")
    g.add_argument("--encoding", default="auto", choices=["auto", "srgb", "linear"],
                   help="transfer function of 8/16-bit input (auto = sRGB; float is linear)")
    g.add_argument("--exposure", type=float, default=1.0,
                   help="linear scale on radiance (e.g. 2**EV); default 1")
    g.add_argument("--downsample", type=int, default=1,
                   help="fast path: area-average the linearised frame by this factor")
    g.add_argument("--order", default="2", choices=["0", "1", "2", "auto"],
                   help="highest SH band kept (auto: lowest within --order-budget)")
    g.add_argument("--order-budget", type=float, default=0.02,
                   help="irradiance error budget for --order auto (default 0.02 = 2%%)")
    g.add_argument("--dering", default="off", choices=["off", "auto"],
                   help="auto: window the SH just enough that irradiance is never negative")
    g.add_argument("--rotate", metavar="YAW,PITCH,ROLL", default=None,
                   type=lambda t: _floats(t, 3, "--rotate"),
                   help="sensor rotation in degrees (about +Y, +X, -Z), applied to coefficients")
    g.add_argument("--fov", type=float, default=None,
                   help="fisheye field of view in degrees (fisheye 180, dual-fisheye 200)")
    g.add_argument("--center", metavar="CX,CY", default=None,
                   type=lambda t: _floats(t, 2, "--center"), help="fisheye image-circle centre (px)")
    g.add_argument("--radius", type=float, default=None,
                   help="fisheye pixel radius at fov/2 (default: inscribed circle)")
    g.add_argument("--calibration", default=None,
                   help="JSON file with an OpenCV fisheye calibration {\"K\": 3x3, \"D\": 4}")
    g.add_argument("--fill", default="ground", choices=["ground", "mirror", "zero"],
                   help="fisheye: model of the unseen hemisphere (default ground)")
    g.add_argument("--albedo", type=float, default=0.1,
                   help="fisheye fill albedo (default 0.1, measured best on real scenes)")


def engine_options(args) -> dict:
    """Translate parsed arguments into :class:`~provider.engine.SH9Projector` options."""
    from .sh import rotation_from_euler
    opts = dict(encoding=args.encoding, exposure=args.exposure, downsample=args.downsample,
                order=args.order if args.order == "auto" else int(args.order),
                order_budget=args.order_budget, dering=args.dering)
    if args.rotate:
        opts["rotation"] = rotation_from_euler(*args.rotate)
    if args.projection == "fisheye":
        opts.update(fill=args.fill, albedo=args.albedo)
        if args.fov is not None:
            opts["fov_deg"] = args.fov
        if args.center is not None:
            opts["center"] = tuple(args.center)
        if args.radius is not None:
            opts["radius"] = args.radius
        if args.calibration:
            try:
                with open(args.calibration) as f:
                    cal = json.load(f)
                opts["K"], opts["D"] = np.asarray(cal["K"], float), np.asarray(cal["D"], float)
            except (OSError, ValueError, KeyError) as exc:
                raise InputError(f"cannot use calibration {args.calibration}: {exc}") from None
    elif args.projection == "dual-fisheye" and args.fov is not None:
        opts["fov_deg"] = args.fov
    return opts


def cmd_compute(args) -> int:
    from .engine import compute_sh9
    from .io import read_image
    from .message import coefficient_message, dumps
    import os
    image = read_image(args.image)
    result = compute_sh9(image, projection=args.projection, error_estimate=True,
                         **engine_options(args))
    msg = coefficient_message(result, probe=args.probe, seq=0,
                              time=os.path.getmtime(args.image), projection=args.projection)
    text = dumps(msg) if not args.pretty else json.dumps(msg, indent=2, allow_nan=False)
    print(text)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="shlight", description="Live SH9 ambient lighting for AR headsets.")
    parser.add_argument("--version", action="version", version=f"shlight {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")

    p = sub.add_parser("compute", help="print the wire JSON (DESIGN.md §3) for one image")
    p.add_argument("image", help="panorama/fisheye image (.exr, .hdr, .png, .jpg, .tif, ...)")
    p.add_argument("--probe", default="default", help="probe name in the message")
    p.add_argument("--pretty", action="store_true", help="indent the JSON")
    add_engine_arguments(p)
    p.set_defaults(func=cmd_compute)

    for name, module, helptext in (
            ("serve", "server", "serve live coefficients over WebSocket (default: demo source)"),
            ("validate-shaders", "harness", "prove the GLSL/HLSL compute what the CPU computes"),
            ("bench", "bench", "speed against error: Markdown table and PNG plot")):
        p = sub.add_parser(name, help=helptext)
        try:
            mod = __import__(f"provider.{module}", fromlist=["add_arguments", "run"])
        except ImportError as exc:  # the subcommand's module is not installed/built
            p.set_defaults(func=lambda a, e=exc, n=name: _missing(n, e))
            continue
        mod.add_arguments(p)
        p.set_defaults(func=mod.run)
    return parser


def _missing(name, exc):
    print(f"shlight {name}: unavailable ({exc})", file=sys.stderr)
    return 2


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except InputError as exc:
        print(f"shlight {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"shlight {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
