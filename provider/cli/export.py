"""``shlight export IMAGE --to FORMAT``: one image's lighting in another engine's layout
(the same input as ``compute``: images, FRAME@SECONDS brackets, the engine options)."""
from __future__ import annotations

from .compute import add_input_arguments, print_json, wire_message

_PHASED = ("arcore", "openxr-android")


def add_arguments(p) -> None:
    from ..core.conventions import FORMATS
    p.add_argument("--to", required=True, choices=FORMATS, metavar="FORMAT",
                   help="target layout: " + ", ".join(FORMATS))
    g = p.add_argument_group("where the targets' own sources disagree (see README)")
    g.add_argument("--babylon-handedness", choices=["left", "right"], default=None,
                   help="gltf: the Babylon.js scene's handedness (default left, Babylon's "
                        "default); the two differ by a 180° turn about +Y")
    g.add_argument("--no-condon-shortley", action="store_true",
                   help="arcore, openxr-android: no Condon-Shortley phase (the archived ARCore "
                        "Unity SDK's reading) instead of Google's maintained Android sample's")
    add_input_arguments(p)


def run(args) -> int:
    from ..core.errors import InputError
    from ..live.export import export_message
    options = {}
    if args.babylon_handedness is not None:
        if args.to != "gltf":
            raise InputError("--babylon-handedness applies to --to gltf only")
        options["babylon_handedness"] = args.babylon_handedness
    if args.no_condon_shortley:
        if args.to not in _PHASED:
            raise InputError("--no-condon-shortley applies to --to arcore or openxr-android only")
        options["condon_shortley"] = False
    print_json(export_message(wire_message(args, "export"), args.to, **options), args.pretty)
    return 0
