"""The MQTT path of ``shlight bench --sections server``: frame → ``shlight serve --mqtt`` →
a local mosquitto → subscribers.

A real mosquitto (Debian's) on loopback, on the load generator's CPUs; ``shlight serve``
(demo source, every frame sent) pinned to its own CPU and publishing to it; paho
subscribers in this process. Reported per subscriber count: messages per second each,
frame-to-subscriber latency p50/p99 (receive time − the message's ``time``), the server's
CPU (what publishing costs it: one message per frame, whatever the number of subscribers)
and the broker's CPU (the fan-out is the broker's work).
"""
from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import tempfile
import threading
import time

from .common import stop

_TIME = re.compile(rb'"time":([0-9.eE+-]+)')


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _pct(values, q):
    if not values:
        return float("nan")
    values = sorted(values)
    return values[min(len(values) - 1, int(round(q / 100 * (len(values) - 1))))]


def measure_mqtt(start_server, cpu_seconds, fps: float, seconds: float, server_cpus,
                 client_cpus, progress, counts=(1, 100)) -> dict:
    """Rows for the MQTT path, or {"skipped": reason}."""
    mosquitto = shutil.which("mosquitto") or "/usr/sbin/mosquitto"
    if not os.path.exists(mosquitto):
        return {"skipped": "no mosquitto (apt-get install mosquitto)"}
    try:
        import paho.mqtt.client as paho
    except ImportError as exc:
        return {"skipped": f"paho-mqtt missing: {exc}"}
    folder = tempfile.mkdtemp(prefix="shlight-bench-mqtt-")
    port = _free_port()
    conf = os.path.join(folder, "mosquitto.conf")
    with open(conf, "w") as f:
        f.write(f"listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n"
                + ("user root\n" if os.geteuid() == 0 else ""))
    preexec = (lambda: os.sched_setaffinity(0, client_cpus)) if client_cpus else None
    broker = subprocess.Popen([mosquitto, "-c", conf], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL, preexec_fn=preexec)
    subscribers, rows = [], []
    server = None
    try:
        deadline = time.monotonic() + 10
        while True:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=1).close()
                break
            except OSError:
                if time.monotonic() > deadline or broker.poll() is not None:
                    return {"skipped": "mosquitto did not start"}
                time.sleep(0.05)
        server, _ = start_server(fps, server_cpus,
                                 ["--mqtt", f"mqtt://127.0.0.1:{port}/bench"])
        state = {"record": False}
        lock = threading.Lock()

        def subscriber():
            got = {"count": 0, "lat": []}

            def on_message(client, userdata, msg):
                now = time.time()
                if state["record"] and not msg.retain:
                    m = _TIME.search(msg.payload)
                    if m:
                        with lock:
                            got["lat"].append(now - float(m.group(1)))
                            got["count"] += 1
            c = paho.Client(paho.CallbackAPIVersion.VERSION2)
            c.on_message = on_message
            c.on_connect = lambda client, u, f, rc, p: client.subscribe("bench/default")
            c.connect("127.0.0.1", port, keepalive=60)
            c.loop_start()
            return c, got

        time.sleep(1.0)
        for n in counts:
            while len(subscribers) < n:
                subscribers.append(subscriber())
            time.sleep(1.5)
            for _, got in subscribers:
                got["count"], got["lat"] = 0, []
            cpu0, b0, t0 = cpu_seconds(server.pid), cpu_seconds(broker.pid), time.monotonic()
            state["record"] = True
            time.sleep(seconds)
            state["record"] = False
            cpu1, b1, t1 = cpu_seconds(server.pid), cpu_seconds(broker.pid), time.monotonic()
            wall = t1 - t0
            with lock:
                lats = [x for _, got in subscribers for x in got["lat"]]
                rates = [got["count"] / wall for _, got in subscribers]
            row = {"subscribers": n, "rate_median": round(_pct(rates, 50), 2),
                   "latency_p50_ms": round(_pct(lats, 50) * 1e3, 2),
                   "latency_p99_ms": round(_pct(lats, 99) * 1e3, 2),
                   "server_cpu": round((cpu1 - cpu0) / wall, 3),
                   "broker_cpu": round((b1 - b0) / wall, 3)}
            rows.append(row)
            progress(f"  MQTT, {n:4d} subscriber(s): {row['rate_median']:.1f} msg/s each, "
                     f"latency p50 {row['latency_p50_ms']:.1f} ms p99 "
                     f"{row['latency_p99_ms']:.1f} ms, server CPU "
                     f"{row['server_cpu'] * 100:.0f} %, broker CPU {row['broker_cpu'] * 100:.0f} %")
    finally:
        for c, _ in subscribers:
            c.disconnect()
            c.loop_stop()
        if server is not None:
            stop(server)
        stop(broker, 10)
        shutil.rmtree(folder, ignore_errors=True)
    return {"rows": rows}
