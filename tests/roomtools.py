"""The analytic room's positioned probes (provider/bench/room.py) as the probe-grid tests serve
them to engines (tests/clients/three/test_three_probe_grid.py, tests/clients/unity/test_unity_probe_grid.py): ``shlight
serve``'s arguments with a token and the room, and ``shlight interpolate``'s light at a point,
which an engine's light there is held against. The probes file itself is conftest.py's
``room_probes`` fixture."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from provider.bench import room

TOKEN = "s3cret"


def serve_args(probes_file: Path) -> list[str]:
    """``shlight serve`` with every probe at its position, the token and the room's box."""
    args = ["--fps", "2", "--token", TOKEN, "--room", room.room_box()]
    for p in json.loads(probes_file.read_text())["probes"]:
        args += ["--probe", f"{p['name']}={probes_file.parent / p['image']}",
                 "--probe-position", f"{p['name']}={','.join(map(str, p['position']))}"]
    return args


def interpolate(probes_file: Path, at, *extra: str) -> dict:
    """``shlight interpolate``'s point at ``at`` (wire frame) in the room."""
    r = subprocess.run([sys.executable, "-m", "provider.cli", "interpolate", str(probes_file),
                        "--at", ",".join(map(str, at)), "--room", room.room_box(), *extra],
                       capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout)["points"][0]
