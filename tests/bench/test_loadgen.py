"""The load generator of ``shlight bench --sections server`` against a real server: its
clients handshake, receive every probe message and measure latency (no timing asserted)."""
from __future__ import annotations

import pytest

from provider.bench.loadgen import LoadGenerator

from servertools import ServeProcess

pytestmark = pytest.mark.bench


def test_load_generator_clients_receive_and_measure():
    with ServeProcess("--source", "demo", "--change-threshold", "0") as proc:
        gen = LoadGenerator("127.0.0.1", proc.port, "/", procs=2)
        try:
            assert gen.connect(10) == [] and gen.clients == 10
            counts, lats, cpu = gen.measure(1.5)
            assert len(counts) == 10 and min(counts) > 0
            assert len(lats) == sum(counts) and min(lats) > 0
            assert cpu >= 0
            assert gen.connect(12) == [] and gen.clients == 12
        finally:
            gen.close()
        assert proc.proc.poll() is None and "Traceback" not in proc.output
