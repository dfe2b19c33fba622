"""The maths: frames in, lighting out. No sockets, threads, asyncio or wire message here.

One room per concern (docs/architecture.md); the import rules are import-linter contracts
in pyproject.toml, checked by the test command. From the bottom up:

* :mod:`.errors`: :class:`~provider.core.errors.InputError`, the one error every layer
  shares; :mod:`.options`: the options every product takes, checked before any frame;
  :mod:`.blas`: BLAS on one thread inside the products' per-frame calls; :mod:`.table_cache`:
  the products' built tables kept on disk (the user's cache folder), read on the next start;
* :mod:`.geometry`: the SH basis and its maths, projections (per-pixel directions and exact
  solid angles), probe projections, cube-map geometry, pinhole views of a sphere;
* :mod:`.radiometry`: from code values to light: image reading, the decode (transfer function
  or camera response as a table, exposure, float clean-up), response fitting, brackets;
* :mod:`.framepass`: one pass over a frame that decodes it once and feeds each product's
  sink (the SH9 sums, the lights' copy, the cube's work image, the clip counter);
* the products, each built on geometry, radiometry and the frame pass: :mod:`.lights` (directional lights),
  :mod:`.reflections` (the radiance cube and its GGX mips, glTF IBL images) and :mod:`.sh9`
  (the SH9 engine, which hands its decoded frame to the lights extractor);
* above them: :mod:`.registration` (markers, XMP pose, ball finding) and :mod:`.conventions`
  (our SH9 and cube in every consumer's convention).

Geometry and radiometry know nothing of each other; lights and reflections know nothing of
each other; nothing here imports :mod:`provider.live`, :mod:`provider.verify`,
:mod:`provider.bench` or :mod:`provider.cli`.
"""
