"""``shlight export IMAGE --to FORMAT``: one image's lighting in another engine's layout
(the same input as ``compute``: images, FRAME@SECONDS brackets, the engine options).

``--to gltf`` also makes the reflection cube for ``EXT_lights_image_based``'s
``specularImages`` (its mips at Babylon.js's roughness, :mod:`provider.core.reflections.gltf_ibl`), and
``--to arcore`` the 16² cube of ``acquireEnvironmentalHdrCubeMap``; ``--no-cube`` skips it."""
from __future__ import annotations

from .compute import add_input_arguments, print_json, wire_message

_PHASED = ("arcore", "openxr-android")
#: Formats that carry a reflection cube, and the face size each gets by default.
CUBE_FORMATS = {"gltf": 32, "arcore": 16}


def add_arguments(p) -> None:
    from ..core.conventions.formats import FORMATS
    p.add_argument("--to", required=True, choices=FORMATS, metavar="FORMAT",
                   help="target layout: " + ", ".join(FORMATS))
    g = p.add_argument_group("where the targets' own sources disagree (docs/engines.md)")
    g.add_argument("--babylon-handedness", choices=["left", "right"], default=None,
                   help="gltf: the Babylon.js scene's handedness (default left, Babylon's "
                        "default); the two differ by a 180° turn about +Y")
    g.add_argument("--no-condon-shortley", action="store_true",
                   help="arcore, openxr-android: no Condon-Shortley phase (the archived ARCore "
                        "Unity SDK's reading) instead of Google's maintained Android sample's")
    c = p.add_argument_group("the reflection cube (gltf specularImages, arcore cube map)")
    c.add_argument("--cube-size", type=int, default=None, metavar="N",
                   help="gltf: edge of mip 0 (specularImageSize), a power of two from 8 to "
                        "256 (default 32); arcore: always 16, ARCore's size")
    c.add_argument("--no-cube", action="store_true",
                   help="gltf, arcore: SH only, no cube (gltf then lists specularImages as "
                        "missing); the other formats carry no cube")
    add_input_arguments(p)


def run(args) -> int:
    from ..core.errors import InputError
    from ..live.wire.export import export_message
    options = {}
    if args.babylon_handedness is not None:
        if args.to != "gltf":
            raise InputError("--babylon-handedness applies to --to gltf only")
        options["babylon_handedness"] = args.babylon_handedness
    if args.no_condon_shortley:
        if args.to not in _PHASED:
            raise InputError("--no-condon-shortley applies to --to arcore or openxr-android only")
        options["condon_shortley"] = False
    size = cube_size(args)
    message = wire_message(args, "export")
    if size is not None:
        options["environment"] = cube_mips(args, size)
    print_json(export_message(message, args.to, **options), args.pretty)
    return 0


def cube_size(args) -> int | None:
    """The edge of the reflection cube's mip 0, checked before any work (None: no cube for
    this format, or ``--no-cube``); :class:`InputError` for a size that cannot be, as
    ``environment --size`` refuses it, never a silent default."""
    from ..core.errors import InputError
    from ..live.reflections.cube import check_size
    if args.cube_size is not None:
        if args.to != "gltf":
            raise InputError("--cube-size applies to --to gltf only (ARCore's cube is 16²)")
        if args.no_cube:
            raise InputError("--cube-size sizes the cube that --no-cube leaves out: give one")
        try:
            return check_size(args.cube_size)
        except InputError:
            raise InputError(f"--cube-size {args.cube_size}: a power of two from 8 to 256 "
                             f"(default {CUBE_FORMATS['gltf']})") from None
    if args.no_cube and args.to not in CUBE_FORMATS:     # the rule of options that do nothing
        raise InputError(f"--no-cube has no effect with --to {args.to}: it carries no "
                         f"reflection cube (only {' and '.join(CUBE_FORMATS)} do); leave it out")
    if args.to not in CUBE_FORMATS or args.no_cube:
        return None
    return CUBE_FORMATS[args.to]


def cube_mips(args, size: int) -> list:
    """The reflection cube of the command line's input (a bracket: its median exposure, as
    ``serve --environment`` does), with the same engine options as the coefficients, so the
    two carry the same units and rotation; for gltf prefiltered at Babylon's roughness."""
    from ..core.reflections.environment import EnvironmentProjector
    from ..core.reflections.gltf_ibl import babylon_roughness
    from ..live.reflections.cube import check_size, cube_options
    from .compute import locate_ball_note
    from .feedback import say
    from .frames import read_frames
    from .options import engine_options
    size = check_size(size)
    images, times, _ = read_frames(args.image, need_times=len(args.image) > 1,
                                   max_pixels=args.max_frame_pixels)
    k = sorted(range(len(images)), key=lambda i: times[i] or 0.0)[len(images) // 2]
    options = engine_options(args)
    if options.get("ball") == "auto":
        options = locate_ball_note(options, images[k], "export")
    extra = {"mip_roughness": babylon_roughness(size)} if args.to == "gltf" else {}
    projector = EnvironmentProjector(images[k].shape[1], images[k].shape[0], args.projection,
                                     size=size, **cube_options(options), **extra)
    for warning in projector.warnings:
        say("export", "warning", f"cube: {warning}")
    mips = projector.project(images[k], exposure_s=times[k]).mips
    from ..core.options import check_cube_lighting
    check_cube_lighting(mips, options.get("exposure", 1.0), times[k])
    return mips if args.to == "gltf" else mips[:1]
