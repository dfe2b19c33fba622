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
from .core.sh import irradiance, irradiance_matrices, rotate_coefficients, rotate_matrices  # noqa: F401
from .core.engine import SH9Projector, SH9Result, compute_sh9  # noqa: F401
from .core.errors import InputError  # noqa: F401

__version__ = "0.1.0"
