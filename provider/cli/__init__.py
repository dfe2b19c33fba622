"""`shlight COMMAND ...`: the command line. :data:`COMMANDS` lists every command, the module
of this package that holds its options and its one-line help (`shlight --help` prints them).

User errors (bad files, bad options) print one clear line to stderr and exit with status
2; they never show a traceback. Each command's options live in its module here (the frame@time
syntax in :mod:`.frames`; the engine options shared by several in :mod:`.options`; output
paths in :mod:`.outputs`); what the command does lives in its layer and is imported only when
the command runs.
"""
from __future__ import annotations

from .threads import limit_blas_threads

limit_blas_threads()        # before anything below (or a command) imports numpy

import argparse  # noqa: E402
import importlib  # noqa: E402
import sys  # noqa: E402

from .. import __version__  # noqa: E402
from ..core.errors import InputError  # noqa: E402
from .options import Parser  # noqa: E402

#: (command, module of this package, help)
COMMANDS = (
    ("compute", "compute", "print the wire JSON (docs/contract.md §3) for one image"),
    ("export", "export", "print one image's lighting in another engine's layout (--to FORMAT)"),
    ("serve", "serve", "serve live coefficients over WebSocket (default: demo source)"),
    ("validate-shaders", "validate", "prove the GLSL/HLSL compute what the CPU computes"),
    ("bench", "bench", "speed against error: Markdown table and PNG plot"),
    ("calibrate-response", "calibrate",
     "a camera's response curve from FRAME@SECONDS brackets -> camera.json"),
    ("calibrate-lens", "lens",
     "a fisheye lens's curve from chessboard photos of one lens -> a lens file (--lens FILE)"),
    ("locate-ball", "locate", "find a mirror ball in a frame: its circle as JSON (for --ball)"),
    ("environment", "environment",
     "one image's reflection cube (GGX-prefiltered mips) -> KTX2 (-o cube.ktx2)"),
    ("interpolate", "interpolate",
     "the light at points of the room from several probes at known positions"),
    ("register", "register", "where a printed marker is in a panorama: the camera's pose (§13)"),
    ("marker", "marker", "write a printable registration marker (PNG at print resolution)"),
    ("passthrough", "passthrough",
     "a headset camera's response, exposures and white balance from its views -> JSON"),
)


def build_parser(argv=None) -> argparse.ArgumentParser:
    """The parser; only the command named in ``argv`` gets its options (and imports), so
    that ``shlight --help`` and each command load only what they need (None: all)."""
    parser = Parser(prog="shlight", description="Live SH9 ambient lighting for AR headsets.")
    parser.add_argument("--version", action="version", version=f"shlight {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    wanted = None if argv is None else next((a for a in argv if not a.startswith("-")), "")
    parser.commands = {}        # name -> its parser, whose errors name the command
    for name, module, helptext in COMMANDS:
        p = parser.commands[name] = sub.add_parser(name, help=helptext)
        if wanted is None or wanted == name:
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
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    args, extra = parser.parse_known_args(argv)
    if extra:   # argparse's own parse_args says these as "shlight: error:"; the command's does
        parser.commands.get(getattr(args, "command", None), parser).error(
            "unrecognized arguments: " + " ".join(extra))
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    if getattr(args, "no_table_cache", False):     # read where the projectors are built
        import os
        os.environ["SHLIGHT_TABLE_CACHE"] = "0"
    try:
        if getattr(args, "projection", None) is not None:
            from .options import resolve_projection
            resolve_projection(args, args.command)
        code = _run(args)
        sys.stdout.flush()      # what a command printed fails here, not at exit
        return code
    except InputError as exc:
        print(f"shlight {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"shlight {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:     # `shlight compute pano.exr | head`: the reader left, fine
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except OSError as exc:
        if not _stdout_failed(exc):
            raise
        from .feedback import output_error
        print(f"shlight {args.command}: error: {output_error(exc)}", file=sys.stderr)
        return 2


def _stdout_failed(exc: OSError) -> bool:
    """Whether ``exc`` is stdout's write failing (a full disk, ``> /dev/full``): the error
    of a command that printed with ``print`` rather than :func:`.feedback.write_output`."""
    import errno
    return exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG) and (
        exc.filename is None)

