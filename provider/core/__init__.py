"""The maths: SH basis, projections, the engine, image reading.

Frames in, coefficients out. Nothing here knows about sockets, threads, asyncio or the
wire message; the live service (:mod:`provider.live`) and the tools (:mod:`provider.verify`,
:mod:`provider.bench`) are built on top of it, never the other way round.

* :mod:`.sh`: the real SH basis, irradiance, the 4×4 matrices, rotation, windowing;
* :mod:`.projections`: per-pixel directions and exact solid angles, one class per projection;
* :mod:`.engine`: :class:`SH9Projector` (precompute once, project each frame) and
  :func:`compute_sh9`;
* :mod:`.images`: reading image files into the engine's frame contract;
* :mod:`.errors`: :class:`InputError`.
"""
