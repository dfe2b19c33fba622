"""What a command says on stderr while it works: notes, warnings and progress of long work."""
from __future__ import annotations

import sys
import time


def write_output(text: str) -> None:
    """``text`` and a newline on stdout, flushed now, so that a write that fails (a full
    disk, ``> /dev/full``) fails here, in one line (:class:`InputError`, exit 2), rather
    than as a traceback, or at exit. A reader that left (``| head``) raises
    :class:`BrokenPipeError`, which the command line ends quietly."""
    try:
        sys.stdout.write(text + "\n")
        sys.stdout.flush()
    except BrokenPipeError:
        raise
    except OSError as exc:
        raise output_error(exc) from None


def output_error(exc: OSError):
    """The :class:`InputError` of a failed write to stdout; stdout is pointed at the null
    device first, so that the exit's own flush of what is left does not fail again."""
    import os
    from ..core.errors import InputError
    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass
    return InputError(f"cannot write the output: {exc.strerror or exc}")


def say(command: str, kind: str, text: str) -> None:
    """One line on stderr, e.g. ``shlight compute: warning: ...``."""
    print(f"shlight {command}: {kind}: {text}", file=sys.stderr, flush=True)


class Progress:
    """A progress callback (fraction done) that prints ``what: 40 % (12 s)`` on stderr: on
    one rewritten line on a terminal, else one line per 20 %."""

    def __init__(self, command: str, what: str):
        self.prefix = f"shlight {command}: {what}"
        self.tty = sys.stderr.isatty()
        self.step = 0.05 if self.tty else 0.2
        self.shown = -1.0
        self.t0 = time.monotonic()

    def __call__(self, fraction: float) -> None:
        if fraction < 1.0 and fraction - self.shown < self.step:
            return
        self.shown = fraction
        line = f"{self.prefix}: {fraction * 100:3.0f} % ({time.monotonic() - self.t0:.0f} s)"
        end = "\n" if (not self.tty or fraction >= 1.0) else ""
        print(("\r" if self.tty else "") + line, end=end, file=sys.stderr, flush=True)
