"""Projection and engine options shared by ``compute``, ``export``, ``environment``, ``serve``
and ``register``, and the rule for options that cannot do anything where they are given.

The rule (issue 33), the same for every command:

* an option that does nothing with the rest of the command line (``--fov`` with ``--projection
  equirect``, ``--order-budget`` without ``--order auto``), and two options that contradict
  each other or give the same thing twice (``--ball-distance`` and ``--fov``, ``--no-hlsl`` and
  ``--require-hlsl``), are refused before any work: one line, exit 2 (:func:`unused_options`,
  :func:`refuse_unused_options`; ``engine_options`` applies it);
* an option that does nothing with *this input*, which only the frame shows (``--camera`` on a
  float frame: :func:`frame_warnings`; a 2:1 frame read as ``--projection fisheye``: the
  projection's own warning, :func:`say_projection_warnings` where no engine says it), is one
  warning line on stderr, and the command goes on;
* a number beyond what can make sense is refused with its range in the message (``--fps``:
  :data:`MAX_FPS`).

Options whose use depends on others default to None here (their documented default is filled
in by ``engine_options``), so that "given" can be told from "left out".
"""
from __future__ import annotations

import argparse
import json
import math
import os
import re

from ..core.errors import InputError


#: The documented defaults of options that default to None (see the module docstring).
DEFAULT_ORDER_BUDGET = 0.02
DEFAULT_FILL = "ground"
DEFAULT_ALBEDO = 0.1
#: Highest ``--fps``: frames a second a source is paced at (demo, files, snapshot URLs, the
#: most a relay takes). Beyond it a demo or file source only burns a core.
MAX_FPS = 240.0

#: Options only some projections read: dest -> (flag, the projections that read it).
PROJECTION_OPTIONS = {
    "fov": ("--fov", ("fisheye", "dual-fisheye", "mirrorball")),
    "center": ("--center", ("fisheye", "mirrorball", "angular")),
    "radius": ("--radius", ("fisheye", "mirrorball", "angular")),
    "calibration": ("--calibration", ("fisheye",)),
    "lens": ("--lens", ("dual-fisheye", "fisheye")),
    "front": ("--front", ("dual-fisheye",)),
    "fill": ("--fill", ("fisheye",)),
    "albedo": ("--albedo", ("fisheye",)),
    "ball_unseen": ("--ball-unseen", ("mirrorball",)),
    "ball_mask": ("--ball-mask", ("mirrorball",)),
    "ball_fill": ("--ball-fill", ("mirrorball",)),
    "ball_distance": ("--ball-distance", ("mirrorball",)),
}
#: Options that only another option gives a use: dest -> (flag, what it needs, is it there).
NEEDS = {
    "order_budget": ("--order-budget", "--order auto", lambda a: a.order == "auto"),
    "environment_size": ("--environment-size", "--environment", lambda a: a.environment),
    "environment_hz": ("--environment-hz", "--environment", lambda a: a.environment),
}
#: Pairs of options that contradict each other, or give the same thing twice: (dest, dest,
#: when it matters (None: always), what they both do).
CONFLICTS = (
    ("ball_distance", "fov", lambda a: a.projection == "mirrorball",
     "both set the mirror ball's perspective (the camera's distance to it)"),
    ("ball", "center", None, "both give the ball's circle"),
    ("ball", "radius", None, "both give the ball's circle"),
    ("no_hlsl", "require_hlsl", None, "contradict each other (skip HLSL, and fail without it)"),
    ("calibration", "lens", None, "both give the fisheye's lens model"),
)


def _flag(dest: str) -> str:
    return "--" + dest.replace("_", "-")


def _set(args, dest: str) -> bool:
    """Whether the command line gave ``dest`` (None: left out; False: a flag not given; 0 is
    a value)."""
    value = getattr(args, dest, None)
    return value is not None and value is not False


