"""``shlight serve``: live SH9 lighting for every headset, over WebSockets.

One process serves one or more named *probes* (a 360° camera, a fisheye on an edge
device, a file...). Each probe reads its source in a thread, projects the newest frame
onto SH9 with the engine, and every connected client receives the probe's messages.
HTTP is served on the same port.

Connecting
----------
``ws://HOST:8765/`` (default host 127.0.0.1; ``--host 0.0.0.0`` for a LAN, e.g. a
HoloLens). With ``--token T`` a client presents the token either as the query parameter
``?token=T`` or as the header ``Authorization: Bearer T``; otherwise the handshake is
refused with HTTP 401. Browsers send an ``Origin`` header: it must be the server's own
origin (the dashboard) or one given with ``--allow-origin``, else HTTP 403. Programs
(Unity, Python) send no Origin and are not affected. Optional query parameters
``?probe=NAME&max_hz=N&to=FORMAT`` subscribe at connect time (an unknown probe: HTTP 404;
an unknown format: HTTP 400).

Messages (JSON text frames; JSON Schema: ``provider/live/wire/sh9_message.schema.json``)
-------------------------------------------------------------------------------
Server → client:

* ``hello``, first, once::

      {"type": "hello", "version": 1, "provider": "shlight 0.1.0", "frame": "rh-y-up",
       "probes": ["default"], "subscribed": "*", "max_hz": 0, "keepalive_s": 1.0,
       "stale_after_s": 2.0, "max_message_bytes": 4096, "server_time": 1700000000.0}

* ``sh9``, the lighting (docs/contract.md §3), for every subscribed probe: immediately the
  probe's latest message, then whenever the lighting changes beyond the change
  threshold, and at least every ``keepalive_s`` seconds. Fields beyond the contract:
  ``fps`` (source frames per second), ``latency_ms`` (capture of the frame → message,
  on this server; for a relay, from the upstream capture), ``age_s`` (now − ``time``),
  ``resent`` (true: the lighting is within the change threshold of the previous
  message), ``source`` (the source kind). While the source is lost, the last lighting is
  resent every ``keepalive_s`` with ``"stale": true`` and a growing ``age_s``; fresh
  messages resume by themselves after the source reconnects. ``seq`` counts the probe's
  messages. A client only ever gets the *newest* message of a probe: a slow client
  skips messages, never lags behind.
* ``export``, instead of ``sh9``, to a client that asked for another engine's layout
  with ``to`` (``threejs``, ``webxr``, ``unity``, ``arcore``, ``gltf``,
  ``openxr-android``; ``sh9``: the provider's own message again): the same message
  converted by :mod:`provider.live.wire.export` (once per message and format, however many
  clients asked), with the fields that say what its numbers are.
* ``subscribed``, the answer to a subscribe: ``{"type": "subscribed", "probe": "theta",
  "max_hz": 30}``, with ``"to"`` when the subscribe had one or a format is in use.
* ``pong``, the answer to a ping: ``{"type": "pong", "time": <server unix time>,
  "id": <the ping's id>}`` (clients on another machine can estimate their clock offset).
* ``error``: ``{"type": "error", "error": "<code>", "detail": "<text>"}``, codes
  ``bad_json``, ``bad_request``, ``unknown_type``, ``unknown_probe``,
  ``unknown_format`` (the detail lists the formats). The connection stays open.

Client → server (all optional; a plain client just listens):

* ``{"type": "subscribe", "probe": "theta", "max_hz": 30, "to": "webxr"}``: receive only
  this probe (``"*"``: all, the default) at most ``max_hz`` messages per second (0: no
  cap beyond the server's ``--max-hz``), in the layout ``to`` (default ``sh9``). Any
  field may be left out to keep its value.
* ``{"type": "ping", "id": 7}``.
* ``"environment": true`` in a subscribe (``shlight serve --environment``): also the
  probes' reflection cubes, each an ``environment`` JSON message and then one binary frame
  (KTX2; :mod:`provider.live.server.cube_fanout`, docs/contract.md §12).

A client message larger than ``--max-message-bytes`` closes the connection with code
1009. A client that does not read for ``--send-timeout`` seconds is disconnected (the server
pings it with its writes, at most every quarter of the timeout, and a write that finds a ping
unanswered for the timeout drops it: clients must answer pings, as RFC 6455 says). Each
client has a budget (:mod:`provider.live.server.limits`): 20 frames a second after a burst of 50
(messages, pings and pongs alike; beyond it messages are dropped, and 50 more close the
connection with code 1008) and 4 × ``--max-message-bytes`` bytes a second (beyond it the
socket is not read until the budget allows).

Headsets (``--passthrough``): ``ws://HOST:8765/capture?probe=NAME``, behind the same token,
Origin, Host and connection checks, takes per view a ``view`` text message and then the view's
JPEG, and answers each with ``passthrough`` (exposure, white balance, EV100) and, when the
headset's fitted curve moves, ``passthrough_camera``; the fitting is the probe layer's
(:mod:`provider.live.probe.passthrough`, docs/passthrough.md). Without ``--passthrough``:
HTTP 404.

HTTP (same port; the token is needed as for WebSockets, except for ``/healthz`` and ``/static/``)
-------------------------------------------------------------------------------------------------
GET and HEAD only (else 405; a request with a body: 400). A ``Host`` that is not an IP
address, ``localhost``, this machine's name or an ``--allow-host`` name gets 421 (DNS
rebinding), on every path and the WebSocket alike.
``/`` the dashboard, ``/healthz`` (JSON; status ``ok`` or ``degraded``),
``/latest.json?probe=NAME[&to=FORMAT]`` (the latest sh9 message, or its export;
an unknown format: HTTP 400), ``/environment.ktx2?probe=NAME`` (with ``--environment``: the
latest reflection cube, KTX2; docs/contract.md §12), ``/thumbnail.jpg?probe=NAME``
(the newest frame, tone-mapped), ``/metrics`` (Prometheus text format).
"""
from __future__ import annotations

