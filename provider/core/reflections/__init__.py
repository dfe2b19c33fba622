"""The reflections product: an HDR radiance cube and its GGX-prefiltered mips
(docs/contract.md §12).

* :mod:`.environment`: :class:`~provider.core.reflections.environment.EnvironmentProjector`
  (precompute once, project each frame, as the SH9 engine does);
* :mod:`.overlap`: where the work image's pixels fall on the base cube, binned a few rows
  at a time;
* :mod:`.prefilter`: GGX prefiltering as a fixed sparse operator;
* :mod:`.bright`: the brightest work pixels, prefiltered from their own directions;
* :mod:`.work_image`: the work image filled by the pass that decodes the frame anyway
  (the cube's sink in :mod:`provider.core.framepass`);
* :mod:`.gltf_ibl`: the cube as glTF ``EXT_lights_image_based`` images (Babylon.js).

May import: geometry, radiometry, :mod:`provider.core.framepass`,
:mod:`provider.core.options`, :mod:`provider.core.table_cache`. Not the other products.
"""
