"""shlight: live SH9 ambient lighting for AR.

The library entry point is :func:`compute_sh9` (one image) and :class:`SH9Projector`
(a stream of frames of one size: everything that does not depend on pixels is
precomputed once).
"""
from .sh import irradiance, irradiance_matrices, rotate_coefficients, rotate_matrices  # noqa: F401
from .engine import SH9Projector, SH9Result, compute_sh9, InputError  # noqa: F401

__version__ = "0.1.0"
