"""``shlight serve --mqtt mqtt://[USER:PASS@]HOST[:PORT]/PREFIX``: every probe's wire
messages published to an existing MQTT broker (docs/contract.md §11).

Topic ``PREFIX/PROBE``, payload exactly the wire JSON (the bytes WebSocket clients get),
retained, QoS 0: a subscriber that joins late gets the latest lighting at once. With
``--environment``, each probe's reflection cube too: ``PREFIX/PROBE/environment``, the KTX2
bytes of ``GET /environment.ktx2`` (docs/contract.md §12), retained. ``mqtts://``
connects with TLS (system trust, or ``--mqtt-ca FILE``). Default ports 1883 / 8883; default
prefix ``shlight``.

The broker never delays WebSocket clients: the client library (paho-mqtt) does all its
network I/O in its own thread; :meth:`MqttPublisher.offer`, called on the server's event
loop for each message, only stores the probe's newest message and hands it to paho when
fewer than :attr:`MqttPublisher.MAX_UNWRITTEN` messages are still waiting for the socket.
A slow broker therefore gets the newest message of each probe when it catches up (beyond
what its own socket buffers took before it stalled: docs/mqtt.md); a broker that is down
gets nothing, and paho reconnects with backoff. On every
(re)connection the latest message of each probe is published again, so that a restarted
broker (which may have lost its retained messages) has the current lighting at once.
"""
from __future__ import annotations

import logging
import socket
import sys
import time

# The broker's URL and client are shared with the lux meter's subscriber (wire.mqtt_link).
from .wire.mqtt_link import DEFAULT_PREFIX, MqttTarget, paho_client, parse_mqtt_url

__all__ = ["DEFAULT_PREFIX", "MqttPublisher", "MqttTarget", "parse_mqtt_url"]

log = logging.getLogger("shlight.mqtt")


