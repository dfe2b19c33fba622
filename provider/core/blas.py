"""The BLAS pool held to one thread inside the engine's own calls, whoever calls them.

The engine's matrix products are small and memory-bound (:mod:`provider.cli.threads` says
why one thread is fastest). The command line sizes the pool before numpy loads; a program
that imports the library may not, and on a busy machine OpenBLAS's workers, one per core,
then wait for each other: ``SH9Projector.project`` on a 1920×960 8-bit frame took 400 ms
beside one CPU hog on 2 cores in an audit, against 25 ms on one thread (here: 71 ms against
24.6 ms; with this module 24.4 ms). threadpoolctl, the kept library for exactly this, limits
the pools for the duration of a call (about 20 µs) and restores them after it
(tests/core/test_blas_threads.py).

No threads of our own, no I/O: a pool's size is a library setting.
"""
from __future__ import annotations

import functools

try:
    from threadpoolctl import ThreadpoolController
except ImportError:         # an install without it: the caller's pool sizes stand
    ThreadpoolController = None

_controller = None


def _blas():
    """The loaded BLAS libraries' controllers (found once, when first needed)."""
    global _controller
    if _controller is None and ThreadpoolController is not None:
        _controller = ThreadpoolController().select(user_api="blas")
    return _controller


def one_blas_thread(method):
    """Decorate a per-frame entry point: it runs with BLAS on one thread, the pools' sizes
    restored after it. Nothing is changed, and nothing costs, when they are one already
    (the command line's case)."""
    @functools.wraps(method)
    def wrapper(*args, **kwargs):
        blas = _blas()
        if not blas or all(c.num_threads == 1 for c in blas.lib_controllers):
            return method(*args, **kwargs)
        with blas.limit(limits=1):
            return method(*args, **kwargs)
    return wrapper
