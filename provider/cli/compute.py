"""``shlight compute``: the wire message of one image, or of a bracket of frames."""
from __future__ import annotations

import json
import os

from .options import add_budget_argument, add_engine_arguments, add_table_cache_argument


def add_input_arguments(p) -> None:
    """The input of ``compute`` (and ``export``): images, or FRAME@SECONDS brackets, and the
    engine options."""
    p.add_argument("image", nargs="+", metavar="IMAGE[@SECONDS]",
                   help="panorama/fisheye image (.exr, .hdr, .png, .jpg, .tif, ...). With its "
                        "exposure time, IMAGE@SECONDS (a decimal or a fraction such as 1/60): "
                        "radiance per second of exposure; several IMAGE@SECONDS of one static "
                        "view (8- or 16-bit): merged first (hat-weighted)")
    p.add_argument("--probe", default="default", help="probe name in the message")
    p.add_argument("--pretty", action="store_true", help="indent the JSON")
    add_budget_argument(p, 0, "the command fails with one line (exit 2)")
    add_engine_arguments(p)
    add_table_cache_argument(p)


def add_arguments(p) -> None:
    add_input_arguments(p)
    p.add_argument("--lux", type=float, default=None, metavar="E",
                   help="an up-facing lux meter's reading at the camera, taken with the "
                        "frame: the light it sees beyond what the frame explains goes to the "
                        "clipped region (a clipped sun), as a light and in SH9; needs absolute "
                        "units (--camera calibrated with --lux, the frame's exposure known; "
                        "docs/photometry.md)")
    add_meter_arguments(p)


def add_meter_arguments(p) -> None:
    """``--lux-facing`` and ``--lux-cct`` (compute and serve)."""
    p.add_argument("--lux-facing", default=None, metavar="up|sun|AZ,EL",
                   help="with --lux: where the meter faces: up (default), sun (held toward "
                        "the sun: the largest clipped region), or AZ,EL degrees (azimuth from "
                        "the panorama's front, -Z, toward +X; elevation). Hold it toward a "
                        "low sun: face up, a sun 4° high is seen at sin 4°")
    p.add_argument("--lux-cct", default=None, metavar="K[,DUV]",
                   help="with --lux: a chroma meter's CCT (and Duv) of the same reading: the "
                        "closed light takes the colour the camera does not explain (else "
                        "neutral)")


def wire_message(args, command: str = "compute") -> dict:
    """The wire message of the command line's input: one image (with its exposure time, if
    given) or a bracket merged first; notes and progress on stderr."""
    from ..core.sh9.bracket_projection import project_bracket
    from ..core.sh9.engine import SH9Projector
    from ..core.options import precompute_note
    from ..live.wire.message import coefficient_message
    from .feedback import Progress, say
    from .frames import read_exposed_frames
    from .options import check_meter_arguments, engine_options
    from .options import say_fifo_waits, say_frame_warnings
    facing, colour = check_meter_arguments(args)      # before any work
    several = len(args.image) > 1
    say_fifo_waits(args.image, command)
    images, exposures, paths = read_exposed_frames(args.image, need_times=several,
                                                   max_pixels=args.max_frame_pixels,
                                                   command=command)
    times, gain, f_number = exposure_of(exposures)
    options = engine_options(args)
    image = images[0]
    say_frame_warnings(args, image, command)
    if several:
        from ..core.radiometry.response import check_bracket
        check_bracket(images, times)  # sizes, pixel types, times: one clear line each
    height, width = image.shape[:2]
    if options.get("ball") == "auto":
        options = locate_ball_note(options, image, command)
    note = precompute_note(width, height, args.projection, args.downsample)
    if note:
        say(command, "note", note)
    projector = SH9Projector(width, height, args.projection, error_estimate=True,
                             progress=Progress(command, "per-pixel weights") if note else None,
                             **options)
    for warning in projector.warnings:
        say(command, "warning", warning)
    if getattr(args, "lux", None) is not None:      # one projection, of the closed frame
        result = meter_closed(projector, images, times, gain, f_number, args.lux, command,
                              facing, colour)
    elif several:
        result = project_bracket(projector, images, times, gain=gain, f_number=f_number)
    else:
        result = projector.project(image, exposure_s=times[0], gain=gain, f_number=f_number)
    from .options import say_nonfinite
    say_nonfinite(args, image, result.stats, command)
    if exposures[0].iso:
        result.stats["iso"] = exposures[0].iso
    if projector.response is not None and projector.response.params.get("absolute") \
            and result.stats.get("coefficient_units") != "cd/m²":
        say(command, "note", "the camera has an absolute scale but the frame's exposure time "
                             "is unknown (no @SECONDS, no EXIF ExposureTime): units stay "
                             "relative")
    if not result.coefficients[0].any():      # L00 = 0: not one pixel seen is above 0
        say(command, "warning", f"the frame{'s are' if several else ' is'} all zeros where "
                                "the projection looks: no light, the lighting is black (a "
                                "lens cap, a black render, the wrong file?)")
    return coefficient_message(result, probe=args.probe, seq=0,
                               time=os.path.getmtime(paths[0]), projection=args.projection)


