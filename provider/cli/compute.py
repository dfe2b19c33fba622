"""``shlight compute``: the wire message of one image, or of a bracket of frames."""
from __future__ import annotations

import json
import os

from .options import add_engine_arguments


def add_arguments(p) -> None:
    p.add_argument("image", nargs="+", metavar="IMAGE[@SECONDS]",
                   help="panorama/fisheye image (.exr, .hdr, .png, .jpg, .tif, ...). With its "
                        "exposure time, IMAGE@SECONDS (a decimal or a fraction such as 1/60): "
                        "radiance per second of exposure; several IMAGE@SECONDS of one static "
                        "view (8- or 16-bit): merged first (hat-weighted)")
    p.add_argument("--probe", default="default", help="probe name in the message")
    p.add_argument("--pretty", action="store_true", help="indent the JSON")
    add_engine_arguments(p)


def run(args) -> int:
    from ..core.bracket import project_bracket
    from ..core.engine import SH9Projector
    from ..core.engine_options import precompute_note
    from ..live.message import coefficient_message, dumps
    from .feedback import Progress, say
    from .frames import read_frames
    from .options import engine_options
    several = len(args.image) > 1
    images, times, paths = read_frames(args.image, need_times=several)
    options = engine_options(args)
    image = images[0]
    if several:
        from ..core.response import check_bracket
        check_bracket(images, times)  # sizes, pixel types, times: one clear line each
    height, width = image.shape[:2]
    note = precompute_note(width, height, args.projection, args.downsample)
    if note:
        say("compute", "note", note)
    projector = SH9Projector(width, height, args.projection, error_estimate=True,
                             progress=Progress("compute", "per-pixel weights") if note else None,
                             **options)
    for warning in projector.warnings:
        say("compute", "warning", warning)
    if several:
        result = project_bracket(projector, images, times)
    else:
        result = projector.project(image, exposure_s=times[0])
    msg = coefficient_message(result, probe=args.probe, seq=0,
                              time=os.path.getmtime(paths[0]), projection=args.projection)
    text = dumps(msg) if not args.pretty else json.dumps(msg, indent=2, allow_nan=False)
    print(text)
    return 0