def unused_options(args, given=None) -> dict:
    """``{dest: one line}`` for each option of the parsed command line ``args`` that does
    nothing with the rest of it, or contradicts another (the module docstring's rule);
    ``given``: the dests to consider (default: every one that is set, not None or False).
    Works on any command's namespace: options it lacks count as not given."""
    def has(dest):
        return _set(args, dest) and (given is None or dest in given)
    out = {}
    projection = getattr(args, "projection", None)
    for dest, (flag, readers) in PROJECTION_OPTIONS.items():
        if has(dest) and projection is not None and projection not in readers:
            out[dest] = (f"{flag} has no effect with --projection {projection} (only "
                         f"{', '.join(readers)} read it): leave it out")
    for dest, (flag, needed, present) in NEEDS.items():
        if has(dest) and not present(args):
            out[dest] = f"{flag} has no effect without {needed}: give {needed}, or leave {flag} out"
    for a, b, when, what in CONFLICTS:
        if (_set(args, a) and _set(args, b) and (has(a) or has(b))
                and (when is None or when(args))):
            out.setdefault(a if has(a) else b, f"{_flag(a)} and {_flag(b)} {what}: give one")
    return out


def refuse_unused_options(args) -> None:
    """:func:`unused_options` refused in one line (InputError), unless the command already
    checked them its own way (``args._options_checked``: serve, per probe)."""
    if getattr(args, "_options_checked", False):
        return
    problems = unused_options(args)
    if problems:
        raise InputError(next(iter(problems.values())))


def frame_warnings(args, floating: bool) -> list:
    """What the first frame shows the options cannot do with it (one line each, warnings:
    the command goes on): ``--camera`` or ``--encoding`` on a float frame (float frames are
    linear: neither decodes them). A 2:1 frame read as a fisheye is the projection's own
    warning (``Projection.warnings``, which every command prints)."""
    out = []
    if floating and getattr(args, "camera", None):
        out.append("--camera has no effect on a float frame (its curve decodes 8- and "
                   "16-bit frames; float frames are linear already)")
    if floating and getattr(args, "encoding", "auto") not in ("auto", None):
        out.append(f"--encoding {args.encoding} has no effect on a float frame (float "
                   "frames are linear already)")
    return out


def say_frame_warnings(args, image, command: str) -> None:
    """:func:`frame_warnings` of the first frame (an array), each a warning line on stderr."""
    from .feedback import say
    floating = getattr(image, "dtype", None) is not None and image.dtype.kind == "f"
    for line in frame_warnings(args, floating):
        say(command, "warning", line)


#: OpenEXR's cube faces, top to bottom (ImfEnvmap.h).
EXR_CUBE_FACES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")


def say_nonfinite(args, image, stats: dict, command: str) -> None:
    """:func:`nonfinite_warning` of a frame the engine projected (``stats``: its counts; a
    frame with no usable light at all was refused, in one line, instead)."""
    from .feedback import say
    if stats.get("nonfinite_pixels"):
        line = nonfinite_warning(image, getattr(args, "projection", None))
        if line:
            say(command, "warning", line)


def nonfinite_warning(image, projection) -> str | None:
    """A float frame's NaN or infinite pixels, which the engines take as black (counted in
    ``nonfinite_pixels``; ``coverage_sr`` is the sphere the projection sees, not the light
    it holds): how many, and for an OpenEXR cube the faces that hold nothing else."""
    import numpy as np
    bad = ~np.isfinite(image).all(axis=-1)
    count = int(np.count_nonzero(bad))
    if not count:
        return None
    h, w = bad.shape
    where = ""
    if projection == "exr-cube" and h == 6 * w:
        faces = [EXR_CUBE_FACES[f] for f in range(6) if bad[f * w:(f + 1) * w].all()]
        if faces:
            where = f" (the whole {', '.join(faces)} face{'s' if len(faces) > 1 else ''} of " \
                    "the cube)"
    return (f"{count:,} of {h * w:,} pixels ({count / (h * w):.1%}) are NaN or infinite"
            f"{where}: taken as black, so the lighting lacks what they saw (nonfinite_pixels)")


