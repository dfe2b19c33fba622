"""The live service: source → frame → coefficients → message → clients.

* :mod:`.sources`: frame sources, one module per family, and the specification parser;
* :mod:`.capture`: the capture thread (newest frame only, reconnect with backoff, hang watchdog);
* :mod:`.probe`: one probe: frames through the engine's one call into messages;
* :mod:`.temporal`: smoothing with snap-through, change threshold, keep-alive;
* :mod:`.message`: the wire message and its JSON Schema;
* :mod:`.server`: WebSocket fan-out and HTTP routes; :mod:`.session`: one client's outbox;
* :mod:`.dashboard`: what the HTTP side shows (``static/``), thumbnails; :mod:`.status`:
  /healthz and /metrics.

Built on :mod:`provider.core`; nothing in the maths imports from here.
"""
