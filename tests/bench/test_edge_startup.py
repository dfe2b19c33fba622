"""Start-up in instructions (provider.bench.edge_startup) and the edge page's table of
boards (provider.bench.edge_boards): a second start reading the table cache costs under a
tenth of a first start's instructions (issue 44's done-when), counted by callgrind, which
does not depend on the machine's load."""
import shutil

import pytest

from provider.bench import edge, edge_startup
from provider.bench.edge_boards import BOARDS, board_lines


@pytest.mark.bench    # minutes under callgrind: .ci/run's bench step, not the unit suite
@pytest.mark.skipif(shutil.which("valgrind") is None,
                    reason="valgrind is not installed (apt-get install valgrind)")
def test_a_cached_start_costs_under_a_tenth_of_a_first_start():
    """The Theta S SH9 + lights and 32² cube projectors built in a first start (tables
    written to an empty cache) and in a second (tables read): whole processes, imports
    included, under callgrind (minutes: the first start is ~20 G instructions)."""
    counts = edge_startup.startup_instructions()
    assert counts["baseline"] < counts["second"] < counts["first"] / 10
    # the build itself, less the imports every start pays, shrinks further still
    assert counts["second"] - counts["baseline"] < (counts["first"] - counts["baseline"]) / 10


def test_without_valgrind_startup_and_boards_say_so(monkeypatch, capsys):
    monkeypatch.setattr(edge.shutil, "which", lambda name: None)
    assert edge.main(["--startup"]) == 1
    assert edge.main(["--boards"]) == 1
    assert capsys.readouterr().out.count("valgrind is not installed") == 2


def test_the_boards_table_is_clock_over_instructions():
    """fps = clock / instructions a frame, start-up seconds = clock / instructions, at one
    instruction a cycle; the 32-bit-only Pi Zero is not estimated (no NEON, no 64-bit
    wheels); the cube's column sums SH9 + lights and the cube update."""
    lines = board_lines({"theta": 25e6, "cube": 25e6, "pi": 5e6},
                        {"baseline": 1e9, "first": 20e9, "second": 2e9}, 200.0)
    rows = {line.split(" |")[0].lstrip("| "): [c.strip() for c in line.split("|")[1:-1]]
            for line in lines if line.startswith("| Pi")}
    assert len(rows) == len(BOARDS)
    zero2 = rows["Pi Zero 2 W (64-bit)"]
    assert zero2[3:] == ["~40", "~20", "~200", "20 / 2.0"]
    assert rows["Pi 5 (64-bit)"][3:6] == ["~96", "~48", "~480"]
    assert rows["Pi Zero (W) (32-bit only)"][3] == "not estimated"
    assert any("x86-64" in line and "25.0 M" in line for line in lines)
    assert any("200 MB" in line for line in lines)
