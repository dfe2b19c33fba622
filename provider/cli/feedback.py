"""What a command says on stderr while it works: notes, warnings and progress of long work."""
from __future__ import annotations

import sys
import time


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
