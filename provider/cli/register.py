"""``shlight register``: where a printed marker is in a panorama (docs/contract.md §13)."""
from __future__ import annotations

import json

from ..core.errors import InputError
from .options import finite_float, fisheye_calibration

EPILOG = """\
prints JSON: rotation (9 numbers, row-major: R_camera<-marker, its columns the marker's x, y, z
axes as OpenCV's ArUco defines them, in the camera frame of docs/contract.md §1), position
(the marker's centre, metres), error_deg / error_px (RMS corner reprojection error), apparent
size in panorama pixels, and whether the frame was levelled by gravity (a still's XMP
GPano:PosePitchDegrees / PoseRollDegrees), and camera_position: the camera's centre in the
marker's frame (metres; x printed right, y printed up, z out of the print: -R^T position),
which serve --probe-position NAME=THIS.json reads. Several IMAGEs of one static scene: the pose is
averaged over those that show the marker. theta://HOST: a full-resolution still is taken
through OSC camera.takePicture. The headset composes R_world<-camera = R_world<-marker ·
R_camera<-marker^T.

examples:
  shlight marker aruco:DICT_4X4_50:7 --size 0.2 -o marker.png     # print it at 100 %
  shlight register room.jpg --marker aruco:DICT_4X4_50:7 --marker-size 0.2
  shlight register theta://192.168.1.1 --marker qr:room-1 --marker-size 0.15
"""


def add_projection_arguments(p) -> None:
    """The projection options of the engine (docs/contract.md §1), as compute takes them."""
    g = p.add_argument_group("projection")
    g.add_argument("--projection", default="equirect",
                   choices=["equirect", "fisheye", "dual-fisheye", "cubemap"],
                   help="image geometry (default: equirect, 2:1)")
    g.add_argument("--fov", type=finite_float, default=None,
                   help="fisheye field of view in degrees (fisheye 180, dual-fisheye 200)")
    g.add_argument("--center", metavar="CX,CY", default=None,
                   help="fisheye image-circle centre (px)")
    g.add_argument("--radius", type=finite_float, default=None,
                   help="fisheye pixel radius at fov/2 (default: inscribed circle)")
    g.add_argument("--calibration", default=None,
                   help="JSON file with an OpenCV fisheye calibration {\"K\": 3x3, \"D\": 4}")
    from .options import add_lens_arguments
    add_lens_arguments(g)


def add_arguments(p) -> None:
    import argparse
    p.description = "Find a printed marker in a panorama: its pose in the camera's frame."
    p.epilog = EPILOG
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.add_argument("image", nargs="+", metavar="IMAGE|theta://HOST",
                   help="panorama/fisheye image(s) of one static scene, or a Theta to take a still")
    p.add_argument("--marker", required=True, metavar="SPEC",
                   help="aruco:DICT_4X4_50:7 (dictionary and id), or qr / qr:TEXT")
    p.add_argument("--marker-size", type=finite_float, required=True, metavar="METRES",
                   help="the printed side, 0.005-5 m: ArUco's black square, or the QR symbol "
                        "without its quiet zone (what `shlight marker` prints under it)")
    p.add_argument("--level", default="auto", choices=["auto", "off"],
                   help="auto: level the frame where the still says its pitch and roll (XMP)")
    p.add_argument("--pretty", action="store_true", help="indent the JSON")
    add_projection_arguments(p)


def projection_options(args) -> dict:
    """The projection's options from the command line (InputError on bad values)."""
    from .options import refuse_unused_options
    refuse_unused_options(args)
    opts = {}
    if args.fov is not None:
        if not 0 < args.fov <= 360:
            raise InputError(f"--fov {args.fov:g}: a field of view is in (0, 360] degrees")
        opts["fov_deg"] = args.fov
    if args.projection in ("dual-fisheye", "fisheye"):
        from .options import lens_options
        opts.update(lens_options(args, args.projection))
    if args.projection != "fisheye":
        return opts
    if args.center is not None:
        try:
            cx, cy = (float(v) for v in args.center.split(","))
        except ValueError:
            raise InputError(f"--center {args.center!r}: expected CX,CY in pixels") from None
        opts["center"] = (cx, cy)
    if args.radius is not None:
        opts["radius"] = args.radius
    if args.calibration:
        opts.update(fisheye_calibration(args.calibration))
    return opts


def measure(args, command: str = "register"):
    """The marker's pose (averaged over the images that show it) and the images' names."""
    from ..core.radiometry.images import read_image
    from ..core.registration.marker_detect import parse_marker
    from ..core.registration.pose import (MarkerNotFound, average_poses, find_marker, levelled,
                                          levelling_rotation)
    from ..core.registration.xmp_pose import read_pose
    from .feedback import say
    from ..core.registration.marker_detect import check_marker_size
    spec = parse_marker(args.marker)
    check_marker_size(args.marker_size, "--marker-size")
    options = projection_options(args)
    # every input checked before the first still is taken or the first image read
    from ..live.sources.theta import theta_url
    from .options import say_fifo_waits
    for name in args.image:
        if name.startswith("theta://"):
            theta_url(name)
    say_fifo_waits([n for n in args.image if not n.startswith("theta://")], command)
    poses, missing = [], []
    for name in args.image:
        if name.startswith("theta://"):
            from ..live.probe.registration import theta_still
            say(command, "note", f"taking a full-resolution still with {name}")
            path = theta_still(name)
        else:
            path = name
        image = read_image(path)
        from .options import say_projection_warnings
        say_projection_warnings(args.projection, image, options, command)
        try:
            pose = find_marker(image, spec, args.marker_size, args.projection, **options)
        except MarkerNotFound as exc:
            missing.append(f"{name}: {exc}")
            continue
        tilt = read_pose(path) if args.level == "auto" else None
        if tilt is not None:
            pose = levelled(pose, levelling_rotation(*tilt))
        poses.append(pose)
    if not poses:
        raise MarkerNotFound(missing[0] if len(missing) == 1
                             else f"no {spec} marker found in any of {len(args.image)} images")
    for line in missing:
        say(command, "note", f"skipped {line}")
    if len({p.levelled for p in poses}) > 1:
        raise InputError("some images say their pitch and roll and some do not: "
                         "pass --level off, or only stills of one camera")
    return average_poses(poses) if len(poses) > 1 else poses[0]


