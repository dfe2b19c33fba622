"""One light probe: source → frame → coefficients → message.

* :mod:`.pipeline`: :class:`~provider.live.probe.pipeline.Probe`, the engine's one call per
  frame and the probe's latest message;
* :mod:`.capture`: the capture thread (newest frame only, reconnects, hang watchdog);
* :mod:`.temporal`: smoothing with snap-through, change threshold, keep-alive;
* :mod:`.registration`: the marker re-measured off the hot path;
* :mod:`.camerafile`: camera.json, a camera's inverse response on disk;
* :mod:`.luxmeter`: a lux meter read live (a number, an MQTT topic, an I²C sensor).

May import: :mod:`provider.core`, :mod:`provider.live.sources`, :mod:`provider.live.wire`,
:mod:`provider.live.reflections`. Nothing of the server.
"""
