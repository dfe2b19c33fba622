"""The optional C kernels (the rest of the build is pyproject.toml).

Two small kernels decode an 8-bit frame through its table inside the pass that consumes it
(issue 34: a Raspberry Pi-class core's budget), as the ``websockets`` library builds its
``speedups``: optional, so an install without a C compiler still works, on the exact
numpy/OpenCV path the kernels are tested against. ``SHLIGHT_BUILD_KERNELS=no`` skips them.
"""
import os
import sys

from setuptools import Extension, setup

# -O3: GCC vectorises the kernels' inner loops (SSE2 on x86-64, NEON on a 64-bit Pi).
FLAGS = [] if sys.platform == "win32" else ["-O3"]
KERNELS = [
    Extension("provider.core.radiometry._blocks", ["provider/core/radiometry/_blocks.c"],
              extra_compile_args=FLAGS, optional=True),
    Extension("provider.core.sh9._fold", ["provider/core/sh9/_fold.c"],
              extra_compile_args=FLAGS, optional=True),
]

setup(ext_modules=[] if os.environ.get("SHLIGHT_BUILD_KERNELS") == "no" else KERNELS)
