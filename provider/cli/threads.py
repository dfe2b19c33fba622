"""Thread pools sized on purpose, not by accident.

Numpy's BLAS (OpenBLAS in the pip wheels; MKL, BLIS or Accelerate elsewhere) starts one
worker per core on its first large product. The engine's products are small ((6 × H) @
(H × 3W) per band for an equirect frame, (3 × P) @ (P × 9) otherwise: memory-bound, done in
a millisecond or so), and waking workers costs more than they save; worse, between two
frames OpenBLAS's idle workers busy-wait before they sleep, so a 30 fps `shlight serve`
with no client at all kept a whole core spinning on a many-core machine. So every command
runs BLAS and OpenMP with one thread. These libraries read their variables once, when they
load: :func:`limit_blas_threads` runs at the command line's entry, before anything imports
numpy (importing :mod:`provider` loads no numpy). A value the user set is kept.

OpenCV's own pool (resize, LUT, decoding) is set per command by
:func:`limit_opencv_threads`: ``serve`` uses one thread, because each probe already runs in
its own worker thread (several probes use several cores) and per-frame calls are too short
to split; ``compute`` keeps OpenCV's default (one large image benefits from it); ``bench``
pins everything to one core itself, to measure one core.
"""
from __future__ import annotations

import os

#: BLAS/OpenMP variables, for every library numpy may be built with.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                         "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")


def limit_blas_threads() -> None:
    """One BLAS/OpenMP thread unless the user chose otherwise (call before numpy loads)."""
    for name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(name, "1")


def limit_opencv_threads(threads: int = 1) -> None:
    """Size OpenCV's pool (``cv2.setNumThreads``)."""
    import cv2
    cv2.setNumThreads(threads)
