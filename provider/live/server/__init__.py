"""``shlight serve``'s network side: WebSockets and HTTP (docs/contract.md §3-§4).

* :mod:`.service`: the server, its routes and its lifecycle;
* :mod:`.session`: one connected client (outbox, rate, writer task);
* :mod:`.limits`: what no client may take from the others (rates, budgets, connections);
* :mod:`.cube_fanout`: reflection cubes to their subscribers;
* :mod:`.replies`, :mod:`.status`, :mod:`.dashboard`: HTTP replies, /healthz and
  /metrics, the dashboard's files (``static/``);
* :mod:`.tls`: wss:// and https://.

May import: :mod:`provider.live.probe`, :mod:`provider.live.wire`,
:mod:`provider.live.reflections`, :mod:`provider.core.errors` and
:mod:`provider.core.conventions`: it knows the maths only through the probe's one call.
"""
