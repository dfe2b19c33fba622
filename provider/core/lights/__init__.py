"""The lights product: a scene's compact bright sources as directional lights plus SH9
ambient (docs/contract.md §10).

* :mod:`.extractor`: :class:`~provider.core.lights.extractor.LightExtractor`, the lights
  of one decoded frame, and its detection copy's sink in the frame pass;
* :mod:`.analysis`: the results (:class:`~provider.core.lights.analysis.Light`) and the
  evaluator of light sets;
* :mod:`.tracking`: hysteresis of lights across frames (a pure state machine);
* :mod:`.shadows`: the shadow a receiver sees (the ratio a shadow catcher multiplies by).

May import: geometry, radiometry, :mod:`provider.core.framepass` (the sink protocol).
Not the other products.
"""
