"""TLS for ``shlight serve --tls-cert FILE --tls-key FILE``: wss:// and https://.

One :class:`ssl.SSLContext` for the server, built from a PEM certificate (chain) and its
private key, with every way that can go wrong turned into one clear
:class:`~provider.core.errors.InputError` line (missing, unreadable, not PEM, key and
certificate that do not belong together).
"""
from __future__ import annotations

import os
import ssl

from ...core.errors import InputError


def _check_file(flag: str, path: str) -> None:
    if not os.path.exists(path):
        raise InputError(f"{flag} {path}: no such file")
    if not os.path.isfile(path):
        raise InputError(f"{flag} {path}: not a file")
    try:
        with open(path, "rb") as f:
            head = f.read(1 << 16)
    except OSError as exc:
        raise InputError(f"{flag} {path}: cannot read ({exc.strerror or exc})") from None
    if b"-----BEGIN " not in head:
        raise InputError(f"{flag} {path}: not a PEM file (expected '-----BEGIN ...')")


def server_context(cert: str | None, key: str | None) -> ssl.SSLContext | None:
    """The server's TLS context, or None when neither file is given.

    ``key`` may be left out when ``cert`` holds the private key as well (one PEM with
    both). Raises :class:`InputError` with a one-line reason.
    """
    if not cert and not key:
        return None
    if not cert:
        raise InputError("--tls-key needs --tls-cert (the certificate, PEM)")
    _check_file("--tls-cert", cert)
    if key:
        _check_file("--tls-key", key)
    try:    # the certificate alone first, so that an error names the right file
        ssl.create_default_context(cafile=cert)
    except (ssl.SSLError, ValueError) as exc:
        raise InputError(f"--tls-cert {cert}: no valid certificate in it "
                         f"({getattr(exc, 'reason', None) or exc})") from None
    ctx = ssl.SSLContext(ssl.PROTOCOL_TLS_SERVER)
    ctx.minimum_version = ssl.TLSVersion.TLSv1_2

    def encrypted(*_):
        raise InputError(f"--tls-key {key or cert}: the private key is encrypted; give an "
                         "unencrypted one (openssl pkey -in KEY -out PLAIN.pem)")
    try:
        ctx.load_cert_chain(cert, key or None, password=encrypted)
    except ssl.SSLError as exc:
        reason = (exc.reason or str(exc)).upper()
        if "KEY_VALUES_MISMATCH" in reason or "X509_CHECK_PRIVATE_KEY" in reason:
            raise InputError(f"--tls-key {key or cert} does not match the certificate "
                             f"in --tls-cert {cert}") from None
        if not key:
            raise InputError(f"--tls-cert {cert} holds no private key: give --tls-key FILE"
                             ) from None
        raise InputError(f"--tls-key {key}: no valid private key in it "
                         f"({exc.reason or exc})") from None
    except OSError as exc:
        raise InputError(f"--tls-cert {cert} / --tls-key {key}: "
                         f"{exc.strerror or exc}") from None
    return ctx
