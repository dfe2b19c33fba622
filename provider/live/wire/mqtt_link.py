"""An MQTT broker's address and a paho client configured for it (user, password, TLS): one
link for both directions of the service's MQTT, the lighting published
(:mod:`provider.live.mqtt`, ``serve --mqtt``) and a lux meter's readings subscribed to
(:mod:`provider.live.probe.luxmeter`, ``serve --lux mqtt[s]://...``).

``mqtt[s]://[USER[:PASS]@]HOST[:PORT][/TOPIC]``: ``mqtts`` is TLS (system trust, or a CA
file), default ports 1883 / 8883; USER and PASS are percent-decoded (``p%40ss`` is
``p@ss``); the password is never shown (:attr:`MqttTarget.url`).
"""
from __future__ import annotations

import re
import uuid
from dataclasses import dataclass
from urllib.parse import unquote, urlsplit

from ...core.errors import InputError

DEFAULT_PREFIX = "shlight"


@dataclass(frozen=True)
class MqttTarget:
    """A broker and a topic (the publisher's prefix, or the topic a meter publishes on):
    parsed from an ``mqtt://`` or ``mqtts://`` URL."""

    tls: bool
    host: str
    port: int
    prefix: str
    username: str | None = None
    password: str | None = None

    @property
    def url(self) -> str:
        """The URL without the password (for logs, /healthz and the dashboard)."""
        user = f"{self.username}@" if self.username else ""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"mqtt{'s' if self.tls else ''}://{user}{host}:{self.port}/{self.prefix}"

    def topic(self, probe: str) -> str:
        return f"{self.prefix}/{probe}"


def parse_mqtt_url(text: str, option: str = "--mqtt",
                   default_topic: str | None = DEFAULT_PREFIX) -> MqttTarget:
    """``mqtt[s]://[USER[:PASS]@]HOST[:PORT][/TOPIC]`` → :class:`MqttTarget`
    (:class:`InputError` with one line on anything else, naming ``option``). Without a
    topic: ``default_topic``, or an error when it is None."""
    if not str(text).strip():   # a script's unset variable: never a silent "no broker"
        raise InputError(f"{option} is empty: expected mqtt[s]://[USER:PASS@]HOST[:PORT]/"
                         f"{'PREFIX' if default_topic else 'TOPIC'}, or leave {option} out")
    try:
        parts = urlsplit(text.strip())
        port = parts.port
    except ValueError as exc:
        raise InputError(f"{option} {text}: {exc}") from None
    if parts.scheme not in ("mqtt", "mqtts"):
        raise InputError(f"{option} {text}: expected mqtt://HOST:PORT/"
                         f"{'PREFIX' if default_topic else 'TOPIC'} or mqtts://...")
    if not parts.hostname:
        raise InputError(f"{option} {text}: no broker host")
    if parts.query or parts.fragment or "#" in text or "?" in text:   # "t/#": an empty fragment
        raise InputError(f"{option} {text}: no ?query or #fragment expected")
    prefix = unquote(parts.path).strip("/") or default_topic
    if not prefix:
        raise InputError(f"{option} {text}: no topic (mqtt[s]://[USER:PASS@]HOST[:PORT]/TOPIC)")
    if re.search(r"[+#\x00]", prefix) or "//" in prefix:
        raise InputError(f"{option} {text}: the topic {prefix!r} may not contain '+', "
                         "'#' or empty levels")
    if port == 0:   # urlsplit reads ":0" as 0, which paho would take for its default 1883
        raise InputError(f"{option} {text}: port 0 is no broker's port (1-65535; leave it out "
                         "for 1883, mqtts 8883)")
    tls = parts.scheme == "mqtts"
    return MqttTarget(tls=tls, host=parts.hostname,
                      port=port if port is not None else (8883 if tls else 1883),
                      prefix=prefix,
                      username=unquote(parts.username) if parts.username else None,
                      password=unquote(parts.password) if parts.password is not None else None)


def paho_client(target: MqttTarget, ca_file: str | None = None, ca_option: str = "--mqtt-ca"):
    """A paho-mqtt client (MQTT 3.1.1, clean session, a fresh client id) with the target's
    user, password and TLS (system trust, or ``ca_file``); not connected. One InputError
    for a CA file that cannot be read, or one given for a plain ``mqtt://`` target."""
    import paho.mqtt.client as paho     # a dependency of shlight (pyproject.toml)
    client = paho.Client(paho.CallbackAPIVersion.VERSION2,
                         client_id=f"shlight-{uuid.uuid4().hex[:12]}",
                         protocol=paho.MQTTv311, clean_session=True)
    if target.username:
        client.username_pw_set(target.username, target.password)
    if target.tls:
        import ssl
        try:
            context = ssl.create_default_context(cafile=ca_file)
        except (OSError, ssl.SSLError, ValueError) as exc:
            raise InputError(f"{ca_option} {ca_file}: {getattr(exc, 'strerror', None) or exc}"
                             ) from None
        client.tls_set_context(context)
    elif ca_file:
        raise InputError(f"{ca_option} is for mqtts:// brokers")
    return client