def say_projection_warnings(projection: str, image, options: dict, command: str) -> None:
    """The warnings of ``projection`` (with its ``options``) built for ``image``'s size, each
    a line on stderr, for a command that builds it without the engine, which says them
    itself (``register``: a 2:1 panorama read as --projection fisheye gives a confident,
    wrong pose). A projection that cannot be built is left for the command to refuse."""
    from ..core.geometry.projections import make_projection
    from .feedback import say
    try:
        built = make_projection(projection, image.shape[1], image.shape[0], **options)
    except (InputError, TypeError, ValueError):       # ProjectionError: a ValueError
        return
    for line in getattr(built, "warnings", ()):
        say(command, "warning", line)


def say_fifo_waits(texts, command: str) -> None:
    """Before reading ``FRAME[@SECONDS]`` arguments: a note for each that is a FIFO (a named
    pipe), whose opening waits, as POSIX has it, until some program opens it for writing."""
    import os
    import stat
    from .feedback import say
    from .frames import parse_frame
    for text in texts:
        try:
            path = parse_frame(text)[0]
            fifo = stat.S_ISFIFO(os.stat(path).st_mode)
        except (OSError, ValueError, InputError):     # said by the reading, in its words
            continue
        if fifo:
            say(command, "note", f"waiting for a writer on FIFO {path}")


#: Options whose value may start with '-' ("--bracket -4,-2,0,2,4"): argparse would take such
#: a value for an unknown option, so it is glued to its option ("--bracket=-4,...") first.
NEGATIVE_VALUE_OPTIONS = ("--bracket",)


class Parser(argparse.ArgumentParser):
    """argparse, reading ``--bracket -4,-2,0`` as a value (see NEGATIVE_VALUE_OPTIONS), and
    saying a usage error in one line (and where to read more), not the whole usage block."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see: {self.prog} --help)\n")

    def parse_known_args(self, args=None, namespace=None):
        import sys
        args = list(sys.argv[1:] if args is None else args)
        out = []
        i = 0
        while i < len(args):
            a = args[i]
            if (a in NEGATIVE_VALUE_OPTIONS and i + 1 < len(args)
                    and re.match(r"[-+\u2212]?\d", args[i + 1])):
                out.append(f"{a}={args[i + 1]}")
                i += 2
                continue
            out.append(a)
            i += 1
        return super().parse_known_args(out, namespace)


def _floats(text: str, n: int, what: str):
    try:
        vals = [float(v) for v in text.replace(";", ",").split(",")]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {n} comma-separated numbers, got {text!r}")
    if len(vals) != n:
        raise argparse.ArgumentTypeError(f"expected {n} numbers, got {len(vals)}")
    if not all(math.isfinite(v) for v in vals):
        raise argparse.ArgumentTypeError(f"expected finite numbers, got {text!r}")
    return vals


def finite_float(text: str) -> float:
    """An argparse type: a float that is not NaN or infinite (they would pass every range
    check and poison the maths)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return v


def pixel_budget(text: str) -> int:
    """An argparse type: a number of pixels (``33554432``; 0: no budget) or ``WxH``."""
    m = re.fullmatch(r"\s*(\d+)\s*(?:[xX×]\s*(\d+)\s*)?", text)
    if not m:
        raise argparse.ArgumentTypeError("expected a number of pixels (0: no budget) or "
                                         f"WIDTHxHEIGHT, e.g. 8192x4096, got {text!r}")
    return int(m.group(1)) * (int(m.group(2)) if m.group(2) else 1)


def add_budget_argument(g, default: int, what: str) -> None:
    """``--max-frame-pixels`` (``default`` pixels; ``what``: what a refusal does)."""
    shown = "0: none" if not default else f"{default}"
    if default == 8192 * 4096:
        shown = "8192x4096 = 33554432"
    g.add_argument("--max-frame-pixels", type=pixel_budget, default=default, metavar="N|WxH",
                   help="refuse an image with more pixels than this, from its header, before "
                        "decoding it (JPEG, PNG, OpenEXR, .hdr, TIFF, BMP, WebP, PNM): "
                        f"{what}. 0: no budget (default {shown})")


