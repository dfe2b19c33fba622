"""`shlight` command line: compute | serve | validate-shaders | bench | calibrate-response.

User errors (bad files, bad options) print one clear line to stderr and exit with status
2; they never show a traceback. Each command's options live in a module of this package
(:mod:`.compute`, :mod:`.serve`, :mod:`.validate`, :mod:`.bench`, :mod:`.calibrate`; the
frame@time syntax in :mod:`.frames`; the engine options shared
by several in :mod:`.options`); what the command does lives in its layer and is imported
only when the command runs.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from .. import __version__
from ..core.errors import InputError

#: (command, module of this package, help)
COMMANDS = (
    ("compute", "compute", "print the wire JSON (DESIGN.md §3) for one image"),
    ("serve", "serve", "serve live coefficients over WebSocket (default: demo source)"),
    ("validate-shaders", "validate", "prove the GLSL/HLSL compute what the CPU computes"),
    ("bench", "bench", "speed against error: Markdown table and PNG plot"),
    ("calibrate-response", "calibrate",
     "a camera's response curve from FRAME@SECONDS brackets -> camera.json"),
)


def build_parser() -> argparse.ArgumentParser:
    from .options import Parser
    parser = Parser(prog="shlight", description="Live SH9 ambient lighting for AR headsets.")
    parser.add_argument("--version", action="version", version=f"shlight {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module, helptext in COMMANDS:
        p = sub.add_parser(name, help=helptext)
        mod = importlib.import_module(f"{__name__}.{module}")
        mod.add_arguments(p)
        p.set_defaults(func=mod.run)
    return parser


def _run(args) -> int:
    try:
        return int(args.func(args) or 0)
    except ImportError as exc:  # a command whose optional dependency is not installed
        print(f"shlight {args.command}: unavailable ({exc})", file=sys.stderr)
        return 2


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return _run(args)
    except InputError as exc:
        print(f"shlight {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"shlight {args.command}: interrupted", file=sys.stderr)
        return 130