import asyncio
import hmac
import json
import logging
import math
import re
import ssl
import time
from dataclasses import dataclass, replace
from urllib.parse import parse_qs, urlsplit

from websockets.asyncio.server import ServerConnection, serve
from websockets.exceptions import ConnectionClosed
from websockets.frames import CloseCode
from websockets.http11 import Request, Response

from ... import __version__
from ...core.errors import InputError
from . import status
from .cube_fanout import EnvironmentFanout
from .dashboard import DASHBOARD_CSP, PUBLIC_FILES, PUBLIC_HEADERS, static_file, thumbnail_jpeg
from ..wire.export import CUBE_FORMATS, EXPORT_WAIT_S, FORMATS, NATIVE, ExportCache, check_format
from .admission import SilentConnections
from .limits import (BudgetedConnection, ConnectRate, HostCheck, LimitCounters, _peer,
                     duplicate_header, early_refusal, fit_open_files,
                     silent_capacity)
from .replies import _json_error, _response
from ..wire.message import FRAME, SCHEMA_VERSION
from ..probe.passthrough import PassthroughService, PassthroughSettings
from .capture import CAPTURE_PATH, check_capture, serve_capture
from .points import PointFanout, wants_point
from ..probe.pipeline import Probe
from .session import ALL, WRITE_LIMIT, ClientSession, Counters, text_frame

log = logging.getLogger("shlight.server")

DEFAULT_PORT = 8765
#: What a probe may be called (letters, digits, '_', '.', '-'; at most 64).
PROBE_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,63}")


@dataclass
class ServeSettings:
    """Network and safety settings of a :class:`ProviderServer`."""

    host: str = "127.0.0.1"
    port: int = DEFAULT_PORT
    token: str | None = None
    allowed_origins: tuple[str, ...] = ()
    max_clients: int = 500
    max_message_bytes: int = 4096
    send_timeout: float = 10.0
    max_hz: float = 0.0             # cap on every client's rate (0: none)
    deflate: bool = False           # permessage-deflate (costs CPU per client and message)
    tls: ssl.SSLContext | None = None   # wss:// and https:// (provider.live.server.tls)
    allowed_hosts: tuple[str, ...] = ()  # Host names answered beyond the local ones (limits)
    client_frame_rate: float = 20.0     # frames per second a client may send (then 1008)...
    client_frame_burst: float = 50.0    # ...after a burst of this many
    client_byte_rate: float = 0.0       # bytes per second a client may send (0: 4 messages)
    connect_rate: float = 2.0           # WebSocket handshakes a second per address (0: any)...
    connect_burst: float = 20.0         # ...after a burst of this many (limits.ConnectRate)
    head_timeout: float = 5.0           # seconds a connection may stay silent (admission)
    silent_per_address: int = 8         # silent connections an address may hold (admission)
    accept_rate: float = 20.0           # TCP connections a second per address (0: any)...
    accept_burst: float = 40.0          # ...after a burst of this many (admission)
    passthrough: PassthroughSettings | None = None   # /capture (serve --passthrough)