def add_engine_arguments(p: argparse.ArgumentParser) -> None:
    """Projection and engine options shared by `compute`, `serve` and `bench`."""
    g = p.add_argument_group("projection and engine options")
    g.add_argument("--projection", default="auto",
                   choices=["auto", "equirect", "fisheye", "dual-fisheye", "cubemap",
                            "mirrorball", "angular", "cross", "exr-latlong", "exr-cube"],
                   help="image geometry (default auto: an OpenEXR file's own envmap "
                        "attribute, latlong or cube, in OpenEXR's conventions, else equirect, "
                        "2:1; mirrorball: a chrome ball, angular: Debevec's angular map, "
                        "cross: a 4×3 or 3×4 cube cross)")
    g.add_argument("--encoding", default="auto", choices=["auto", "srgb", "linear"],
                   help="transfer function of 8/16-bit input (auto = sRGB; float is linear)")
    g.add_argument("--exposure", type=finite_float, default=1.0,
                   help="linear scale on radiance (e.g. 2**EV); default 1")
    g.add_argument("--downsample", type=int, default=1,
                   help="fast path: area-average the linearised frame by this factor")
    g.add_argument("--order", default="2", choices=["0", "1", "2", "auto"],
                   help="highest SH band kept (auto: lowest within --order-budget)")
    g.add_argument("--order-budget", type=finite_float, default=None,
                   help="irradiance error budget for --order auto (default 0.02 = 2%%)")
    g.add_argument("--dering", default="off", choices=["off", "auto"],
                   help="auto: window the SH just enough that irradiance is never negative")
    g.add_argument("--lights", default="off", choices=["off", "auto"],
                   help="auto: directional lights for compact bright sources (a sun, a lamp) "
                        "plus ambient SH9, kept only where they lower the measured error")
    g.add_argument("--max-lights", type=int, default=None, metavar="K",
                   help="at most K lights per frame with --lights auto (1-4, default 4: the "
                        "shaders' slots)")
    g.add_argument("--rotate", metavar="YAW,PITCH,ROLL", default=None,
                   type=lambda t: _floats(t, 3, "--rotate"),
                   help="sensor rotation in degrees (about +Y, +X, -Z), applied to coefficients")
    g.add_argument("--fov", type=finite_float, default=None,
                   help="fisheye field of view in degrees (fisheye 180, dual-fisheye 200)")
    g.add_argument("--center", metavar="CX,CY", default=None,
                   type=lambda t: _floats(t, 2, "--center"), help="fisheye image-circle centre (px)")
    g.add_argument("--radius", type=finite_float, default=None,
                   help="fisheye pixel radius at fov/2 (default: inscribed circle)")
    g.add_argument("--calibration", default=None,
                   help="JSON file with an OpenCV fisheye calibration {\"K\": 3x3, \"D\": 4}")
    add_lens_arguments(g)
    g.add_argument("--fill", default=None, choices=["ground", "mirror", "zero"],
                   help="fisheye: model of the unseen hemisphere (default ground)")
    g.add_argument("--albedo", type=finite_float, default=None,
                   help="fisheye fill albedo (default 0.1, measured best on real scenes)")
    g.add_argument("--camera", default=None, metavar="CAMERA.json",
                   help="the camera's response (shlight calibrate-response): 8/16-bit frames "
                        "are decoded with its curve instead of sRGB")
    from .probe_options import add_probe_arguments
    add_probe_arguments(g)


def add_table_cache_argument(p) -> None:
    """``--no-table-cache``: build the projectors' tables at every start
    (:mod:`provider.core.table_cache`)."""
    p.add_argument("--no-table-cache", action="store_true",
                   help="do not read or write built tables in the user's cache folder "
                        "(SHLIGHT_CACHE_DIR, else ~/.cache/shlight): rebuild them at every "
                        "start (also SHLIGHT_TABLE_CACHE=0)")


