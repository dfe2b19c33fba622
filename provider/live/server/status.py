"""What ``shlight serve`` reports about itself: /healthz and /metrics (Prometheus text).

Reads the server's probes, clients, counters and publishers; changes nothing.
"""
from __future__ import annotations

import math
import time

from ... import __version__


def _label(value: str) -> str:
    return str(value).replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")


class MetricsText:
    """Builds the Prometheus text exposition format (version 0.0.4)."""

    CONTENT_TYPE = "text/plain; version=0.0.4; charset=utf-8"

    def __init__(self):
        self._lines: list[str] = []

    def add(self, name: str, kind: str, help_text: str, samples) -> None:
        """``samples``: a number, or a list of (labels dict, number)."""
        self._lines.append(f"# HELP {name} {help_text}")
        self._lines.append(f"# TYPE {name} {kind}")
        if not isinstance(samples, list):
            samples = [({}, samples)]
        for labels, value in samples:
            lab = ",".join(f'{k}="{_label(v)}"' for k, v in labels.items())
            v = float(value)
            text = "NaN" if math.isnan(v) else ("+Inf" if v == math.inf else repr(v))
            self._lines.append(f"{name}{{{lab}}} {text}" if lab else f"{name} {text}")

    def text(self) -> str:
        return "\n".join(self._lines) + "\n"


def health(server) -> dict:
    """The /healthz document: overall status, each probe's state, each publisher's."""
    probes = {name: p.health() for name, p in server.probes.items()}
    # a --lux meter without a reading in use: the lighting lacks the light it would close
    ok = all(p["state"] == "live" and "outdated" not in p
             and p.get("meter", {}).get("state", "reading") == "reading"
             for p in probes.values())
    health = {"status": "ok" if ok else "degraded", "provider": f"shlight {__version__}",
              "uptime_s": round(time.time() - server.started_at, 3),
              "clients": len(server.clients), "probes": probes}
    health.update(limits_health(server))
    for publisher in server.publishers:        # e.g. "mqtt": {"state": "connected", ...}
        health[publisher.kind] = publisher.health()
        if health[publisher.kind]["state"] != "connected":
            health["status"] = "degraded"
    if server.environment.probes:              # shlight serve --environment
        health["environment"] = server.environment.health()
    if server.passthrough is not None:          # shlight serve --passthrough
        health["passthrough"] = server.passthrough.health()
    return health

def limits_health(server) -> dict:
    """What the server holds at most (provider.live.server.limits): the effective max_clients,
    below the one asked for when the open-files limit cannot hold that many."""
    return {"max_clients": server.max_clients,
            "max_clients_requested": server.settings.max_clients,
            "open_files_limit": server.open_files_limit,
            # connections that have sent no request yet, and those cut (admission)
            "silent_connections": len(server.silent),
            "silent_connections_cut": dict(sorted(server.silent.cut.items()))}


def limits_metrics(server, m: "MetricsText") -> None:
    """The per-client budgets' counters and the probe tasks' state, for /metrics."""
    c = server.limit_counters
    m.add("shlight_messages_held_total", "counter",
          "Messages that waited for their turn under a client's max_hz.",
          server.counters.messages_held)
    m.add("shlight_max_clients", "gauge", "Clients the server holds at most (open files "
          "limit included).", server.max_clients)
    m.add("shlight_client_messages_dropped_total", "counter",
          "Client messages dropped past their budget.", c.frames_dropped)
    m.add("shlight_client_policy_closes_total", "counter",
          "Clients closed (1008) for sending far past their budget.", c.policy_closes)
    m.add("shlight_client_throttled_reads_total", "counter",
          "Times a client's socket was left unread for sending too many bytes.",
          c.throttled_reads)
    m.add("shlight_silent_connections", "gauge",
          "Accepted connections that have sent no request yet.", len(server.silent))
    m.add("shlight_silent_connections_cut_total", "counter",
          "Connections cut before their request, by reason.",
          [({"reason": r}, n) for r, n in sorted(server.silent.cut.items())]
          or [({"reason": "head_timeout"}, 0)])
    m.add("shlight_probe_running", "gauge", "1 while the probe's task runs.",
          [({"probe": p.name}, 1 if p.running else 0) for p in server.probes.values()])
    registrars = [p for p in server.probes.values() if p.registrar is not None]
    if registrars:                          # --marker
        m.add("shlight_registration_attempts_total", "counter",
              "Marker detections run.", [({"probe": p.name}, p.registrar.attempts)
                                          for p in registrars])
        m.add("shlight_registration_misses_total", "counter",
              "Marker detections that did not find the marker.",
              [({"probe": p.name}, p.registrar.misses) for p in registrars])
        m.add("shlight_registration_found", "gauge", "1 while the probe's pose is known.",
              [({"probe": p.name}, 1 if p.registrar.pose is not None else 0)
               for p in registrars])
    m.add("shlight_probe_loop_errors_total", "counter",
          "Unexpected errors the probe survived.",
          [({"probe": p.name}, p.loop_errors) for p in server.probes.values()])