def add_serve_arguments(parser) -> None:
    """``shlight serve``'s registration options (docs/contract.md §13)."""
    g = parser.add_argument_group("registration (docs/contract.md §13)")
    g.add_argument("--marker", default=None, metavar="SPEC",
                   help="re-detect this printed marker (aruco:DICT_4X4_50:7, qr[:TEXT]); each "
                        "message then carries 'registration' (the marker's pose in the camera)")
    g.add_argument("--marker-size", type=finite_float, default=None, metavar="METRES",
                   help="its printed side (needed with --marker)")
    g.add_argument("--register-every", type=finite_float, default=5.0, metavar="SECONDS",
                   help="seconds between detections, off the frame path (default 5)")
    g.add_argument("--probe-position", action="append", default=[],
                   metavar="NAME=X,Y,Z|NAME=REGISTER.json",
                   help="where the probe's camera is in the world (metres, docs/contract.md "
                        "§1's axes), sent as 'position' in its messages; or the output of "
                        "shlight register (its camera_position: the marker's frame). "
                        "Repeatable; the probe named 'default' is 'default'")
    g.add_argument("--room", default=None, metavar="box:X0,Y0,Z0,X1,Y1,Z1|MESH",
                   help="the room's box (metres, the positions' frame) or a mesh file of it "
                        "(OBJ, PLY, glTF): /latest.json?at=X,Y,Z "
                        "and /probe-grid.json re-project the placed probes' panoramas through "
                        "it (docs/probes.md); without it they blend the probes' SH9")


def probe_positions(texts, names) -> dict:
    """``--probe-position`` values: probe name -> (x, y, z) metres."""
    import math
    import os
    out = {}
    for text in texts:
        name, sep, value = text.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not name or not value:
            raise InputError(f"--probe-position: expected NAME=X,Y,Z or NAME=REGISTER.json, "
                             f"got {text!r}")
        if name not in names:
            raise InputError(f"--probe-position: no probe named {name!r} (probes: "
                             f"{', '.join(names)})")
        if name in out:
            raise InputError(f"--probe-position: probe {name!r} is placed twice")
        if value.lower().endswith(".json") or os.path.isfile(value):
            position = _registered_position(value)
        else:
            try:
                position = [float(v) for v in value.replace(";", ",").split(",")]
            except ValueError:
                position = []
        if len(position) != 3 or not all(math.isfinite(v) for v in position):
            raise InputError(f"--probe-position {text!r}: expected X,Y,Z (three finite "
                             "numbers, metres) or a file shlight register wrote")
        out[name] = tuple(float(v) for v in position)
    return out


def _registered_position(path: str) -> list:
    from ..core.json_text import parse_json
    try:
        with open(path, encoding="utf-8") as f:
            found = parse_json(f.read(), path, 4)
    except FileNotFoundError:
        raise InputError(f"--probe-position: no such file: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"--probe-position: cannot read {path}: "
                         f"{getattr(exc, 'strerror', None) or exc}") from None
    position = found.get("camera_position") if isinstance(found, dict) else None
    if not (isinstance(position, list) and all(isinstance(v, (int, float))
                                               and not isinstance(v, bool) for v in position)):
        raise InputError(f"--probe-position: {path} has no camera_position (write it with "
                         "shlight register)")
    return [float(v) for v in position]


def registrar_for(ns, name: str):
    """The probe's :class:`~provider.live.probe.registration.Registrar`, or None without --marker."""
    if ns.marker is None:
        if ns.marker_size is not None:
            raise InputError("--marker-size needs --marker SPEC")
        return None
    if ns.marker_size is None:
        raise InputError("--marker needs --marker-size METRES (the printed side)")
    from ..core.registration.marker_detect import check_marker_size
    check_marker_size(ns.marker_size, "--marker-size")
    from ..live.probe.registration import Registrar
    from .options import engine_options
    opts = {k: v for k, v in engine_options(ns).items()
            if k in ("fov_deg", "center", "radius", "K", "D", "lens", "front", "curve")}
    return Registrar(ns.marker, ns.marker_size, ns.projection, opts, ns.register_every, name)


def run(args) -> int:
    pose = measure(args)
    import numpy as np
    camera = -np.asarray(pose.rotation).T @ np.asarray(pose.position)
    out = {**pose.to_json(), "marker_size": args.marker_size, "projection": args.projection,
           "camera_position": [round(float(v), 5) for v in camera]}
    print(json.dumps(out, indent=2 if args.pretty else None, allow_nan=False))
    return 0
