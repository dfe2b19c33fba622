"""``shlight bench --sections server``, second part: many clients, a flooding client, a
rate cap (issue 22).

For each client count (1,000 and 2,000; 200 with ``--quick``) a fresh ``shlight serve``
(demo source at 30 fps, every frame sent) is measured three ways, a few seconds each:

* ``plain``: every client takes every message;
* ``flood``: the same, plus one more client that sends ``{"type":"ping"}`` without pause
  and, each time the server closes it (code 1008), connects again at once and goes on; it
  connects from 127.0.0.2 (Linux), an address ``--connect-rate`` limits as it limits a LAN
  client (429 beyond it: the flooder tries again at once);
* ``flood, no --connect-rate``: the same flooder against ``--connect-rate 0``;
* ``max_hz 30``: every client subscribes with ``?max_hz=30``, the source's own rate.

Reported per row: messages per second per client (median, p5), frame-to-client latency
p50/p99 (receive time − the frame's capture time), the server's CPU (fraction of one core,
all its threads) and resident memory (MiB) at the end, and for ``flood`` how many times
the flooder was closed and how many pongs it got. The server and the clients share the
machine: see the load average reported with the figures.
"""
from __future__ import annotations

import threading
import time
from typing import NamedTuple

from .common import cpu_seconds, stop


class FaultMode(NamedTuple):
    """One row kind: its name in the table, the clients' path, whether the flooder runs,
    and what the server is started with."""

    name: str
    path: str = "/"
    flood: bool = False
    server_args: tuple = ()


#: The rows measured at each client count, in order (the module docstring says what each is).
MODES = (FaultMode("plain"), FaultMode("flood", flood=True),
         FaultMode("flood, no --connect-rate", flood=True, server_args=("--connect-rate", "0")),
         FaultMode("max_hz 30", path="/?max_hz=30"))


def rss_mib(pid: int) -> float:
    """Resident memory of a process, MiB (Linux /proc; NaN elsewhere)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    return float("nan")


#: The flooder's address: loopback, but not one that ``--connect-rate`` exempts.
FLOOD_SOURCE = "127.0.0.2"


class Flooder:
    """A client that sends JSON pings without pause, reconnecting at once whenever it is
    closed or refused, from ``source`` (an address of this machine; None: the default)."""

    def __init__(self, url: str, source: str | None = FLOOD_SOURCE):
        self.url, self.source = url, source
        self.sent = self.pongs = self.closes = self.refusals = 0
        self.close_codes: dict = {}         # WebSocket close code -> times closed with it
        self.refusal_statuses: dict = {}    # HTTP status -> handshakes refused with it
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True, name="flooder")

    def _socket(self):
        """A TCP connection to the server from ``source`` where this machine has it."""
        import socket
        from urllib.parse import urlsplit
        parts = urlsplit(self.url)
        try:
            return socket.create_connection((parts.hostname, parts.port), timeout=10,
                                            source_address=(self.source, 0) if self.source
                                            else None)
        except OSError:
            if not self.source:
                raise
            self.source = None                  # not Linux: 127.0.0.2 is not this machine's
            return self._socket()

    def _run(self) -> None:
        from websockets.exceptions import ConnectionClosed, InvalidStatus
        from websockets.sync.client import connect
        while not self._stop.is_set():
            try:
                with connect(self.url, sock=self._socket(), open_timeout=10, close_timeout=1,
                             max_queue=None) as ws:
                    try:
                        while not self._stop.is_set():
                            ws.send('{"type":"ping","id":1}')
                            self.sent += 1
                            if self.sent % 256 == 0:
                                self._drain(ws)
                    except ConnectionClosed:
                        self.closes += 1
                        code = ws.protocol.close_rcvd.code if ws.protocol.close_rcvd else 1006
                        self.close_codes[code] = self.close_codes.get(code, 0) + 1
            except InvalidStatus as exc:     # 429 past --connect-rate: again, at once
                self.refusals += 1
                status = exc.response.status_code
                self.refusal_statuses[status] = self.refusal_statuses.get(status, 0) + 1
            except Exception:  # noqa: BLE001 - reset: try again shortly
                self._stop.wait(0.05)

    def _drain(self, ws) -> None:
        while True:
            try:
                text = ws.recv(timeout=0)
            except TimeoutError:
                return
            self.pongs += '"pong"' in text

    def __enter__(self) -> "Flooder":
        self.thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self.thread.join(10)


def held_messages(port: int) -> float:
    """The server's shlight_messages_held_total (messages that waited under max_hz)."""
    import urllib.request
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/metrics", timeout=10) as resp:
            for line in resp.read().decode().splitlines():
                if line.startswith("shlight_messages_held_total "):
                    return float(line.split()[1])
    except OSError:
        pass
    return float("nan")


