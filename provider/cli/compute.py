"""``shlight compute``: the wire message of one image."""
from __future__ import annotations

import json
import os

from .options import add_engine_arguments


def add_arguments(p) -> None:
    p.add_argument("image", help="panorama/fisheye image (.exr, .hdr, .png, .jpg, .tif, ...)")
    p.add_argument("--probe", default="default", help="probe name in the message")
    p.add_argument("--pretty", action="store_true", help="indent the JSON")
    add_engine_arguments(p)


def run(args) -> int:
    from ..core.engine import SH9Projector, precompute_note
    from ..core.images import read_image
    from ..live.message import coefficient_message, dumps
    from .feedback import Progress, say
    from .options import engine_options
    options = engine_options(args)
    image = read_image(args.image)
    height, width = image.shape[:2]
    note = precompute_note(width, height, args.projection, args.downsample)
    if note:
        say("compute", "note", note)
    projector = SH9Projector(width, height, args.projection, error_estimate=True,
                             progress=Progress("compute", "per-pixel weights") if note else None,
                             **options)
    for warning in projector.warnings:
        say("compute", "warning", warning)
    result = projector.project(image)
    msg = coefficient_message(result, probe=args.probe, seq=0,
                              time=os.path.getmtime(args.image), projection=args.projection)
    text = dumps(msg) if not args.pretty else json.dumps(msg, indent=2, allow_nan=False)
    print(text)
    return 0
