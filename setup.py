"""The C kernels (the rest of the build is pyproject.toml).

Three small kernels decode an 8-bit frame through its table inside the pass that consumes it
(issue 34: a Raspberry Pi-class core's budget), built as the ``websockets`` library builds
its ``speedups`` (its ``BUILD_EXTENSION``), by ``SHLIGHT_BUILD_KERNELS``:

* unset: optional: an install without a C compiler still works, on each kernel's Python
  twin (``provider/core/radiometry/blocks.py``, ``provider/core/sh9/fold_twin.py``,
  ``provider/core/sh9/equirect_pass.py``);
* ``yes``: required: a kernel that does not compile fails the install (CI and
  ``scripts/test.sh``, so that the tests never run the twins in the kernels' place unseen);
* ``no``: not built: the twins alone.
"""
import os
import sys

from setuptools import Extension, setup

BUILD = os.environ.get("SHLIGHT_BUILD_KERNELS", "").strip().lower()
if BUILD not in ("", "yes", "no"):
    sys.exit(f"SHLIGHT_BUILD_KERNELS must be yes, no or unset, got {BUILD!r}")
# -O3: GCC vectorises the kernels' inner loops (SSE2 on x86-64, NEON on a 64-bit Pi).
FLAGS = [] if sys.platform == "win32" else ["-O3"]
SHARED = "provider/core/_kernels"          # the checks and the first pass the kernels share
KERNELS = [
    Extension(name, [source], include_dirs=[SHARED],
              depends=[f"{SHARED}/buffer_check.h", f"{SHARED}/first_pass_band.h"],
              extra_compile_args=FLAGS, optional=BUILD != "yes")
    for name, source in (("provider.core.radiometry._blocks", "provider/core/radiometry/_blocks.c"),
                         ("provider.core.sh9._fold", "provider/core/sh9/_fold.c"),
                         ("provider.core.sh9._equirect", "provider/core/sh9/_equirect.c"),
                         ("provider.core.lights._lights", "provider/core/lights/_lights.c"))
]

setup(ext_modules=[] if BUILD == "no" else KERNELS)
