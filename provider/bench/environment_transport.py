"""What the reflection cube costs on the wire (``shlight bench --sections environment``,
issue 19 item 7): bytes per update and bytes per second at many subscribers.

Measured on the real encoder (:func:`provider.live.reflections.cube.encode_environment`) and
the real WebSocket framing of the server (:mod:`provider.live.server.session`): one update is the
``environment`` JSON text frame plus the binary frame of the KTX2 bytes, the same for every
client (uncompressed RGBA16F: the size does not depend on the picture). MQTT carries the
KTX2 bytes alone, once per update to the broker (the fan-out is the broker's).
"""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from ..live.reflections.cube import SIZES, encode_environment
from ..live.server.session import binary_frame, text_frame


def _mip_count(size: int) -> int:
    """Mips of the core's chain: edges size, size/2, ... down to 2."""
    return int(math.log2(size))


def update_bytes(size: int) -> dict:
    """Bytes of one cube update of ``size``: ``ktx2`` (the file, GET /environment.ktx2,
    MQTT payload), ``message`` (the announcing JSON), ``websocket`` (both frames, headers
    included: what one client receives)."""
    count = _mip_count(size)
    result = SimpleNamespace(
        mips=[np.zeros((6, size >> k, size >> k, 3), np.float32) for k in range(count)],
        roughness=[k / max(count - 1, 1) for k in range(count)], stats={},
        units="input-linear")
    cube = encode_environment(result, probe="default", seq=123456, sh9_seq=1234567,
                              time_s=1.7e9, compute_ms=12.345)
    ws = len(text_frame(cube.text)) + len(binary_frame(cube.ktx2))
    return {"size": size, "mips": count, "ktx2": len(cube.ktx2), "message": len(cube.text),
            "websocket": ws}


def transport_bytes(sizes=(16, 32, 64), subscribers: int = 1000, hz: float = 1.0) -> list[dict]:
    """Per size: :func:`update_bytes` plus ``bytes_per_s`` (WebSocket, ``subscribers``
    clients that asked, one update every 1/``hz`` s: the most ``--environment-hz`` sends;
    fewer when the lighting is still) and ``mbit_per_s``."""
    rows = []
    for size in sizes:
        if size not in SIZES:
            raise ValueError(f"size {size}: one of {SIZES}")
        row = update_bytes(size)
        row["subscribers"], row["hz"] = subscribers, hz
        row["bytes_per_s"] = row["websocket"] * subscribers * hz
        row["mbit_per_s"] = row["bytes_per_s"] * 8 / 1e6
        rows.append(row)
    return rows


def markdown(rows: list[dict]) -> str:
    """The rows of :func:`transport_bytes` as a Markdown table."""
    lines = ["| size | mips | KTX2 bytes / update | WebSocket bytes / update | "
             "clients × Hz | WebSocket bytes/s | Mbit/s |",
             "|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r['size']}² | {r['mips']} | {r['ktx2']:,} | {r['websocket']:,} | "
                     f"{r['subscribers']:,} × {r['hz']:g} | {r['bytes_per_s']:,.0f} | "
                     f"{r['mbit_per_s']:,.1f} |")
    return "\n".join(lines)
