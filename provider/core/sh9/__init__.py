"""The SH9 product: frames in, nine coefficients per channel, matrices and statistics out.

* :mod:`.engine`: :class:`~provider.core.sh9.engine.SH9Projector` (precompute once, project
  each frame) and :func:`~provider.core.sh9.engine.compute_sh9`;
* :mod:`.clipping`: samples clipped at the top code and the light they carry;
* :mod:`.tables`: the per-pixel tables of a non-separable projection, made compactly and
  kept on disk (:mod:`provider.core.table_cache`);
* :mod:`.lens_fold`: fisheye lenses projected through a mirror fold and radial tables (the C
  kernel ``_fold.c``, or its Python twin :mod:`.fold_twin`);
* :mod:`.meter`: a lux meter's reading closes what the camera clipped;
* :mod:`.sun_colour`: a clipped sun's colour without a chroma meter (its rim, or pvlib's
  SPECTRL2 beam at its elevation, imported only then);
* :mod:`.bracket_projection`: a bracket projected (``shlight compute FRAME@T ...``) and the
  live merge of a source that cycles its exposure (the merge's maths is radiometry's).

May import: geometry, radiometry, :mod:`provider.core.framepass` (the engine's one pass
over a frame, its sinks here: the SH9 sums, the clip counter, the meter's up-facing sum),
:mod:`provider.core.options`, :mod:`provider.core.table_cache`
and the public classes of :mod:`provider.core.lights` (the engine hands its decoded frame to
the lights extractor, so that a frame is decoded once for both). Not
:mod:`provider.core.reflections`.
"""
