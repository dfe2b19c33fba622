"""``shlight serve --tls-cert FILE --tls-key FILE``: wss:// and https:// with a throwaway
self-signed certificate, real clients that trust exactly that certificate, and one-line
errors for every bad certificate or key."""
from __future__ import annotations

import asyncio
import json
import os
import ssl
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from servertools import ServeProcess, connect, poll, recv_until, run_cli
from tlstools import make_certificate

HDRI = Path(__file__).resolve().parents[2] / "data" / "hdri"


def wss_lighting(url: str, trust: ssl.SSLContext) -> tuple[dict, dict]:
    """(hello, first fresh sh9 message) over wss://, with websockets' asyncio client: one
    thread does the reads and the writes. (The threaded client reads in a thread of its
    own while it writes its request, and OpenSSL forbids both at once on one connection:
    now and then the request was lost and the handshake timed out.)"""
    from websockets.asyncio.client import connect as aconnect

    async def main():
        async with aconnect(url, ssl=trust, open_timeout=10) as ws:
            hello = json.loads(await asyncio.wait_for(ws.recv(), 10))
            while True:
                msg = json.loads(await asyncio.wait_for(ws.recv(), 20))
                if msg.get("type") == "sh9" and not msg.get("stale"):
                    return hello, msg
    return asyncio.run(main())


@pytest.fixture(scope="module")
def certs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tls")
    return folder, make_certificate(folder), make_certificate(folder, "other")


def test_wss_and_https_with_a_self_signed_certificate(certs):
    _, (cert, key), (other_cert, _) = certs
    with ServeProcess("--source", "demo", "--tls-cert", str(cert), "--tls-key", str(key),
                      "--token", "s3cret") as proc:
        assert f"serving wss://127.0.0.1:{proc.port}/" in proc.output
        assert f"dashboard: https://127.0.0.1:{proc.port}/" in proc.output
        trust = ssl.create_default_context(cafile=str(cert))
        url = f"wss://127.0.0.1:{proc.port}/?token=s3cret"
        hello, msg = wss_lighting(url, trust)
        assert hello["type"] == "hello"
        assert len(msg["coefficients"]) == 27 and msg["stale"] is False
        # https: the same routes, same token rules
        with urllib.request.urlopen(f"https://127.0.0.1:{proc.port}/latest.json?token=s3cret",
                                    context=trust, timeout=10) as resp:
            latest = json.loads(resp.read())
        assert latest["type"] == "sh9" and latest["probe"] == "default"
        with urllib.request.urlopen(f"https://localhost:{proc.port}/healthz", context=trust,
                                    timeout=10) as resp:
            assert json.loads(resp.read())["status"] in ("ok", "degraded")
        with pytest.raises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(f"https://127.0.0.1:{proc.port}/metrics", context=trust,
                                   timeout=10)
        assert refused.value.code == 401
        # A client that trusts another certificate refuses this server.
        with pytest.raises(ssl.SSLCertVerificationError):
            connect(url, ssl=ssl.create_default_context(cafile=str(other_cert)),
                    open_timeout=10)
        # Plain ws:// to a TLS port gets no WebSocket.
        with pytest.raises(Exception) as plain:
            connect(f"ws://127.0.0.1:{proc.port}/?token=s3cret", open_timeout=10)
        assert not isinstance(plain.value, AssertionError)
        assert proc.proc.poll() is None and "Traceback" not in proc.output
    assert proc.proc.returncode == 0, proc.output


def test_a_relay_reads_a_wss_upstream(certs):
    """An edge device serving wss:// and a PC relaying it (``--probe pc=wss://...``, the
    upstream's certificate trusted through SSL_CERT_FILE): the PC re-serves the edge's
    coefficients exactly, and says why when it does not trust the certificate."""
    _, (cert, key), (other_cert, _) = certs
    bridge = str(HDRI / "bridge.exr")
    with ServeProcess("--probe", f"edge={bridge}", "--tls-cert", str(cert), "--tls-key",
                      str(key), "--token", "s3cret") as edge:
        upstream = f"wss://127.0.0.1:{edge.port}/?token=s3cret&probe=edge"
        _, want = wss_lighting(upstream, ssl.create_default_context(cafile=str(cert)))
        with ServeProcess("--probe", f"pc={upstream}", env={"SSL_CERT_FILE": str(cert)}) as pc:
            with connect(pc.url) as ws:
                got = recv_until(ws, lambda m: m.get("type") == "sh9" and not m["stale"],
                                 timeout=30)
            assert got["source"] == "relay" and got["coefficients"] == want["coefficients"]
        with ServeProcess("--probe", f"pc={upstream}", "--source-timeout", "2",
                          env={"SSL_CERT_FILE": str(other_cert)}) as untrusted:
            poll(lambda: "CERTIFICATE_VERIFY_FAILED" in untrusted.output, timeout=30,
                 what="the relay to say it does not trust the upstream")
            assert "s3cret" not in untrusted.output and "Traceback" not in untrusted.output
    assert edge.proc.returncode == 0, edge.output


def test_serve_help_lists_tls():
    res = run_cli("serve", "--help")
    assert res.returncode == 0 and "--tls-cert" in res.stdout and "--tls-key" in res.stdout


def _bad_cases(folder: Path, cert: Path, key: Path, other_key: Path):
    not_pem = folder / "not.pem"
    not_pem.write_text("hello\n")
    garbage = folder / "garbage.pem"
    garbage.write_text("-----BEGIN CERTIFICATE-----\nAAAA\n-----END CERTIFICATE-----\n")
    return [
        (["--tls-cert", str(folder / "missing.crt"), "--tls-key", str(key)], "no such file"),
        (["--tls-cert", str(cert), "--tls-key", str(folder / "missing.key")], "no such file"),
        (["--tls-cert", str(folder), "--tls-key", str(key)], "not a file"),
        (["--tls-cert", str(not_pem), "--tls-key", str(key)], "not a PEM file"),
        (["--tls-cert", str(garbage), "--tls-key", str(key)], "no valid certificate"),
        (["--tls-cert", str(cert), "--tls-key", str(cert)], "no valid private key"),
        (["--tls-cert", str(cert), "--tls-key", str(other_key)], "does not match"),
        (["--tls-key", str(key)], "--tls-key needs --tls-cert"),
        (["--tls-cert", str(cert)], "holds no private key"),
    ]


def test_tls_errors_are_one_line(certs):
    folder, (cert, key), (_, other_key) = certs
    for argv, words in _bad_cases(folder, cert, key, other_key):
        res = run_cli("serve", *argv)
        assert res.returncode == 2, (argv, res.stderr)
        assert "Traceback" not in res.stderr
        last = res.stderr.strip().splitlines()[-1]
        assert last.startswith("shlight serve: error:") and words in last, (argv, res.stderr)


@pytest.mark.skipif(os.geteuid() == 0, reason="root reads any file")
def test_unreadable_key_is_one_line(certs):
    folder, (cert, key), _ = certs
    locked = folder / "locked.key"
    locked.write_bytes(key.read_bytes())
    locked.chmod(0)
    res = run_cli("serve", "--tls-cert", str(cert), "--tls-key", str(locked))
    assert res.returncode == 2 and "cannot read" in res.stderr.strip().splitlines()[-1]