def meter_closed(projector, images, times, gain, f_number, lux, command, facing, colour):
    """``--lux``: the frame(s) projected with the meter's missing light in the clipped blob
    (:func:`provider.core.sh9.meter.project_with_meter`; ``facing``, ``colour``: the meter's
    options as :func:`~provider.cli.options.check_meter_arguments` parsed them), what it
    closed said on stderr."""
    from ..core.sh9.meter import project_with_meter
    from .feedback import say
    new, closure = project_with_meter(projector, images, times, gain, f_number, lux,
                                      facing=facing, colour=colour)
    if closure.warning:
        say(command, "warning", closure.warning)
    if closure.note:
        say(command, "note", closure.note)
    else:
        d = ", ".join(f"{v:+.2f}" for v in closure.direction)
        f = ", ".join(f"{v:+.2f}" for v in closure.facing)
        rgb = ":".join(f"{v:.2f}" for v in closure.colour)
        say(command, "note", f"the meter (facing ({f})) closed {closure.closed_lux:.4g} of its "
                             f"{lux:.4g} lux ({closure.closed_lux / lux:.0%}) in the clipped "
                             f"region toward ({d}), {closure.solid_angle_sr:.3g} sr, "
                             + _colour_words(closure, rgb))
    return new


def _colour_words(closure, rgb: str) -> str:
    """How the closed light was coloured, for the note (docs/photometry.md)."""
    from ..core.radiometry.colour_temperature import cct_duv
    told = cct_duv(closure.colour)
    kelvin = f", {told[0]:,.0f} K" if told and closure.colour_source != "neutral" else ""
    return {"measured": f"coloured R:G:B {rgb} by its CCT",
            "rim": f"coloured R:G:B {rgb}{kelvin} by the sun's partly clipped rim",
            "modelled": f"coloured R:G:B {rgb}{kelvin} as the sun's beam at its elevation "
                        "(SPECTRL2)"}.get(closure.colour_source, "neutral")


def exposure_of(exposures):
    """(times, gain, f_number) for the engine from what the frames say (StillExposure):
    gain = ISO/100 of the first frame; a bracket whose frames differ in ISO or f-number has
    that difference folded into its times (t·(S/S₀)·(N₀/N)², the same sensor exposure), so
    one gain and one f-number describe it."""
    first = exposures[0]
    iso0, n0 = first.iso, first.f_number
    times = []
    for e in exposures:
        t = e.exposure_s
        if t is not None and iso0 and e.iso:
            t *= e.iso / iso0
        if t is not None and n0 and e.f_number:
            t *= (n0 / e.f_number) ** 2
        times.append(t)
    return times, (iso0 / 100.0 if iso0 and times[0] is not None else 1.0), n0


def locate_ball_note(options: dict, image, command: str) -> dict:
    """``--ball auto``: the engine options with the ball found in ``image``, said on stderr."""
    from ..core.registration.ball import resolve_ball
    from .feedback import say
    options, circle = resolve_ball(options, image)
    say(command, "note", f"ball found at x {circle.x:.1f}, y {circle.y:.1f}, radius "
                         f"{circle.radius:.1f} px (--ball {circle.as_dict()['ball']})")
    if circle.weak:
        say(command, "warning", circle.weak_note())
    return options


def print_json(message: dict, pretty: bool) -> None:
    """The message as JSON on stdout (a failed write: one line, exit 2)."""
    from ..live.wire.message import dumps
    from .feedback import write_output
    write_output(dumps(message) if not pretty else json.dumps(message, indent=2,
                                                              allow_nan=False))


def run(args) -> int:
    from .passthrough import compute_views, is_views_input
    if is_views_input(args.image):     # a headset's views: fused alone (docs/passthrough.md)
        print_json(compute_views(args), args.pretty)
        return 0
    print_json(wire_message(args), args.pretty)
    return 0