def _row(gen, pid: int, port: int, seconds: float, fps: float, pct) -> dict:
    time.sleep(1.0 + gen.clients / 1000)      # settle: the handshakes' backlog is served
    held0 = held_messages(port)
    cpu0, t0 = cpu_seconds(pid), time.monotonic()
    counts, lats, gen_cpu = gen.measure(seconds)
    cpu1, t1 = cpu_seconds(pid), time.monotonic()
    held = held_messages(port) - held0
    rates = sorted(max(c, 0) / seconds for c in counts)
    return {"rate_median": round(pct(rates, 50), 2), "rate_p5": round(pct(rates, 5), 2),
            "latency_p50_ms": round(pct(lats, 50) * 1e3, 2),
            "latency_p99_ms": round(pct(lats, 99) * 1e3, 2),
            "server_cpu": round((cpu1 - cpu0) / max(t1 - t0 - 0.2, 1e-3), 3),
            "server_rss_mib": round(rss_mib(pid), 1), "loadgen_cpu": round(gen_cpu / seconds, 3),
            "dropped": sum(1 for c in counts if c < 0),
            "held_fraction": round(held / max(sum(max(c, 0) for c in counts), 1), 4)}


def measure_faults(start_server, pct, fps: float, counts, seconds: float, server_cpus,
                   client_cpus, progress=print) -> list[dict]:
    """The rows described in the module docstring (``start_server`` and ``pct``:
    provider.bench.server's)."""
    from .loadgen import LoadGenerator
    rows = []
    for n in counts:
        for mode in MODES:
            proc, port = start_server(fps, server_cpus, mode.server_args)
            gen = None
            try:
                gen = LoadGenerator("127.0.0.1", port, mode.path,
                                    procs=max(2, len(client_cpus or ())), cpus=client_cpus)
                gen.connect(n)
                if gen.clients < n:
                    progress(f"  {mode.name}: only {gen.clients} of {n} clients connected")
                    continue
                if mode.flood:
                    with Flooder(f"ws://127.0.0.1:{port}/") as flood:
                        row = _row(gen, proc.pid, port, seconds, fps, pct)
                    row.update(flooder_sent=flood.sent, flooder_pongs=flood.pongs,
                               flooder_closes=flood.closes, flooder_refusals=flood.refusals,
                               flooder_source=flood.source or "127.0.0.1",
                               flooder_close_codes={str(k): v for k, v in
                                                    flood.close_codes.items()},
                               flooder_refusal_statuses={str(k): v for k, v in
                                                         flood.refusal_statuses.items()})
                else:
                    row = _row(gen, proc.pid, port, seconds, fps, pct)
            finally:
                if gen is not None:
                    gen.close()
                stop(proc)
            row.update(clients=n, mode=mode.name, flood=mode.flood, seconds=seconds)
            rows.append(row)
            extra = f"; flooder {flooder_summary(row)}" if mode.flood else ""
            progress(f"  {n:5d} clients, {mode.name}: {row['rate_median']:.1f} msg/s each "
                     f"(p5 {row['rate_p5']:.1f}), latency p50 {row['latency_p50_ms']:.1f} ms "
                     f"p99 {row['latency_p99_ms']:.1f} ms, server CPU "
                     f"{row['server_cpu'] * 100:.0f} %, RSS {row['server_rss_mib']:.0f} MiB, "
                     f"held {row['held_fraction'] * 100:.1f} %{extra}")
    return rows


def flooder_summary(row: dict) -> str:
    """What the flooder of a ``flood`` row met: closes by WebSocket close code, refusals by
    HTTP status, pongs for pings, and where it connected from when not 127.0.0.2."""
    def by(counts: dict) -> str:
        return f" ({', '.join(f'{k}: {v}' for k, v in counts.items())})" if counts else ""
    return (f"closed {row['flooder_closes']}×{by(row['flooder_close_codes'])}, refused "
            f"{row['flooder_refusals']}×{by(row['flooder_refusal_statuses'])}, "
            f"{row['flooder_pongs']} pongs / {row['flooder_sent']} pings"
            + ("; from 127.0.0.1, which --connect-rate does not limit (no 127.0.0.2 here)"
               if row["flooder_source"] == "127.0.0.1" else ""))


def markdown(rows: list[dict], fps: float, load: str) -> list[str]:
    """The section of server.md for these rows."""
    lines = ["", "## Many clients, a flooding client, a rate cap", "",
             f"A fresh `shlight serve` per row (demo source at {fps:g} fps, every frame sent); "
             "`flood`: one more client sends JSON pings without pause and reconnects at "
             "once each time it is closed or refused, from 127.0.0.2 (limited by "
             "`--connect-rate` like a LAN client); `flood, no --connect-rate`: the same "
             "against `--connect-rate 0`; `max_hz 30`: every client subscribes with "
             "`?max_hz=30`. "
             f"Load average at the end of the run: {load}.", "",
             "| clients | mode | msg/s per client (median) | p5 | latency p50 (ms) "
             "| latency p99 (ms) | server CPU (core) | server RSS (MiB) | held by max_hz "
             "| flooder |",
             "|---:|:---|---:|---:|---:|---:|---:|---:|---:|:---|"]
    for r in rows:
        flood = flooder_summary(r) if r["flood"] else ""
        lines.append(f"| {r['clients']} | {r['mode']} | {r['rate_median']:.1f} | "
                     f"{r['rate_p5']:.1f} | {r['latency_p50_ms']:.1f} | "
                     f"{r['latency_p99_ms']:.1f} | {r['server_cpu']:.2f} | "
                     f"{r['server_rss_mib']:.0f} | {r['held_fraction'] * 100:.1f} % | {flood} |")
    return lines
