"""Wire messages in other engines' layouts: ``/latest.json?to=FORMAT``, ``subscribe`` ``to``
and ``shlight export``.

:func:`export_message` turns one ``sh9`` message (docs/contract.md §3, with §10's light fields when
the engine produced them) into an ``export`` message: a short envelope (``type``,
``version``, ``probe``, ``seq``, ``time``, ``stale``, ``age_s``) plus what
:func:`provider.core.conventions.formats.export` returns for the format (its payload and its
self-description). :class:`ExportCache` converts a probe's message once per format, however
many clients asked for it.

Exports that carry the reflection cube (gltf ``specularImages``, arcore
``environmentalHdrCubeMap``; :data:`~provider.core.conventions.formats.CUBE_FORMATS`) take it from the
probe's live cube (``shlight serve --environment``), already encoded by the cube's worker
thread (:meth:`provider.live.reflections.cube.EnvironmentWorker.want`): the export then names the
cube's ``environment_seq``; without one, ``cube_note`` says why there is none.
"""
from __future__ import annotations

import logging

from ...core.conventions.formats import (CUBE_FORMATS, FORMATS, export, light_radii_from_fields,
                                          lights_from_fields)
from ...core.errors import InputError
from .message import SCHEMA_VERSION, dumps

log = logging.getLogger("shlight.server")

#: The name of the provider's own layout: ``to=sh9`` is the same as no ``to``.
NATIVE = "sh9"

_ENVELOPE = ("probe", "seq", "time", "stale", "age_s")
#: Where a cube format's cube is: ``shlight serve --environment``.
_CUBE_FIELD = {"gltf": "specularImages", "arcore": "environmentalHdrCubeMap"}
#: How long a ``/latest.json?to=gltf|arcore`` waits for the live cube in that format when the
#: latest cube lacks it (the first request: the re-prefilter's operator is built once); well
#: under the opening handshake's timeout (websockets: 10 s), which HTTP requests share.
EXPORT_WAIT_S = 5.0


def check_format(fmt) -> str | None:
    """``None`` for the native message (``None`` or ``"sh9"``), else the format name;
    InputError (listing the formats) for anything else."""
    if fmt is None or fmt == NATIVE:
        return None
    if isinstance(fmt, str) and fmt in FORMATS:
        return fmt
    shown = repr(fmt[:40]) if isinstance(fmt, str) else type(fmt).__name__
    raise InputError(f"unknown format {shown}; formats: {', '.join(FORMATS)} "
                     f"(or {NATIVE}: the provider's own message)")


def export_message(message: dict, fmt: str, **options) -> dict:
    """The ``export`` message of an ``sh9`` message in format ``fmt`` (one of FORMATS).

    The lights are the message's own docs/contract.md §10 fields (every ``sh9`` message carries
    them), with their angular radii where the format has a field for them. ``options``: ``babylon_handedness`` (gltf), ``condon_shortley`` (arcore,
    openxr-android), ``environment`` (the reflection cube's mips: gltf ``specularImages``,
    arcore ``environmentalHdrCubeMap``); see :func:`provider.core.conventions.formats.export`.
    """
    lights, ambient = lights_from_fields(message)
    radii = light_radii_from_fields(message, len(lights))
    out = {"type": "export", "version": SCHEMA_VERSION}
    out.update((k, message[k]) for k in _ENVELOPE if k in message)
    out.update(export(message["coefficients"], fmt, lights=lights, ambient=ambient,
                      light_angular_radius_deg=radii, **options))
    out["lights"] = len(lights)
    return out


class ExportCache:
    """Per (probe, format), the serialised export of the probe's latest message.

    Conversion happens once per probe message (its ``seq``) per format asked for, never
    per client.
    """

    def __init__(self):
        self._texts: dict[tuple[str, str], tuple[int, bytes | None]] = {}
        self._failing: set[tuple[str, str]] = set()     # logged once until it works again
        self.conversions = 0

    def text(self, message: dict | None, fmt: str, environment=None) -> bytes | None:
        """The export of ``message`` as UTF-8 JSON; None when there is nothing to send.
        ``environment``: the probe's :class:`~provider.live.reflections.cube.EnvironmentWorker`
        (None without ``--environment``), whose latest cube the cube formats carry."""
        if message is None:
            return None
        cube, note = cube_for(fmt, environment, message.get("probe", ""))
        key = (message.get("probe", ""), fmt)
        # converted again for a new message, or a new cube (its seq), or a new note
        seq = (message.get("seq"), cube and (cube[0], id(cube[1])), note)
        cached = self._texts.get(key)
        if cached is not None and cached[0] == seq:
            return cached[1]
        try:
            out = export_message(message, fmt, **({"environment": cube[1]} if cube else {}))
            if cube:
                out["environment_seq"] = cube[0]
            elif note:
                out["cube_note"] = note
            text = dumps(out).encode()
            self._failing.discard(key)
        except (InputError, ValueError) as exc:   # e.g. malformed light fields from a relay
            if key not in self._failing:
                log.error("probe %s: cannot convert its messages to %s (sent to nobody "
                          "until they convert): %s", key[0], fmt, exc)
                self._failing.add(key)
            text = None
        self.conversions += 1
        self._texts[key] = (seq, text)
        return text


def cube_for(fmt: str, environment, probe: str):
    """((cube seq, EncodedCube) or None, note) for an export of ``fmt`` from ``probe``, whose
    :class:`~provider.live.reflections.cube.EnvironmentWorker` is ``environment`` (or None): the
    note says why there is no cube (None: the format has no cube, or it has one)."""
    if fmt not in CUBE_FORMATS:
        return None, None
    field = _CUBE_FIELD[fmt]
    if environment is None:
        return None, (f"no {field}: probe {probe} makes no reflection cube; start the "
                      f"server with --environment (shlight serve --environment) for the "
                      f"live cube in this export")
    environment.want(fmt)
    latest = environment.latest
    if latest is None:
        return None, (f"no {field} yet: probe {probe} has made no reflection cube yet "
                      f"(at most --environment-hz a second, when its lighting changes); "
                      f"ask again")
    encoded = latest.exports.get(fmt)
    if encoded is not None:
        return (latest.seq, encoded), None
    reason = latest.export_errors.get(fmt)
    if reason:
        return None, (f"no {field}: the {fmt} cube failed: {reason}"
                      + (" (shlight serve --environment-size sets the cube's size)"
                         if fmt == "arcore" else ""))
    return None, (f"no {field} yet: the {fmt} cube of reflection cube {latest.seq} is being "
                  f"encoded (from now on with every cube); ask again")
