"""The library on a busy machine (issue 33): the engine runs BLAS on one thread inside its
own calls, whoever imported it, and gives the caller's pool back afterwards.

Imported as a library (no command line to size the pool before numpy loads), OpenBLAS
starts one worker per core; on a busy machine they wait for each other, and a 1920×960
frame took 16× its one-thread time beside one CPU hog. The speed itself is measured by
``shlight bench`` (a benchmark, not a test); here, what a user relies on: the pool's size
during and after a call, seen from inside the call.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys

SCRIPT = r"""
import json
import numpy as np
from threadpoolctl import threadpool_info, threadpool_limits
from provider.core.lights.tracking import LightTracker
from provider.core.sh9.engine import SH9Projector

def blas_threads():
    return sorted({i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"})

class WatchingTracker(LightTracker):
    # The engine hands its per-frame lights to the caller's tracker mid-call: a window
    # into the call.
    seen = []
    def update(self, analysis):
        self.seen.append(blas_threads())
        return super().update(analysis)

threadpool_limits(2, user_api="blas")          # a caller's pool: two threads
frame = (np.random.default_rng(0).random((64, 128, 3)) * 255).astype(np.uint8)
frame[5:8, 20:24] = 255
p = SH9Projector(128, 64, lights="auto")
tracker = WatchingTracker()
p.project(frame, tracker=tracker)
print(json.dumps({"before": [2], "during": tracker.seen, "after": blas_threads()}))
"""


def test_the_engine_runs_blas_on_one_thread_and_gives_the_pool_back():
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", SCRIPT], env=env, capture_output=True,
                         text=True, timeout=120, check=True).stdout
    seen = json.loads(out.strip().splitlines()[-1])
    if not seen["after"]:
        import pytest
        pytest.skip("numpy here has no BLAS that threadpoolctl knows")
    assert seen["during"] == [[1]], seen        # one thread inside the call
    assert seen["after"] == [2], seen           # the caller's two threads after it


def test_the_bench_measures_the_library_beside_a_hog(tmp_path):
    """`shlight bench --sections speed` ends with the library beside a CPU hog: the three
    cases, each a time and its ratio to the pool sized to one, written as a table (numbers
    only: speed is the bench's, not a test's)."""
    from provider.bench.speed import library_beside_a_hog, write_library_beside_a_hog
    rows = library_beside_a_hog(n=3, size=(256, 128))
    assert [r["case"] for r in rows] == ["BLAS pool sized to 1 before numpy loads",
                                         "as a library (the engine's own limit)",
                                         "as a library, the limit taken out"]
    assert all(r["ms"] > 0 for r in rows) and rows[0]["ratio"] == 1.0
    write_library_beside_a_hog(rows, tmp_path)
    table = (tmp_path / "library_beside_a_hog.md").read_text()
    assert table.count("\n| ") == 4 and "× pool sized to 1" in table
