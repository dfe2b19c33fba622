"""JSON a user hands over (a lens file, a Theta option's value), parsed strictly: RFC 8259
JSON of finite numbers (Python's reader takes ``NaN`` and ``Infinity``, which no other JSON
reader, and no camera, does, and reads 1e400 as infinity), nested at most ``max_depth``
deep (Python's reader recurses: ``[`` × 100,000 is a RecursionError, not a ValueError).
Every refusal is one :class:`~.errors.InputError` line naming ``what``."""
from __future__ import annotations

import json
import math

from .errors import InputError


def _no_constant(word: str):
    raise ValueError(f"{word} is not a JSON number (JSON numbers are finite)")


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):        # 1e400: Python's reader makes it inf
        raise ValueError(f"{text} is beyond the range of a JSON number (a double)")
    return value


def depth(value) -> int:
    """How deep lists and objects nest in a parsed JSON value (a scalar: 0)."""
    deepest, todo = 0, [(value, 1)]
    while todo:
        item, level = todo.pop()
        children = item.values() if isinstance(item, dict) else \
            item if isinstance(item, list) else None
        if children is not None:
            deepest = max(deepest, level)
            todo.extend((c, level + 1) for c in children)
    return deepest


def parse_json(text: str, what: str, max_depth: int):
    """The value of JSON ``text``; InputError ``"{what}: ..."`` for anything but strict
    JSON nested at most ``max_depth`` deep."""
    try:
        value = json.loads(text, parse_constant=_no_constant, parse_float=_finite)
    except RecursionError:
        raise InputError(f"{what}: JSON nested too deeply (at most {max_depth} levels)") from None
    except ValueError as exc:       # JSONDecodeError, a constant, a number of > 4300 digits
        raise InputError(f"{what}: not JSON: {exc}") from None
    if depth(value) > max_depth:
        raise InputError(f"{what}: JSON nested too deeply (at most {max_depth} levels)")
    return value
