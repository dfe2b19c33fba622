"""``shlight export IMAGE --to FORMAT``: one image's lighting in another engine's layout."""
from __future__ import annotations

import json
import os

from .options import add_engine_arguments

_PHASED = ("arcore", "openxr-android")


def add_arguments(p) -> None:
    from ..core.conventions import FORMATS
    p.add_argument("image", help="panorama/fisheye image (.exr, .hdr, .png, .jpg, .tif, ...)")
    p.add_argument("--to", required=True, choices=FORMATS, metavar="FORMAT",
                   help="target layout: " + ", ".join(FORMATS))
    p.add_argument("--probe", default="default", help="probe name in the message")
    p.add_argument("--pretty", action="store_true", help="indent the JSON")
    g = p.add_argument_group("where the targets' own sources disagree (see README)")
    g.add_argument("--babylon-handedness", choices=["left", "right"], default=None,
                   help="gltf: the Babylon.js scene's handedness (default left, Babylon's "
                        "default); the two differ by a 180° turn about +Y")
    g.add_argument("--no-condon-shortley", action="store_true",
                   help="arcore, openxr-android: no Condon-Shortley phase (the archived ARCore "
                        "Unity SDK's reading) instead of Google's maintained Android sample's")
    add_engine_arguments(p)


def run(args) -> int:
    from ..core.engine import compute_sh9
    from ..core.errors import InputError
    from ..core.images import read_image
    from ..live.export import export_message
    from ..live.message import coefficient_message, dumps
    from .options import engine_options
    options = {}
    if args.babylon_handedness is not None:
        if args.to != "gltf":
            raise InputError("--babylon-handedness applies to --to gltf only")
        options["babylon_handedness"] = args.babylon_handedness
    if args.no_condon_shortley:
        if args.to not in _PHASED:
            raise InputError("--no-condon-shortley applies to --to arcore or openxr-android only")
        options["condon_shortley"] = False
    image = read_image(args.image)
    result = compute_sh9(image, projection=args.projection, error_estimate=False,
                         **engine_options(args))
    msg = coefficient_message(result, probe=args.probe, seq=0,
                              time=os.path.getmtime(args.image))
    out = export_message(msg, args.to, **options)
    print(dumps(out) if not args.pretty else json.dumps(out, indent=2, allow_nan=False))
    return 0