class MqttPublisher:
    """Publishes the probes' messages to one broker (see the module docstring).

    :meth:`offer` and everything that touches the pending messages run on the event loop
    given to :meth:`start`; paho's callbacks (its own thread) only schedule work there.
    """

    kind = "mqtt"

    #: Messages handed to paho but not yet written to its socket, at most.
    MAX_UNWRITTEN = 8
    #: The socket's send buffer (bytes; Linux doubles it). Small on purpose: loopback and
    #: LAN auto-tuning grow it to megabytes, which a stalled broker would later receive as
    #: tens of seconds of stale lighting; this bounds that to a few dozen messages.
    SEND_BUFFER = 32 * 1024

    def __init__(self, target: MqttTarget, *, ca_file: str | None = None,
                 keepalive: int = 15, backoff_max: float = 10.0):
        import paho.mqtt.client as paho     # a dependency of shlight (pyproject.toml)
        self.target, self.keepalive = target, keepalive
        self.state = "starting"             # starting, connecting, connected, down
        self.error = ""
        self.published = 0                  # handed to the broker's socket
        self.skipped = 0                    # replaced by a newer one before it could go
        self.connects = 0
        self.since = time.time()
        self._latest: dict[str, bytes] = {}
        self._pending: dict[str, bytes] = {}
        self._unwritten = 0
        self._loop = None
        self._stopping = False
        self._ok = paho.MQTT_ERR_SUCCESS
        self._client = client = paho_client(target, ca_file)
        client.reconnect_delay_set(0.5, backoff_max)   # paho accepts float seconds
        client.on_connect = self._on_connect
        client.on_connect_fail = self._on_connect_fail
        client.on_disconnect = self._on_disconnect
        client.on_publish = self._on_publish
        client.on_socket_open = self._on_socket_open

    # -- lifecycle (event loop) -------------------------------------------------------------------
    def start(self, loop) -> None:
        """Connect in paho's thread (never blocks the caller) and keep reconnecting."""
        self._loop = loop
        self.state = "connecting"
        self._client.connect_async(self.target.host, self.target.port, self.keepalive)
        self._client.loop_start()
        log.info("MQTT: publishing to %s (topics %s/PROBE, retained, QoS 0)", self.target.url,
                 self.target.prefix)

    def stop(self) -> None:
        """Disconnect and end paho's thread (blocking: call it in a worker thread)."""
        self._stopping = True
        self._client.disconnect()
        self._client.loop_stop()

    # -- publishing (event loop) --------------------------------------------------------------------
    def offer(self, probe: str, text: bytes) -> None:
        """A probe's new message: publish it now, or as soon as the broker can take it."""
        self._latest[probe] = text
        if probe in self._pending:
            self.skipped += 1
        self._pending[probe] = text
        self._flush()

    def offer_environment(self, probe: str, ktx2: bytes) -> None:
        """A probe's new reflection cube (KTX2 bytes, ``shlight serve --environment``):
        retained on ``PREFIX/PROBE/environment``, newest only, like the lighting."""
        self.offer(f"{probe}/environment", ktx2)

    def _flush(self) -> None:
        if self.state != "connected":
            return
        while self._pending and self._unwritten < self.MAX_UNWRITTEN:
            probe = next(iter(self._pending))
            text = self._pending.pop(probe)
            info = self._client.publish(self.target.topic(probe), text, qos=0, retain=True)
            if info.rc != self._ok:      # lost the connection meanwhile
                self._pending.setdefault(probe, text)
                return
            self._unwritten += 1
            self.published += 1

    def _connected(self) -> None:
        self.state, self.error, self.since = "connected", "", time.time()
        self.connects += 1
        self._unwritten = 0
        log.info("MQTT: connected to %s", self.target.url)
        self._pending.update(self._latest)        # the broker may have lost its retained ones
        self._flush()

    def _lost(self, reason: str, disconnected: bool = False) -> None:
        if self._stopping:
            self.state = "stopped"
            return
        if disconnected and self.state != "connected" and self.error.startswith("refused"):
            return             # the broker's own reason for refusing us says more
        if self.state == "connected":
            log.warning("MQTT: lost %s (%s); WebSocket clients are not affected, reconnecting",
                        self.target.url, reason)
            self.since = time.time()
        elif self.state != "down" or reason != self.error:
            log.warning("MQTT: cannot reach %s (%s); retrying", self.target.url, reason)
        self.state, self.error = "down", reason
        self._unwritten = 0

    def _written(self) -> None:
        self._unwritten = max(0, self._unwritten - 1)
        self._flush()

    # -- paho's callbacks (paho's thread) -----------------------------------------------------------
    def _call(self, fn, *args) -> None:
        try:
            self._loop.call_soon_threadsafe(fn, *args)
        except RuntimeError:         # the event loop is closed: shutting down
            pass

    def _on_connect(self, client, userdata, flags, reason_code, properties) -> None:
        if reason_code.is_failure:
            self._call(self._lost, f"refused: {reason_code}")
        else:
            self._call(self._connected)

    def _on_connect_fail(self, client, userdata) -> None:
        exc = sys.exc_info()[1]      # paho calls this inside its `except OSError`
        reason = (getattr(exc, "strerror", None) or str(exc)) if exc else "connection failed"
        self._call(self._lost, reason)

    def _on_disconnect(self, client, userdata, flags, reason_code, properties) -> None:
        self._call(self._lost, str(reason_code) if reason_code.is_failure else "disconnected",
                   True)

    def _on_socket_open(self, client, userdata, sock) -> None:
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, self.SEND_BUFFER)
        except (OSError, AttributeError):   # not a TCP socket (MQTT over WebSocket, ...)
            pass

    def _on_publish(self, client, userdata, mid, reason_code, properties) -> None:
        self._call(self._written)

    # -- for /healthz, /metrics and the dashboard -------------------------------------------------
    def health(self) -> dict:
        return {"state": self.state, "broker": self.target.url, "prefix": self.target.prefix,
                "error": self.error, "published": self.published, "skipped": self.skipped,
                "connects": self.connects, "since_s": round(time.time() - self.since, 3)}

    def add_metrics(self, m) -> None:
        labels = {"broker": self.target.url}
        m.add("shlight_mqtt_connected", "gauge", "1 while connected to the MQTT broker.",
              [(labels, 1 if self.state == "connected" else 0)])
        m.add("shlight_mqtt_messages_published_total", "counter",
              "Messages handed to the MQTT broker's connection.", [(labels, self.published)])
        m.add("shlight_mqtt_messages_skipped_total", "counter",
              "Messages replaced by a newer one while the broker was slow or down.",
              [(labels, self.skipped)])
        m.add("shlight_mqtt_connects_total", "counter", "Connections made to the broker.",
              [(labels, self.connects)])
