"""The headsets' route, ``/capture`` (``serve --passthrough``, docs/passthrough.md): the
handshake's checks (:func:`check_capture`, after the token, Origin and Host checks every route
passes) and the connection (:func:`serve_capture`). A headset's views go to its fit in the
probe layer (:mod:`provider.live.probe.passthrough`); its answers come back through the
client's outbox, with the send timeout and bounds of every client."""
from __future__ import annotations

import asyncio
import logging
import time
from urllib.parse import parse_qs, urlsplit

from websockets.asyncio.server import ServerConnection
from websockets.exceptions import ConnectionClosed

from ... import __version__
from ..wire.message import FRAME, SCHEMA_VERSION
from .replies import _response
from .session import ClientSession

log = logging.getLogger("shlight.server")

#: The headsets' route, its frames a second per connection, and how many times
#: --passthrough-max-jpeg-bytes a message may be before it closes the connection.
CAPTURE_PATH = "/capture"
CAPTURE_FRAME_RATE = 120.0
CAPTURE_SIZE_SLACK = 4


def check_capture(server, connection, query):
    """``/capture`` (docs/passthrough.md): refused without --passthrough, for an unknown
    probe, past --max-clients or past the headsets' cap; else the connection gets the
    route's budget (JPEGs: larger and more frequent messages than a subscribe)."""
    service = server.passthrough
    if service is None:
        server.counters.rejected["no_capture"] += 1
        return _response(404, b"no /capture on this server: start shlight serve with "
                         b"--passthrough\n", "text/plain; charset=utf-8")
    name = query.get("probe", [next(iter(server.probes))])[0]
    if name not in server.probes:
        server.counters.rejected["unknown_probe"] += 1
        return _response(404, f"no probe {name!r}; probes: {', '.join(server.probes)}\n"
                         .encode(), "text/plain; charset=utf-8")
    if len(server.clients) >= server.max_clients or service.full():
        server.counters.rejected["too_many_clients"] += 1
        return _response(503, b"too many headsets on /capture (or clients)\n",
                         "text/plain; charset=utf-8")
    cap = service.settings.max_jpeg_bytes
    # Two frames a view at up to 60 views a second; a JPEG up to CAPTURE_SIZE_SLACK × the
    # cap is read whole and answered with an error (larger: closed with 1009).
    connection.rebudget(byte_rate=4.0 * cap, byte_burst=2.0 * cap + 64,
                        frame_rate=CAPTURE_FRAME_RATE, frame_burst=2 * CAPTURE_FRAME_RATE,
                        max_size=CAPTURE_SIZE_SLACK * cap)
    return None


async def serve_capture(server, ws: ServerConnection) -> None:
    """A headset on ``/capture``: its messages go to its fit in the probe layer
    (:class:`~provider.live.probe.passthrough.HeadsetFit`), whose answers go back
    through the client's outbox (send timeout, bounded replies)."""
    query = parse_qs(urlsplit(ws.request.path).query)
    probe = server.probes[query.get("probe", [next(iter(server.probes))])[0]]
    client = ClientSession(ws, server.counters, send_timeout=server.settings.send_timeout)
    server.clients.add(client)
    server.counters.connections += 1
    headset = server.passthrough.headset(probe, client.reply)
    log.info("headset %s joined /capture (probe %s)", client.label, probe.name)
    writer = asyncio.create_task(client.write_loop())
    s = server.passthrough.settings
    try:
        client.reply({"type": "hello", "version": SCHEMA_VERSION, "route": CAPTURE_PATH,
                      "provider": f"shlight {__version__}", "frame": FRAME,
                      "probe": probe.name, "max_jpeg_bytes": s.max_jpeg_bytes,
                      "max_message_bytes": server.settings.max_message_bytes,
                      "hz": s.hz, "max_views": s.max_views, "server_time": time.time()})
        async for message in ws:
            headset.on_message(message)
    except ConnectionClosed:
        pass
    finally:
        headset.close()
        writer.cancel()
        server.clients.discard(client)
        log.info("headset %s left /capture (%d views, %d dropped)", client.label,
                 headset.received, headset.dropped)
