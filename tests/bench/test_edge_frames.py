"""The edge bench's Theta S frame (provider.bench.edge_frames): a lit room whose lights the
extractor finds, so the bench's "SH9 + lights" counts the work of lights found."""
import numpy as np

from provider.bench import edge
from provider.bench.edge_frames import lit_theta_frame


def test_the_bench_theta_frame_yields_lights_from_the_ceiling():
    """The workload the bench counts: its frame is the lit room, 8-bit, and SH9 + lights
    takes the ceiling panels as lights (the old pattern's two dots yielded none)."""
    what, build, frame = edge.edge_workloads()["theta"]
    assert frame is lit_theta_frame(1280, 720)
    assert frame.shape == (720, 1280, 3) and frame.dtype == np.uint8
    projector = build()
    projector.project(frame)                      # the first frame sets up the tracker
    result = projector.project(frame)
    assert result.stats["light_candidates"] >= 1
    assert len(result.lights) >= 1
    # the panels are overhead: every light points up (+Y), well above the horizon
    assert all(light.direction[1] > 0.5 for light in result.lights)


def test_the_cube_workload_reads_the_same_frame():
    """The cube update is counted on the same frame as SH9 + lights (serve --environment
    decodes one frame for both)."""
    workloads = edge.edge_workloads()
    assert workloads["cube"][2] is workloads["theta"][2]