def add_lens_arguments(g) -> None:
    """``--lens`` and ``--front`` (compute, environment, export, serve, register)."""
    from ..core.geometry.lens_profiles import PROFILES
    g.add_argument("--lens", default=None, metavar="NAME|FILE",
                   help="dual-fisheye lens profile: " + ", ".join(PROFILES) + " (default "
                        "equidistant; Ricoh's design curves at each model's frame size), or a "
                        "lens file of shlight calibrate-lens (fisheye or dual-fisheye; "
                        "docs/cameras.md)")
    g.add_argument("--front", default=None, choices=["left", "right"],
                   help="dual-fisheye: the circle that looks where a stitched panorama's "
                        "centre does (default: the lens profile's, right for every Theta)")


#: Largest lens or calibration file read (bytes): calibrate-lens writes about 600.
MAX_LENS_FILE_BYTES = 64 * 1024


def small_json_file(path: str, what: str, max_depth: int, kind: str):
    """The JSON of a small settings file the user names (a lens file, an OpenCV
    calibration): a regular file (a FIFO would wait for a writer, a device never end), at
    most MAX_LENS_FILE_BYTES, strict JSON at most ``max_depth`` deep. InputError in one line
    ``"{what}: ..."``; ``kind`` says what the file should be."""
    import stat
    from ..core.json_text import parse_json
    try:
        st = os.stat(path)
        if not stat.S_ISREG(st.st_mode):
            raise InputError(f"{what}: not a regular file ({kind})")
        if st.st_size > MAX_LENS_FILE_BYTES:
            raise InputError(f"{what}: {st.st_size:,} bytes, too large ({kind}; at most "
                             f"{MAX_LENS_FILE_BYTES // 1024} KiB)")
        with open(path, "rb") as f:
            text = f.read(MAX_LENS_FILE_BYTES + 1).decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{what}: not a JSON text file ({kind})") from None
    except OSError as exc:
        raise InputError(f"{what}: {exc.strerror or exc}") from None
    return parse_json(text, what, max_depth)


def _lens_file(path: str) -> dict:
    # a lens file is one flat object of numbers and lists of numbers: 2 levels
    kind = "a lens file is the JSON file shlight calibrate-lens writes"
    data = small_json_file(path, f"--lens {path}", 2, kind)
    if not isinstance(data, dict):
        raise InputError(f"--lens {path}: not a lens file ({kind})")
    return data


def lens_options(args, projection: str) -> dict:
    """The ``lens`` (a profile name, or a lens file read here) and ``front`` options of a
    dual-fisheye or fisheye frame, as projection options (InputError in one line)."""
    from ..core.geometry.checks import ProjectionError
    from ..core.geometry.lens_calibration import calibrated_profile, lens_from_dict
    from ..core.geometry.lens_profiles import lens_profile
    opts, lens = {}, getattr(args, "lens", None)
    try:
        if lens is not None and (os.path.exists(lens) or lens.lower().endswith(".json")):
            data = _lens_file(lens)
            if projection == "dual-fisheye":
                opts["lens"] = calibrated_profile(data, lens)
            else:
                cal = lens_from_dict(data, lens)
                fov = cal["fov_deg"] if args.fov is None else args.fov
                opts.update(curve=cal["curve"], center=cal["center"], fov_deg=fov,
                            radius=cal["focal"] * float(cal["curve"].radius(
                                min(math.radians(fov / 2), cal["curve"].theta_limit))))
        elif lens is not None:
            lens_profile(lens)
            if projection != "dual-fisheye":
                raise InputError(f"--lens {lens} is a dual-fisheye profile; a fisheye takes a "
                                 "lens file of shlight calibrate-lens")
            opts["lens"] = lens
    except ProjectionError as exc:
        raise InputError(f"--lens: {exc}") from None
    if getattr(args, "front", None) is not None:
        opts["front"] = args.front
    return opts


def auto_projection(args) -> str:
    """``--projection auto``: "exr-latlong" or "exr-cube" for OpenEXR inputs whose headers
    all say that ``envmap`` (read by OpenEXR's bindings: scan lines, tiles, mipmaps,
    multi-part; docs/compute.md), else "equirect"."""
    return header_projection("auto", _input_layouts(args))[0]


