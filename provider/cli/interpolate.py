"""``shlight interpolate``: the light at points of the room from several probes at known
positions (docs/probes.md, "Light between probes")."""
from __future__ import annotations

import argparse
import json
import math
import os

from ..core.errors import InputError

EPILOG = """\
PROBES.json: {"probes": [{"name": "door", "image": "door.exr", "position": [1.0, 1.2, 0.5]},
...]}: each probe's panorama (an equirect, 2:1, read as compute reads it; a path relative
to PROBES.json) and its camera's position in the world frame (metres, docs/contract.md §1's
axes, which the panoramas' directions share).

prints {"points": [{"position", "method", "coefficients", "matrices", "lights", ...}]}: per
point the wire message's lighting fields (docs/contract.md §3, §10).

  --room box:X0,Y0,Z0,X1,Y1,Z1  each probe's panorama re-projected through the room's box to
                                the point (parallax); lights found at the point (--lights auto)
  --room ROOM.obj|.ply|.glb     the same through a mesh of the room (trimesh), walls and
                                furniture hiding what a probe does not see
  without --room                the probes' SH9 blended as Unity blends its light probes
                                (tetrahedra; outside their hull, its nearest face)

examples:
  shlight interpolate probes.json --at 2,1.2,3 --room box:0,0,0,6,3,5
  shlight interpolate probes.json --at 2,1.2,3 --at 4,0.8,1
"""

#: Most points one command (or one request) asks for.
MAX_POINTS = 4096


def point(text: str):
    """An argparse type: ``X,Y,Z`` in metres."""
    try:
        values = [float(v) for v in text.replace(";", ",").split(",")]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected X,Y,Z (metres), got {text!r}")
    return tuple(values)


def add_arguments(p) -> None:
    p.description = ("The light at points of the room from several probes at known "
                     "positions.")
    p.epilog = EPILOG
    p.formatter_class = argparse.RawDescriptionHelpFormatter
    p.add_argument("probes", metavar="PROBES.json", help="the probes: name, image, position")
    p.add_argument("--at", action="append", type=point, required=True, metavar="X,Y,Z",
                   help="a point (metres, the probes' world frame); repeatable")
    p.add_argument("--room", default=None, metavar="box:X0,Y0,Z0,X1,Y1,Z1|MESH",
                   help="the room's box (two opposite corners, metres) or a mesh file (OBJ, "
                        "PLY, glTF, STL, OFF): parallax through it")
    p.add_argument("--lights", default="off", choices=["off", "auto"],
                   help="with --room: directional lights found in the light at each point "
                        "(docs/contract.md §10); default off")
    p.add_argument("--rows", type=int, default=None, metavar="N",
                   help="with --room: rows of the panorama re-projected at each point "
                        "(columns twice; default 64, at most 512)")
    p.add_argument("--pretty", action="store_true", help="indent the JSON")


def read_probes(path: str) -> list[dict]:
    """The probes of PROBES.json: name, image (the path), position (3 floats);
    :class:`InputError` in one line for anything missing or malformed."""
    from ..core.json_text import parse_json
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except FileNotFoundError:
        raise InputError(f"no such file: {path}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read {path}: {getattr(exc, 'strerror', None) or exc}") \
            from None
    top = parse_json(text, path, 6)
    probes = top.get("probes") if isinstance(top, dict) else None
    if not isinstance(probes, list) or not probes:
        raise InputError(f'{path}: expected {{"probes": [{{"name", "image", "position"}}, '
                         '...]}, at least one probe')
    out, names = [], set()
    folder = os.path.dirname(os.path.abspath(path))
    for i, probe in enumerate(probes):
        where = f"{path}: probe {i + 1}"
        if not isinstance(probe, dict):
            raise InputError(f"{where}: expected an object with name, image and position")
        name = probe.get("name", f"probe{i + 1}")
        if not isinstance(name, str) or not name:
            raise InputError(f"{where}: 'name' must be a non-empty string")
        if name in names:
            raise InputError(f"{where}: the name {name!r} is taken by another probe")
        names.add(name)
        image = probe.get("image")
        if not isinstance(image, str) or not image:
            raise InputError(f"{where} ({name}): 'image' must be the panorama's path")
        position = probe.get("position")
        if (not isinstance(position, list) or len(position) != 3
                or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                           and math.isfinite(v) for v in position)):
            raise InputError(f"{where} ({name}): 'position' must be three numbers (metres), "
                             f"got {json.dumps(position)[:60]}")
        out.append({"name": name, "image": os.path.join(folder, image),
                    "position": [float(v) for v in position]})
    return out


def probe_panorama(path: str, name: str):
    """The probe's panorama as linear float32 radiance (8/16-bit: sRGB decoded)."""
    from ..core.radiometry.images import read_image
    from ..live.probe.points import linear_panorama
    img = read_image(path)
    if img.ndim != 3 or img.shape[1] != 2 * img.shape[0]:
        raise InputError(f"probe {name}: {path} is {img.shape[1]}×{img.shape[0]}; an "
                         "equirect panorama (2:1) is needed")
    return linear_panorama(img)


def check_arguments(args) -> None:
    if args.room is None:
        if args.lights != "off":
            raise InputError("--lights auto needs --room: without the room a light has no "
                             "place to be seen from the point")
        if args.rows is not None:
            raise InputError("--rows is the panorama re-projected through --room: give "
                             "--room, or leave --rows out")
    if len(args.at) > MAX_POINTS:
        raise InputError(f"{len(args.at)} points: at most {MAX_POINTS} a command")


def run(args) -> int:
    from ..live.wire.message import dumps
    from ..live.probe.points import Interpolator
    check_arguments(args)
    probes = read_probes(args.probes)
    images = [probe_panorama(p["image"], p["name"]) for p in probes]
    interpolator = Interpolator([p["name"] for p in probes], [p["position"] for p in probes],
                                images, room=args.room, lights=args.lights, rows=args.rows)
    out = {"room": interpolator.room_text, "points": [interpolator.at(x) for x in args.at]}
    print(json.dumps(out, indent=2, allow_nan=False) if args.pretty else dumps(out))
    return 0
