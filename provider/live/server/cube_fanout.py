"""Reflection cubes to their consumers (docs/contract.md §12, "Transport"): the WebSocket
clients that asked (``{"type": "subscribe", "environment": true}``), the publishers (MQTT,
``PREFIX/PROBE/environment``, retained) and ``GET /environment.ktx2?probe=NAME``.

Each cube is encoded once by its probe's thread (:mod:`.environment`) and framed here once
for every client: an ``environment`` JSON text frame, then one binary frame of the KTX2
bytes. Only clients that asked are visited; a client that never asks receives none and
costs nothing. A slow client keeps only the newest cube of each probe (its outbox,
:class:`~provider.live.server.session.ClientSession`). The server (:mod:`.server`) calls in here
from its routes and its subscribe handling; this module knows nothing of the maths.
"""
from __future__ import annotations

import logging

from ..reflections.cube import ENCODING, FORMAT
from .session import ALL, ClientSession, binary_frame, text_frame

log = logging.getLogger("shlight.server")

CONTENT_TYPE = "image/ktx2"


class EnvironmentFanout:
    """The server's cubes: the latest of each probe, the clients that want them, counters."""

    def __init__(self, server):
        self.server = server
        self.clients: set[ClientSession] = set()     # asked for cubes
        self.latest: dict = {}                        # probe -> EnvironmentCube
        self.updates = 0                              # cubes published
        self.messages_sent = 0                        # (message, KTX2) pairs handed to clients
        self.bytes_sent = 0                           # their bytes (both frames' payloads)
        self.skipped = 0                              # replaced before a slow client took it
        for p in server.probes.values():    # a cube that gains an export (gltf, arcore) later
            if p.environment is not None:
                p.environment.exported = self.exports_changed

    @property
    def probes(self) -> list[str]:
        """The probes that make cubes (``shlight serve --environment``)."""
        return [name for name, p in self.server.probes.items() if p.environment is not None]

    # -- from the probes (event loop) -----------------------------------------------------
    def publish(self, cube) -> None:
        """A probe's new cube: to every client that asked and subscribes to its probe,
        framed once; to every publisher that takes cubes."""
        self.latest[cube.probe] = cube
        self.updates += 1
        subscribers = self.server._subscribers.get(cube.probe, ())
        frames = None
        for client in self.clients:
            if client in subscribers:
                if frames is None:
                    frames = text_frame(cube.text) + binary_frame(cube.ktx2)
                self._offer(client, cube, frames)
        for publisher in self.server.publishers:
            offer = getattr(publisher, "offer_environment", None)
            if offer is not None:
                offer(cube.probe, cube.ktx2)
        if cube.exports or cube.export_errors:
            self.exports_changed(cube)

    def exports_changed(self, cube) -> None:
        """The probe's exports that carry the cube (``to`` gltf, arcore) have a new cube: the
        latest export, converted once per format, to each client that asked for one (the
        same sh9 ``seq``, a new ``environment_seq``)."""
        framed = {}
        for client in self.server._subscribers.get(cube.probe, ()):
            if client.to in cube.exports or client.to in cube.export_errors:
                if client.to not in framed:
                    framed[client.to] = self.server._latest(cube.probe, client.to)
                if framed[client.to] is not None:
                    client.offer(cube.probe, framed[client.to])

    def _offer(self, client: ClientSession, cube, frames: bytes | None = None) -> None:
        if client.offer_environment(cube.probe, cube.text, cube.ktx2, frames):
            self.skipped += 1
        self.messages_sent += 1
        self.bytes_sent += len(cube.text) + len(cube.ktx2)

    # -- from the server's subscribe handling (event loop) ----------------------------------
    def subscribe(self, client: ClientSession, msg: dict) -> dict | None:
        """Apply a subscribe's ``environment`` field (after its probe and rate): returns
        None, or an ``error`` reply (the subscription to the lighting stands)."""
        if "environment" not in msg:
            if client.environment:     # a new probe subscription: its newest cube at once
                for name in self._subscribed(client):
                    if name in self.latest:
                        self._offer(client, self.latest[name])
            return None
        wanted = msg["environment"]
        if not isinstance(wanted, bool):
            return {"type": "error", "error": "bad_request",
                    "detail": "environment must be true or false"}
        if not wanted:
            client.environment = False
            self.clients.discard(client)
            return None
        subscribed = self._subscribed(client)
        offering = [name for name in subscribed if self.server.probes[name].environment]
        if not offering:
            if not self.probes:
                which = "no probe of this server makes"
            elif len(subscribed) == 1 and client.subscription != ALL:
                which = f"probe {subscribed[0]} makes no"
            else:
                which = "none of the subscribed probes makes"
            return {"type": "error", "error": "environment_off",
                    "detail": f"{which} reflection cubes (shlight serve --environment; "
                              f"probes with cubes: {', '.join(self.probes) or 'none'}); "
                              "the lighting (sh9) still comes"}
        client.environment = True
        self.clients.add(client)
        for name in offering:        # the newest cube at once; later ones as they come
            cube = self.latest.get(name)
            if cube is not None:
                self._offer(client, cube)
        return None

    def forget(self, client: ClientSession) -> None:
        """The client left."""
        self.clients.discard(client)

    def _subscribed(self, client: ClientSession) -> list[str]:
        return [name for name, subs in self.server._subscribers.items() if client in subs]

    # -- HTTP (GET /environment.ktx2?probe=NAME) --------------------------------------------
    def http(self, query) -> tuple[int, bytes, str, list, dict | None]:
        """(status, body, content type, headers, error) of ``GET /environment.ktx2``;
        ``error`` (code, detail) instead of a body when there is no cube to give."""
        name = query.get("probe", [next(iter(self.server.probes))])[0]
        probe = self.server.probes.get(name)
        if probe is None:
            return 404, b"", "", [], ("unknown_probe", f"no probe {name!r}")
        if probe.environment is None:
            return 404, b"", "", [], ("environment_off",
                                      f"probe {name} makes no reflection cubes (shlight serve "
                                      "--environment)")
        cube = self.latest.get(name)
        if cube is None:
            return 503, b"", "", [], ("no_environment_yet",
                                      f"probe {name} has no reflection cube yet")
        headers = [("X-Shlight-Seq", str(cube.seq)),
                   ("X-Shlight-Sh9-Seq", str(cube.message["sh9_seq"])),
                   ("Content-Disposition", f'inline; filename="{name}-environment.ktx2"')]
        return 200, cube.ktx2, CONTENT_TYPE, headers, None

    # -- hello, /healthz, /metrics --------------------------------------------------------------
    def hello(self) -> dict:
        """The hello fields: which probes make cubes, and in what encoding."""
        return {"environment": self.probes, "environment_encoding": ENCODING,
                "environment_format": FORMAT}

    def health(self) -> dict:
        return {"probes": self.probes, "clients": len(self.clients), "updates": self.updates,
                "messages_sent": self.messages_sent, "bytes_sent": self.bytes_sent,
                "skipped": self.skipped}

    def add_metrics(self, m) -> None:
        probes = [p for p in self.server.probes.values() if p.environment is not None]
        if not probes:
            return

        def per(fn):
            return [({"probe": p.name}, fn(p.environment)) for p in probes]
        m.add("shlight_environment_updates_total", "counter",
              "Reflection cubes made (shlight serve --environment).", per(lambda w: w.updates))
        m.add("shlight_environment_update_bytes", "gauge",
              "KTX2 bytes of the last reflection cube.", per(lambda w: w.bytes))
        m.add("shlight_environment_compute_seconds", "gauge",
              "Time to project the last reflection cube (its own thread).",
              per(lambda w: w.compute_ms / 1e3))
        m.add("shlight_environment_encode_seconds", "gauge",
              "Time to encode the last reflection cube as KTX2.",
              per(lambda w: w.encode_ms / 1e3))
        m.add("shlight_environment_errors_total", "counter",
              "Reflection cubes that failed.", per(lambda w: w.errors))
        m.add("shlight_environment_clients", "gauge",
              "WebSocket clients that asked for reflection cubes.", len(self.clients))
        m.add("shlight_environment_messages_sent_total", "counter",
              "Reflection cubes handed to WebSocket clients.", self.messages_sent)
        m.add("shlight_environment_sent_bytes_total", "counter",
              "Bytes of reflection cubes handed to WebSocket clients.", self.bytes_sent)
        m.add("shlight_environment_skipped_total", "counter",
              "Reflection cubes replaced by a newer one before a slow client took them.",
              self.skipped)
