"""shlight: live SH9 ambient lighting for AR.

The library entry point is :func:`compute_sh9` (one image) and :class:`SH9Projector`
(a stream of frames of one size: everything that does not depend on pixels is
precomputed once).

The package is layered, data flowing one way (docs/architecture.md):

* :mod:`provider.core`: the maths (SH basis, projections, the engine, image reading);
* :mod:`provider.live`: the live service (sources, capture, probes, the server, the wire
  message), built on the maths;
* :mod:`provider.verify` and :mod:`provider.bench`: tools built on both (shader
  verification, benchmarks);
* :mod:`provider.cli`: the ``shlight`` command line.
"""
from __future__ import annotations

import importlib

__version__ = "0.1.0"

# The library names are imported on first use (PEP 562), not here: importing the package
# must not load numpy, so that `shlight --help` is instant and the command line can size
# numpy's thread pools before numpy starts them (provider/cli/threads.py).
_EXPORTS = {
    "irradiance": "core.geometry.sh", "irradiance_matrices": "core.geometry.sh",
    "rotate_coefficients": "core.geometry.sh", "rotate_matrices": "core.geometry.sh",
    "SH9Projector": "core.sh9.engine", "SH9Result": "core.sh9.engine", "compute_sh9": "core.sh9.engine",
    "InputError": "core.errors",
    "EnvironmentProjector": "core.reflections.environment", "EnvironmentResult": "core.reflections.environment",
    "compute_environment": "core.reflections.environment",
    "find_marker": "core.registration.pose", "MarkerPose": "core.registration.pose",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'provider' has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_EXPORTS))
