"""The live service: source → frame → coefficients → message → clients.

One room per concern (docs/architecture.md), from the bottom up:

* :mod:`.sources`: frame sources, one module per family, and the specification parser;
* :mod:`.wire`: the wire message, its JSON Schema and its layouts for other engines;
* :mod:`.reflections`: a probe's live reflection cube (its worker thread) and the KTX2
  writer;
* :mod:`.probe`: one light probe: capture thread, the engine's one call per frame, the
  temporal filter, live registration, a camera's response file;
* :mod:`.server`: WebSocket fan-out and HTTP routes, one client's session, limits, TLS,
  /healthz and /metrics, the dashboard; :mod:`.mqtt`: the MQTT publisher.

Built on :mod:`provider.core`; nothing in the maths imports from here.
"""