def _input_layouts(args) -> list:
    """The OpenEXR header (:func:`~provider.core.radiometry.images.exr_layout`, None for
    another format) of each ``FRAME[@SECONDS]`` input of the command line."""
    from ..core.radiometry.images import exr_layout
    inputs = getattr(args, "image", None)
    inputs = [inputs] if isinstance(inputs, str) else list(inputs or [])
    out = []
    for text in inputs:
        path = text if os.path.exists(text) else re.sub(r"@[0-9./]+$", "", text)
        out.append(exr_layout(path))
    return out


def header_projection(given: str, layouts) -> tuple:
    """(projection, warnings) of ``--projection given`` for inputs whose OpenEXR headers are
    ``layouts`` (:class:`~provider.core.radiometry.images.ExrLayout`, None for another
    format): ``auto`` becomes the envmap the headers all say ("exr-latlong", "exr-cube"),
    else "equirect"; ``exr-latlong`` given for a file whose header says cube (or ``exr-cube``
    for a latlong) is refused in one line (InputError); any other projection given for a
    file whose header says an envmap, an envmap value OpenEXR does not define, and a
    multi-part file (one part is read) are a warning each."""
    kinds = {None if layout is None else layout.envmap for layout in layouts}
    said = {layout.envmap: layout.path for layout in layouts if layout and layout.envmap}
    if given == "auto" and len(said) > 1:          # frames of one bracket, two layouts
        raise InputError("the frames' OpenEXR headers disagree: " + ", ".join(
            f"{path} says envmap {kind}" for kind, path in sorted(said.items())))
    projection = given
    if given == "auto":
        projection = ("exr-" + next(iter(kinds)) if len(kinds) == 1 and None not in kinds
                      else "equirect")
    warnings = []
    for layout in layouts:
        if layout is None:
            continue
        warnings += layout.notes
        if layout.envmap is None or given in ("auto", "exr-" + layout.envmap):
            continue
        if given.startswith("exr-"):
            raise InputError(f"--projection {given}: {layout.path}'s header says envmap "
                             f"{layout.envmap}; give --projection exr-{layout.envmap} (or "
                             "auto, which reads the header)")
        warnings.append(f"{layout.path}'s header says it is an OpenEXR {layout.envmap} map; "
                        f"read as --projection {given}, as given (--projection auto reads "
                        f"it as exr-{layout.envmap})")
    return projection, warnings


def resolve_projection(args, command: str) -> None:
    """:func:`header_projection` of the command line's ``FRAME[@SECONDS]`` inputs, before any
    work: ``args.projection`` set, its warnings said on stderr (serve, whose sources are no
    files here, resolves its own per probe)."""
    from .feedback import say
    if not hasattr(args, "image"):
        return
    args.projection, warnings = header_projection(args.projection, _input_layouts(args))
    for line in warnings:
        say(command, "warning", line)


def fisheye_calibration(path: str) -> dict:
    """``{"K": 3×3, "D": 4}`` of an OpenCV fisheye calibration file, as float arrays for the
    projection (InputError in one line for a file that is not one)."""
    import numpy as np
    kind = "{\"K\": 3x3, \"D\": 4}"
    cal = small_json_file(path, f"cannot use calibration {path}", 3, kind)
    if not isinstance(cal, dict):
        raise InputError(f"cannot use calibration {path}: not {kind}")
    try:
        return {"K": np.asarray(cal["K"], float), "D": np.asarray(cal["D"], float)}
    except KeyError as exc:
        raise InputError(f"cannot use calibration {path}: no {exc} ({kind})") from None
    except (ValueError, TypeError) as exc:
        raise InputError(f"cannot use calibration {path}: {exc}") from None