class ProviderServer:
    """The WebSocket + HTTP server around a list of :class:`~provider.live.probe.pipeline.Probe`.

    ``await start()`` binds and starts the probes; ``await stop()`` closes every
    connection (code 1001) and stops the sources. ``port`` is the bound port (useful
    with port 0).
    """

    #: Seconds ``stop()`` waits for connections to close before dropping those still in
    #: their opening handshake.
    SHUTDOWN_GRACE_S = 2.0

    def __init__(self, probes: list[Probe], settings: ServeSettings | None = None,
                 publishers=()):
        if not probes:
            raise InputError("no probes to serve")
        self.settings = settings or ServeSettings()
        self.probes = {p.name: p for p in probes}
        self.environment = EnvironmentFanout(self)     # reflection cubes (--environment)
        self.points = PointFanout(self)     # the light at points (--probe-position, --room)
        for p in probes:
            p.publish = self.publish
            p.publish_environment = self.environment.publish
        self.clients: set[ClientSession] = set()
        # Other destinations of every message (provider.live.mqtt.MqttPublisher): offer(),
        # start(loop), stop() (blocking), health(), add_metrics().
        self.publishers = list(publishers)
        self._subscribers: dict[str, set[ClientSession]] = {name: set() for name in self.probes}
        self.counters = Counters()
        self.started_at = time.time()
        self._server = None
        self._tasks: list[asyncio.Task] = []
        self._thumbnails: dict[str, tuple[int, bytes]] = {}
        self.exports = ExportCache()
        self._allowed_origins = {o.rstrip("/").lower() for o in self.settings.allowed_origins}
        self.host_check = HostCheck(self.settings.host, self.settings.allowed_hosts)
        self.limit_counters = LimitCounters()
        self.connect_rate = ConnectRate(self.settings.connect_rate, self.settings.connect_burst)
        s = self.settings
        self.silent = SilentConnections(s.head_timeout, s.silent_per_address,
                                        accept_rate=s.accept_rate, accept_burst=s.accept_burst)
        self.max_clients = self.settings.max_clients     # lowered by start() to what fits
        self.open_files_limit: int | None = None
        self._stopping = False
        #: the headsets' passthrough fits (``/capture``), or None without --passthrough
        self.passthrough = (PassthroughService(self.settings.passthrough)
                            if self.settings.passthrough is not None else None)

    # -- lifecycle ----------------------------------------------------------------------------
    async def start(self) -> None:
        s = self.settings
        self.open_files_limit, self.max_clients = fit_open_files(s.max_clients)
        self.silent.max_silent = silent_capacity(self.open_files_limit, self.max_clients)
        try:
            self._server = await serve(
                self._handler, s.host, s.port, process_request=self._process_request,
                create_connection=BudgetedConnection.factory(s, self.limit_counters,
                                                              self.silent),
                max_size=s.max_message_bytes, max_queue=4, write_limit=WRITE_LIMIT,
                compression="deflate" if s.deflate else None, close_timeout=2,
                ping_interval=20, ping_timeout=20, server_header=f"shlight/{__version__}",
                ssl=s.tls)
        except OSError as exc:
            raise InputError(f"cannot listen on {s.host}:{s.port}: {exc.strerror or exc}") from None
        for publisher in self.publishers:
            publisher.start(asyncio.get_running_loop())
        self._tasks = [asyncio.create_task(self._run_probe(p), name=f"probe-{p.name}")
                       for p in self.probes.values()]

    async def stop(self) -> None:
        self._stopping = True
        if self._server is not None:
            self._server.close()
            try:
                await asyncio.wait_for(self._server.wait_closed(), self.SHUTDOWN_GRACE_S)
            except asyncio.TimeoutError:
                # Sockets that never finished their opening handshake (an idle TCP connection,
                # a browser's preconnect) would otherwise hold shutdown for the whole
                # open_timeout: drop them.
                pending = [t for t in self._server.handler_tasks if not t.done()]
                log.info("dropping %d connection(s) still in their opening handshake",
                         len(pending))
                for task in pending:
                    task.cancel()
                await asyncio.gather(*pending, return_exceptions=True)
        for task in self._tasks:
            task.cancel()
        await asyncio.gather(*self._tasks, return_exceptions=True)
        if self.passthrough is not None:
            self.passthrough.close()
        for publisher in self.publishers:
            await asyncio.to_thread(publisher.stop)

    @property
    def port(self) -> int:
        return self._server.sockets[0].getsockname()[1]

    async def _run_probe(self, probe: Probe) -> None:
        probe.running = True
        try:
            await probe.run()
        except asyncio.CancelledError:
            raise
        except Exception as exc:  # noqa: BLE001 - Probe.run survives frame errors itself
            log.exception("probe %s: stopped by an unexpected error", probe.name)
            probe.error = f"{type(exc).__name__}: {exc}"
        finally:
            probe.running = False
            if not self._stopping:          # not a shutdown: say so in /healthz, /metrics
                probe.state = "stopped"
                log.error("probe %s: stopped; clients get no more lighting from it",
                          probe.name)

    # -- fan-out --------------------------------------------------------------------------------
    def publish(self, probe: str, text: bytes) -> None:
        """Hand a probe's new message to every client subscribed to it (and to the publishers,
        e.g. MQTT); each format a client asked for is converted and framed once."""
        subscribers = self._subscribers.get(probe, ())
        native = None   # the sh9 message's frame: most clients', so no lookup for them
        framed = {}     # other format -> (text, WebSocket frame), made once
        for client in subscribers:
            to = client.to
            if to is None:
                if native is None:
                    native = text_frame(text)
                client.offer(probe, text, native)
                continue
            if to not in framed:
                converted = self._latest(probe, to)
                framed[to] = (converted, converted and text_frame(converted))
            converted, frame = framed[to]
            if converted is not None:
                client.offer(probe, converted, frame)
        for publisher in self.publishers:
            publisher.offer(probe, text)

    def _latest(self, probe: str, to: str | None) -> bytes | None:
        """The probe's latest message, in the layout ``to`` (None: the sh9 message)."""
        p = self.probes[probe]
        return p.latest_text if to is None else self.exports.text(p.latest_message, to,
                                                                 p.environment)

    def _subscribe(self, client: ClientSession, probe: str | None, max_hz: float | None,
                   to: str | None = ...) -> None:
        if max_hz is not None:
            cap = self.settings.max_hz
            client.max_hz = min(max_hz, cap) if (cap > 0 and max_hz > 0) else (max_hz or cap)
        if to is not ... and to != client.to:   # ...: keep it; None: the sh9 message
            client.to = to
            for name, subscribers in self._subscribers.items():
                latest = self._latest(name, to) if client in subscribers else None
                if latest is not None:
                    client.offer(name, latest)      # the latest lighting, in the new layout
        if probe is None or probe == client.subscription:
            return
        wanted = set(self.probes) if probe == ALL else {probe}
        for name, subscribers in self._subscribers.items():
            if name in wanted and client not in subscribers:
                subscribers.add(client)
                latest = self._latest(name, client.to)
                if latest is not None:
                    client.offer(name, latest)    # a new subscriber needs no wait
            elif name not in wanted and client in subscribers:
                subscribers.discard(client)
                client.forget(name)
        client.subscription = probe

    # -- WebSocket connections --------------------------------------------------------------------
    async def _handler(self, ws: ServerConnection) -> None:
        if len(self.clients) >= self.max_clients:   # raced past process_request
            self.counters.rejected["too_many_clients"] += 1
            await ws.close(CloseCode.TRY_AGAIN_LATER, "too many clients")
            return
        if urlsplit(ws.request.path).path == CAPTURE_PATH:
            return await serve_capture(self, ws)
        client = ClientSession(ws, self.counters, send_timeout=self.settings.send_timeout)
        client.max_hz = self.settings.max_hz      # --max-hz caps clients that ask nothing too
        query = parse_qs(urlsplit(ws.request.path).query)
        self.clients.add(client)
        self.counters.connections += 1
        log.info("client %s joined (%d connected)", client.label, len(self.clients))
        writer = asyncio.create_task(client.write_loop())
        try:
            probe = query.get("probe", [ALL])[0]
            client.subscription = None     # so that _subscribe adds it and offers the latest
            client.to = check_format(query.get("to", [None])[0])   # checked in the handshake
            self._subscribe(client, probe, self._query_hz(query))
            # hello still goes first: the writer sends replies before lighting
            client.reply(self._hello(probe, client.max_hz))
            async for message in ws:
                self._on_message(client, message)
        except ConnectionClosed:
            pass
        finally:
            writer.cancel()
            for subscribers in self._subscribers.values():
                subscribers.discard(client)
            self.environment.forget(client)
            self.clients.discard(client)
            code = ws.close_code if ws.close_code is not None else 1006
            log.info("client %s left (code %d, %d messages sent; %d connected)", client.label,
                     code, client.sent, len(self.clients))

    @staticmethod
    def _query_hz(query) -> float | None:
        try:
            hz = float(query["max_hz"][0])
        except (KeyError, ValueError):
            return None
        return hz if math.isfinite(hz) and hz >= 0 else None

    def _hello(self, subscribed: str, max_hz: float | None) -> dict:
        probe = next(iter(self.probes.values()))
        return {"type": "hello", "version": SCHEMA_VERSION, "provider": f"shlight {__version__}",
                "frame": FRAME, "probes": list(self.probes), "subscribed": subscribed,
                "formats": [NATIVE, *FORMATS],
                "max_hz": float(max_hz or 0.0),
                "keepalive_s": probe.temporal.keepalive, "stale_after_s": probe.stale_after,
                "max_message_bytes": self.settings.max_message_bytes,
                "server_time": time.time(), **self.environment.hello()}

    def _on_message(self, client: ClientSession, message) -> None:
        """Handle one client message; anything malformed gets an ``error`` reply."""
        if not isinstance(message, str):
            return self._client_error(client, "bad_request",
                                      "binary messages are not supported; send JSON text")
        try:
            msg = json.loads(message)
        except (ValueError, RecursionError) as exc:
            return self._client_error(client, "bad_json", f"not JSON: {str(exc)[:200]}")
        if not isinstance(msg, dict):
            return self._client_error(client, "bad_request", "expected a JSON object")
        kind = msg.get("type")
        if kind == "subscribe":
            probe, max_hz = msg.get("probe"), msg.get("max_hz")
            if probe is not None and not (isinstance(probe, str)
                                          and (probe == ALL or probe in self.probes)):
                return self._client_error(client, "unknown_probe",
                                          f"no probe {str(probe)[:80]!r}; probes: "
                                          f"{', '.join(self.probes)} (or \"*\")")
            if max_hz is not None and not (_finite_number(max_hz) and max_hz >= 0):
                return self._client_error(client, "bad_request",
                                          "max_hz must be a number >= 0 (0: no cap)")
            try:
                to = check_format(msg["to"]) if "to" in msg else ...
            except InputError as exc:
                return self._client_error(client, "unknown_format", str(exc))
            self._subscribe(client, probe, None if max_hz is None else float(max_hz), to)
            problem = (self.environment.subscribe(client, msg)   # reflection cubes
                       or self.points.subscribe(client, msg))    # a point's light
            reply = {"type": "subscribed", "probe": client.subscription,
                     "max_hz": float(client.max_hz)}
            if "to" in msg or client.to:
                reply["to"] = client.to or NATIVE
            if "environment" in msg or client.environment:
                reply["environment"] = client.environment
            client.reply(reply)
            if problem is not None:
                self._client_error(client, problem["error"], problem["detail"])
        elif kind == "ping":
            ident = msg.get("id")
            pong = {"type": "pong", "time": time.time()}
            if isinstance(ident, str) and len(ident) <= 64 or _finite_number(ident):
                pong["id"] = ident
            client.reply(pong)
        else:
            self._client_error(client, "unknown_type",
                               f"unknown message type {str(kind)[:80]!r}; "
                               "expected subscribe or ping")

    def _client_error(self, client: ClientSession, code: str, detail: str) -> None:
        self.counters.client_errors += 1
        log.debug("client %s: %s: %s", client.label, code, detail)
        client.reply({"type": "error", "error": code, "detail": detail})

    # -- the handshake and plain HTTP ---------------------------------------------------------------
    def _authorized(self, request: Request, query) -> bool:
        token = self.settings.token
        if not token:
            return True
        given = query.get("token", [None])[0]
        auth = request.headers.get("Authorization", "")
        if given is None and auth[:7].lower() == "bearer ":
            given = auth[7:].strip()
        return given is not None and hmac.compare_digest(given.encode(), token.encode())

    def _origin_allowed(self, request: Request) -> bool:
        origin = request.headers.get("Origin")
        if origin is None:
            return True                 # not a browser
        origin = origin.rstrip("/").lower()
        if ALL in self._allowed_origins or origin in self._allowed_origins:
            return True
        parts = urlsplit(origin)
        host = request.headers.get("Host", "").lower()
        return parts.scheme in ("http", "https") and bool(host) and \
            _strip_default_port(parts.netloc, parts.scheme) == _strip_default_port(host, parts.scheme)

    async def _process_request(self, connection: ServerConnection, request: Request):
        # A Host not answered (421), a method other than GET/HEAD (405), more connections
        # than the open-files limit holds (503), an address past --connect-rate (429):
        # provider.live.server.limits. HEAD: no body.
        speaking = len(self._server.handler_tasks) - len(self.silent)   # sent a request
        refusal = duplicate_header(request) or early_refusal(request, self.host_check,
                                                              speaking, self.max_clients)
        if refusal is None and "websocket" in request.headers.get("Upgrade", "").lower():
            refusal = await self.connect_rate.admit((connection.remote_address or (None,))[0])
        if refusal is not None:
            status, reason, text, headers = refusal
            self.counters.rejected[reason] += 1
            log.warning("refused %s: %s", _peer(connection), text)
            return _response(status, f"{text}\n".encode(), "text/plain; charset=utf-8", headers)
        response = await self._answer(connection, request)
        return replace(response, body=b"") if request.method == "HEAD" and response else response

    async def _answer(self, connection: ServerConnection, request: Request):
        parts = urlsplit(request.path)
        path, query = parts.path, parse_qs(parts.query)
        upgrade = "websocket" in request.headers.get("Upgrade", "").lower()
        if path == "/healthz" and not upgrade:
            return _response(200, json.dumps(self.health()).encode(), "application/json")
        if (path.startswith("/static/") or path in PUBLIC_FILES) and not upgrade:
            # The dashboard's script and style sheet, the JS client and the WebXR page:
            # public package files, no secret in them, fetched without the page's ?token=.
            return await self._route_http(path, query)
        if not self._authorized(request, query):
            self.counters.rejected["token"] += 1
            log.warning("refused %s %s: missing or wrong token", _peer(connection),
                        "WebSocket" if upgrade else path)
            return _response(401, b"missing or wrong token\n", "text/plain; charset=utf-8",
                             [("WWW-Authenticate", 'Bearer realm="shlight"')])
        if upgrade:
            return self._check_websocket(connection, request, path, query)
        try:
            return await self._route_http(path, query)
        except Exception:  # noqa: BLE001
            log.exception("HTTP %s failed", path)
            return _response(500, b"internal error\n", "text/plain; charset=utf-8")

    def _check_websocket(self, connection, request: Request, path: str, query):
        if not self._origin_allowed(request):
            self.counters.rejected["origin"] += 1
            log.warning("refused %s: Origin %s is not allowed (see --allow-origin)",
                        _peer(connection), request.headers.get("Origin"))
            return _response(403, b"Origin not allowed\n", "text/plain; charset=utf-8")
        if path == CAPTURE_PATH:
            return check_capture(self, connection, query)
        if path not in ("/", "/ws"):
            return _response(404, b"WebSocket endpoint is /\n", "text/plain; charset=utf-8")
        probe = query.get("probe", [ALL])[0]
        if probe != ALL and probe not in self.probes:
            self.counters.rejected["unknown_probe"] += 1
            return _response(404, f"no probe {probe!r}; probes: {', '.join(self.probes)}\n"
                             .encode(), "text/plain; charset=utf-8")
        try:
            check_format(query.get("to", [None])[0])
        except InputError as exc:
            self.counters.rejected["unknown_format"] += 1
            return _response(400, f"{exc}\n".encode(), "text/plain; charset=utf-8")
        if "max_hz" in query and self._query_hz(query) is None:   # as a subscribe refuses it
            self.counters.rejected["bad_request"] += 1
            return _response(400, b"max_hz must be a number >= 0 (0: no cap)\n",
                             "text/plain; charset=utf-8")
        if len(self.clients) >= self.max_clients:
            self.counters.rejected["too_many_clients"] += 1
            log.warning("refused %s: %d clients connected (--max-clients)", _peer(connection),
                        len(self.clients))
            return _response(503, b"too many clients\n", "text/plain; charset=utf-8")
        return None                                          # go on with the handshake

    async def _route_http(self, path: str, query) -> Response:
        if path in ("/", "/index.html"):
            body, ctype = static_file("index.html")
            return _response(200, body, ctype, [("Content-Security-Policy", DASHBOARD_CSP)])
        if path.startswith("/static/") or path in PUBLIC_FILES:
            found = static_file(PUBLIC_FILES.get(path) or path[len("/static/"):])
            if found is None:
                return _response(404, b"not found\n", "text/plain; charset=utf-8")
            return _response(200, *found, PUBLIC_HEADERS)
        if path == "/metrics":
            return _response(200, self.metrics().encode(), status.MetricsText.CONTENT_TYPE)
        if path == "/environment.ktx2":
            code, body, ctype, headers, error = self.environment.http(query)
            return _json_error(code, *error) if error else _response(code, body, ctype, headers)
        if wants_point(path, query):   # /latest.json?at=, /probe-grid.json
            return await self.points.http(path, query)
        if path in ("/latest.json", "/thumbnail.jpg"):
            name = query.get("probe", [next(iter(self.probes))])[0]
            probe = self.probes.get(name)
            if probe is None:
                return _json_error(404, "unknown_probe", f"no probe {name!r}")
            if path == "/latest.json":
                try:
                    to = check_format(query.get("to", [None])[0])
                except InputError as exc:
                    return _json_error(400, "unknown_format", str(exc))
                if to in CUBE_FORMATS and probe.environment is not None:
                    # the live cube in this format, encoded by the cube's thread (a first
                    # request waits for it, without blocking the loop; later ones find it)
                    await probe.environment.export_ready(to, EXPORT_WAIT_S)
                latest = self._latest(name, to)
                if latest is None:
                    return _json_error(503, "no_lighting_yet", f"probe {name} has no lighting yet")
                return _response(200, latest, "application/json")
            if probe.image is None:
                return _json_error(503, "no_frame_yet", f"probe {name} has no frame yet")
            return _response(200, await self._thumbnail(probe), "image/jpeg")
        return _response(404, b"not found\n", "text/plain; charset=utf-8")

    async def _thumbnail(self, probe: Probe) -> bytes:
        cached = self._thumbnails.get(probe.name)
        if cached is None or cached[0] != probe.image_seq:
            seq, image = probe.image_seq, probe.image
            cached = (seq, await asyncio.to_thread(thumbnail_jpeg, image))
            self._thumbnails[probe.name] = cached
        return cached[1]

    # -- health and metrics (provider.live.server.status) ---------------------------------------------------
    def health(self) -> dict:
        return status.health(self)

    def metrics(self) -> str:
        return status.metrics(self)


def _finite_number(x) -> bool:
    """A JSON number that is a finite float (a 400-digit integer is not: float() overflows)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return False
    try:
        return math.isfinite(float(x))
    except OverflowError:
        return False


def _strip_default_port(netloc: str, scheme: str) -> str:
    default = {"http": ":80", "https": ":443"}.get(scheme, "")
    return netloc[: -len(default)] if default and netloc.endswith(default) else netloc
