"""Options of the light-probe projections (``--projection mirrorball`` and ``angular``),
shared by ``compute``, ``serve`` and ``bench`` through :mod:`.options`."""
from __future__ import annotations

import argparse
import math

from ..core.errors import InputError


def ball_circle(text: str):
    """``X,Y,R`` (pixels) or ``auto``."""
    if text.strip().lower() == "auto":
        return "auto"
    try:
        vals = [float(v) for v in text.replace(";", ",").split(",")]
    except ValueError:
        vals = []
    if len(vals) != 3 or not all(math.isfinite(v) for v in vals) or vals[2] <= 0:
        raise argparse.ArgumentTypeError(
            f"expected X,Y,R (the ball's centre and radius in pixels, R > 0) or auto, got {text!r}")
    return tuple(vals)


def add_probe_arguments(g) -> None:
    """Mirror-ball and angular-map options (in the engine options' group ``g``)."""
    g.add_argument("--ball", type=ball_circle, default=None, metavar="X,Y,R|auto",
                   help="mirrorball/angular: the ball's circle in the frame, in pixels (shlight "
                        "locate-ball prints it), or auto: found in the first frame; each frame "
                        "is cropped to it (default: the circle inscribed in the frame)")
    g.add_argument("--ball-unseen", type=float, default=None, metavar="DEG",
                   help="mirrorball: do not use directions within DEG of -Z, behind the ball "
                        "(the grazing rim); default 0")
    g.add_argument("--ball-mask", type=float, default=None, metavar="DEG",
                   help="mirrorball: do not use directions within DEG of +Z (the camera's own "
                        "reflection in the ball's centre); default 0")
    g.add_argument("--ball-fill", default=None, choices=["rim", "zero"],
                   help="mirrorball: fill the unseen cones with the mean of the seen band "
                        "around them (rim, default) or leave them black (zero)")
    g.add_argument("--ball-distance", type=float, default=None, metavar="RADII",
                   help="mirrorball: the camera's distance to the ball's centre in ball radii "
                        "(perspective correction; --fov DEG, the camera's horizontal field of "
                        "view, gives it from the ball's size instead); default: orthographic")


def probe_options(args) -> dict:
    """The projection options of ``--projection mirrorball`` or ``angular``; ``ball`` may be
    "auto" (resolved on a frame by :func:`provider.core.registration.ball.resolve_ball`)."""
    opts: dict = {}
    if args.ball == "auto":
        opts["ball"] = "auto"
    elif args.ball is not None:
        x, y, r = args.ball
        opts.update(center=(x, y), radius=r)
    else:
        if args.center is not None:
            opts["center"] = tuple(args.center)
        if args.radius is not None:
            opts["radius"] = args.radius
    if args.projection != "mirrorball":
        return opts
    unseen = 0.0 if args.ball_unseen is None else args.ball_unseen
    mask = 0.0 if args.ball_mask is None else args.ball_mask
    for flag, value in (("--ball-unseen", unseen), ("--ball-mask", mask)):
        if not (math.isfinite(value) and 0 <= value < 90):
            raise InputError(f"{flag} {value:g}: an angle in [0, 90) degrees")
    opts.update(unseen_deg=unseen, mask_deg=mask, fill=args.ball_fill or "rim")
    if args.ball_distance is not None:    # with --fov too: refused (options.CONFLICTS)
        if not (math.isfinite(args.ball_distance) and args.ball_distance > 1):
            raise InputError(f"--ball-distance {args.ball_distance:g}: in ball radii, more "
                             "than 1 (the camera is outside the ball)")
        opts["distance"] = args.ball_distance
    elif args.fov is not None:
        if not 0 < args.fov < 180:
            raise InputError(f"--fov {args.fov:g}: the camera's field of view is in (0, 180) "
                             "degrees for a mirror ball")
        opts["fov_deg"] = args.fov
    return opts