def metrics(server) -> str:
    """The /metrics text (Prometheus exposition format)."""
    m, c = MetricsText(), server.counters
    m.add("shlight_info", "gauge", "Provider version.", [({"version": __version__}, 1)])
    m.add("shlight_clients", "gauge", "Connected WebSocket clients.", len(server.clients))
    m.add("shlight_connections_total", "counter", "WebSocket connections accepted.",
          c.connections)
    m.add("shlight_rejected_connections_total", "counter",
          "Handshakes refused, by reason.",
          [({"reason": r}, n) for r, n in sorted(c.rejected.items())] or [({"reason": "token"}, 0)])
    m.add("shlight_messages_sent_total", "counter", "Messages sent to clients.",
          c.messages_sent)
    m.add("shlight_messages_skipped_total", "counter",
          "Messages replaced by a newer one before a slow client took them.",
          c.messages_skipped)
    m.add("shlight_client_errors_total", "counter",
          "Malformed client messages answered with an error.", c.client_errors)
    m.add("shlight_stalled_clients_total", "counter",
          "Clients disconnected for not reading.", c.stalled_clients)
    probes = list(server.probes.values())

    def per(fn):
        return [({"probe": p.name}, fn(p)) for p in probes]
    m.add("shlight_probe_up", "gauge", "1 while the probe's source delivers frames.",
          per(lambda p: 1 if p.state == "live" else 0))
    m.add("shlight_probe_stale", "gauge", "1 while clients get stale lighting.",
          per(lambda p: 1 if p.state == "stale" else 0))
    m.add("shlight_probe_frames_total", "counter", "Frames projected.",
          per(lambda p: p.frames_processed))
    m.add("shlight_probe_frames_rejected_total", "counter", "Frames the engine refused.",
          per(lambda p: p.frames_rejected))
    m.add("shlight_probe_frames_adjusted_total", "counter",
          "Relayed messages corrected to fit the contract (an upstream clock that cannot "
          "be right, more lights than the shaders take).",
          per(lambda p: getattr(p, "frames_adjusted", 0)))
    m.add("shlight_probe_frames_too_large_total", "counter",
          "Frames refused for having more pixels than --max-frame-pixels (not decoded).",
          per(lambda p: getattr(p, "frames_too_large", 0)))
    m.add("shlight_probe_messages_total", "counter", "Messages published.",
          per(lambda p: p.seq))
    m.add("shlight_probe_source_fps", "gauge", "Frames per second from the source.",
          per(lambda p: p.capture.fps))
    m.add("shlight_probe_compute_seconds", "gauge", "Engine time of the last frame.",
          per(lambda p: p.compute_ms / 1e3))
    m.add("shlight_probe_latency_seconds", "gauge",
          "Frame capture to message, last frame.", per(lambda p: p.latency_s))
    m.add("shlight_probe_source_reconnects_total", "counter", "Source reconnections.",
          per(lambda p: p.capture.reconnects))
    m.add("shlight_probe_subscribers", "gauge", "Clients subscribed to the probe.",
          per(lambda p: len(server._subscribers[p.name])))
    limits_metrics(server, m)
    for publisher in server.publishers:
        publisher.add_metrics(m)
    server.environment.add_metrics(m)
    if server.passthrough is not None:
        server.passthrough.add_metrics(m)
    return m.text()
