"""Running ``shlight serve`` until it is told to stop: start, the "serving" line, SIGINT and
SIGTERM, a clean shutdown (clients get close code 1001)."""
from __future__ import annotations

import asyncio
import logging
import signal
import socket

from .service import ProviderServer

log = logging.getLogger("shlight.server")

#: Tokens shipped in examples (examples/edge/shlight-edge.env): never a secret.
PLACEHOLDER_TOKENS = ("change-me",)


def _lan_address() -> str | None:
    """This machine's address on the default route (no packet is sent)."""
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("192.0.2.1", 9))
            return s.getsockname()[0]
    except OSError:
        return None


async def serve_until_stopped(server: ProviderServer, stop: asyncio.Event | None = None) -> None:
    """Start ``server``, run until ``stop`` is set or SIGINT/SIGTERM, then shut down."""
    stop = stop or asyncio.Event()
    loop = asyncio.get_running_loop()
    installed = []
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, stop.set)
            installed.append(sig)
        except (NotImplementedError, RuntimeError, ValueError):  # Windows, or not main thread
            pass
    try:
        await server.start()
        s = server.settings
        host = s.host if s.host not in ("0.0.0.0", "::", "") else (_lan_address() or s.host)
        if ":" in host:
            host = f"[{host}]"
        tls = "s" if s.tls is not None else ""
        log.info("serving ws%s://%s:%d/ (dashboard: http%s://%s:%d/%s); probes: %s", tls, host,
                 server.port, tls, host, server.port, "?token=..." if s.token else "",
                 ", ".join(f"{p.name} <- {p.spec.description}" for p in server.probes.values()))
        if s.host not in ("127.0.0.1", "localhost", "::1") and not s.token:
            log.warning("listening on %s without --token: anyone on the network can connect",
                        s.host)
        elif s.token in PLACEHOLDER_TOKENS:
            log.warning("the token is the example's placeholder %r: anyone who has read the "
                        "example can connect; set your own (python3 -c \"import secrets; "
                        "print(secrets.token_urlsafe(24))\")", s.token)
        await stop.wait()
        log.info("shutting down")
    finally:
        for sig in installed:
            loop.remove_signal_handler(sig)
        await server.stop()
    log.info("stopped")
