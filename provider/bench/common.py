"""What the bench sections share: timing against a floor, progress, a simulated 8-bit
camera, and the float64 reference projection."""
from __future__ import annotations

import os
import subprocess
import sys
import time

#: One core: BLAS and OpenCV threads pinned before numpy/cv2 start their pools.
SINGLE_CORE_ENV = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def _median_ms_cycling(fn, frames, repeat):
    """Median ms of ``fn(frame)`` over ``repeat`` passes through ``frames``, a different
    frame each call, as live video delivers them (a frame that was just timed is not
    served again from the cache, which would flatter the floor most)."""
    fn(frames[0])
    times = []
    for _ in range(repeat):
        for f in frames:
            t0 = time.perf_counter()
            fn(f)
            times.append(time.perf_counter() - t0)
    times.sort()
    return times[len(times) // 2] * 1e3


def _median_ms(fn, repeat):
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    times.sort()
    return times[len(times) // 2] * 1e3


def _progress(msg):
    print(msg, file=sys.stderr, flush=True)


def _to_srgb8(hdr, exposure):
    import numpy as np
    v = np.clip(hdr * exposure, 0, 1)
    s = np.where(v <= 0.0031308, 12.92 * v, 1.055 * np.power(v, 1 / 2.4) - 0.055)
    return np.round(s * 255).astype(np.uint8)


def _auto_exposure(hdr):
    """Camera-like auto exposure: the median luminance maps to mid-grey (0.18)."""
    import numpy as np
    lum = np.maximum(hdr, 0).mean(axis=-1)
    return 0.18 / max(float(np.median(lum)), 1e-6)


def _exact_float64(frame, lut=None):
    """Float64 exact projection of an equirect frame (the error reference)."""
    import numpy as np
    from ..core.geometry.projections import Equirect
    h, w = frame.shape[:2]
    p = Equirect(w, h)
    rows, cols = p.row_integrals(), p.col_integrals()
    lin = lut[frame] if lut is not None else np.maximum(np.nan_to_num(frame.astype(np.float64)), 0)
    part = np.einsum("rh,hwc->rwc", rows, lin, optimize=True)
    part = np.einsum("rwc,kw->rkc", part, cols)
    out = np.zeros((9, 3))
    for k, const, ri, ci in Equirect.SEPARABLE_TERMS:
        out[k] += const * part[ri, ci]
    return out


def cpu_seconds(pid: int) -> float:
    """User + system CPU seconds of a process, all its threads (Linux /proc); NaN when it
    cannot be read (the process is gone, or no /proc)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return float("nan")


def stop(proc: subprocess.Popen, timeout: float = 15.0) -> None:
    """Terminate a process (a server the bench or a test started); kill it if it does not
    stop in ``timeout`` s, and reap it."""
    proc.terminate()
    try:
        proc.wait(timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait(5)
