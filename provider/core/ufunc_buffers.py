"""numpy's ufunc buffers held cache-sized inside the engine's per-frame calls.

A ufunc that broadcasts, casts or reads a strided operand copies it through a buffer of
numpy's buffer size, 8192 elements by default (64 KB of float64 an operand), allocated for
the call. Once a frame's pass has streamed the frame through the cache every such buffer is
cold, and the lights' analysis of a few thousand bright pixels makes dozens: on a
Cortex-A53's 512 KB cache the lit Theta S frame moved 0.5 MB a frame through them
(cachegrind, ``python -m provider.bench.edge --traffic theta``, the buffer size set for the
whole process: 10.94 → 10.46 MB with 1024 elements, 10.42 with 512, 10.58 with 2048; 44.8 →
44.9 M instructions; issue 44). 1024 elements (8 KB of float64) stay in the first-level
cache.

Held for the engine's calls only, it also removed the spread of that count between runs
(10.91-11.19 MB over ``PYTHONHASHSEED`` 1-6 before, 10.91-10.92 after): where the heap put
those 64 KB buffers moved it. A reduction through the buffers (a float32 sum in float64) adds in chunks of the
buffer's size: its last bits may round otherwise; no decision moves (the suite, the lights'
reference frames).

The caller's setting is restored after the call: numpy 2 holds it per thread and context;
numpy 1 holds one for the process, which a call on another thread may then see for its
duration.
"""
from __future__ import annotations

import functools

import numpy as np

#: ufunc buffer size (elements) inside a per-frame call.
UFUNC_BUFFER = 1024


def cache_sized_buffers(method):
    """Decorate a per-frame entry point: it runs with numpy's ufunc buffers of
    :data:`UFUNC_BUFFER` elements, the caller's size restored after it."""
    @functools.wraps(method)
    def wrapper(*args, **kwargs):
        old = np.setbufsize(UFUNC_BUFFER)
        try:
            return method(*args, **kwargs)
        finally:
            np.setbufsize(old)
    return wrapper
