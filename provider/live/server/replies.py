"""HTTP replies of the server (provider/live/server/service.py): every response carries its length,
no caching, no sniffing and ``Connection: close``; errors are the wire's ``error`` JSON."""
from __future__ import annotations

import http

from websockets.datastructures import Headers
from websockets.http11 import Response

from ..wire.message import dumps


def _response(status: int, body: bytes, content_type: str, headers=()) -> Response:
    h = Headers()
    h["Content-Type"] = content_type
    h["Content-Length"] = str(len(body))
    h["Cache-Control"] = "no-store"
    h["X-Content-Type-Options"] = "nosniff"
    h["Connection"] = "close"
    for k, v in headers:
        h[k] = v
    return Response(status, http.HTTPStatus(status).phrase, h, body)


def _json_error(status: int, code: str, detail: str) -> Response:
    body = dumps({"type": "error", "error": code, "detail": detail}).encode()
    return _response(status, body, "application/json")