def engine_options(args) -> dict:
    """Translate parsed arguments into :class:`~provider.core.sh9.engine.SH9Projector` options."""
    from ..core.options import check_options
    from ..core.geometry.sh import rotation_from_euler
    refuse_unused_options(args)
    opts = dict(encoding=args.encoding, exposure=args.exposure, downsample=args.downsample,
                order=args.order if args.order == "auto" else int(args.order),
                order_budget=DEFAULT_ORDER_BUDGET if args.order_budget is None
                else args.order_budget, dering=args.dering)
    if args.max_lights is not None:     # the same rule whatever else is given
        from ..core.options import MAX_LIGHTS
        if not 1 <= args.max_lights <= MAX_LIGHTS:
            raise InputError(f"--max-lights {args.max_lights}: out of range (1-{MAX_LIGHTS})")
        if args.lights == "off":
            raise InputError("--max-lights limits the lights of --lights auto; give "
                             "--lights auto too, or leave --max-lights out")
    if args.lights != "off":
        opts.update(lights=args.lights,
                    max_lights=4 if args.max_lights is None else args.max_lights)
    if args.rotate:
        opts["rotation"] = rotation_from_euler(*args.rotate)
    check_options(**opts)
    # What no frame size can make valid is refused here, before any frame (serve: at start).
    if args.fov is not None and not 0 < args.fov <= 360:
        raise InputError(f"--fov {args.fov:g}: a field of view is in (0, 360] degrees")
    if args.radius is not None and args.radius <= 0:
        raise InputError(f"--radius {args.radius:g}: must be positive")
    albedo = DEFAULT_ALBEDO if args.albedo is None else args.albedo
    if not 0 <= albedo <= 1:
        raise InputError(f"--albedo {albedo:g}: must be in [0, 1]")
    if getattr(args, "camera", None):
        from ..live.probe.camerafile import load_camera
        if args.encoding != "auto":
            raise InputError(f"--encoding {args.encoding} and --camera both say how to decode "
                             "8/16-bit frames: give one")
        opts["response"] = load_camera(args.camera)
    if args.projection == "fisheye":
        opts.update(fill=args.fill or DEFAULT_FILL, albedo=albedo)
        opts.update(lens_options(args, "fisheye"))
        if args.fov is not None:
            opts["fov_deg"] = args.fov
        if args.center is not None:
            opts["center"] = tuple(args.center)
        if args.radius is not None:
            opts["radius"] = args.radius
        if args.calibration:
            opts.update(fisheye_calibration(args.calibration))
    elif args.projection == "dual-fisheye":
        if args.fov is not None:
            opts["fov_deg"] = args.fov
        opts.update(lens_options(args, "dual-fisheye"))
    elif args.projection in ("mirrorball", "angular"):
        from .probe_options import probe_options
        opts.update(probe_options(args))
    if getattr(args, "ball", None) is not None and args.projection not in ("mirrorball", "angular"):
        raise InputError("--ball is for --projection mirrorball or angular")
    return opts


def check_meter_arguments(args, where: str = "") -> tuple:
    """The meter's options (``--lux-facing``, ``--lux-cct``; serve's ``--lux-ca``) are for
    ``--lux`` and must parse: said before any work in one line (exit 2), the same in compute
    and serve (``where``: serve's "probe NAME: "). Returns (facing, colour) parsed
    (:func:`~provider.core.sh9.meter.parse_facing`, :func:`~provider.core.sh9.meter.parse_meter_colour`)."""
    from ..core.sh9.meter import parse_facing, parse_meter_colour
    given = [f"--{name.replace('_', '-')}" for name in ("lux_facing", "lux_cct", "lux_ca")
             if getattr(args, name, None) is not None]
    if given and getattr(args, "lux", None) is None:
        raise InputError(f"{where}{' and '.join(given)} {'is' if len(given) == 1 else 'are'} "
                         "for --lux (a lux meter's reading)")
    lux = getattr(args, "lux", None)
    if isinstance(lux, float):          # compute's reading (serve's SOURCE: its meter's own)
        from ..core.radiometry.photometry import LUX_RANGE, check_physical
        check_physical(f"{where}--lux", lux, LUX_RANGE, " lux")
    facing = getattr(args, "lux_facing", None)
    return (parse_facing("up" if facing is None else facing),
            parse_meter_colour(getattr(args, "lux_cct", None)))
