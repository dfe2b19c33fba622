"""The test suite's own shape: test files named by concern, never by issue number, and no test
module importing another (shared set-up lives in tests/*tools.py helper modules and in
conftest.py fixtures), so a test file can be moved, run alone or run on any xdist worker."""
from __future__ import annotations

import ast
import re
from pathlib import Path

TESTS = Path(__file__).resolve().parent
#: An issue number at the end of a test file's name (test_colour_31.py) or the word itself.
ISSUE_NAME = re.compile(r"(_\d+|issue\w*)$")


def _test_files() -> list[Path]:
    return sorted(p for p in TESTS.rglob("test_*.py") if "node_modules" not in p.parts)


def imported_test_modules(source: str) -> list[str]:
    """The test modules (``test_*``) that ``source`` imports, anywhere in it."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            names = [node.module]
        else:
            continue
        out += [n for n in names if n.split(".")[-1].startswith("test_")
                or n.split(".")[0].startswith("test_")]
    return out


def test_no_test_module_imports_another():
    found = {p.relative_to(TESTS).as_posix(): imported_test_modules(p.read_text(encoding="utf-8"))
             for p in sorted(TESTS.rglob("*.py")) if "node_modules" not in p.parts}
    assert {k: v for k, v in found.items() if v} == {}


def test_the_import_check_sees_imports_inside_functions():
    source = "import numpy\ndef f():\n    from test_tls import make_certificate\n"
    assert imported_test_modules(source) == ["test_tls"]
    assert imported_test_modules("from tlstools import make_certificate\n") == []


def test_no_test_file_is_named_after_an_issue():
    named = [p.name for p in _test_files() if ISSUE_NAME.search(p.stem)]
    assert named == [], "name a test file by what it tests, not by the issue that asked for it"
    assert ISSUE_NAME.search("test_bad_input_33") and not ISSUE_NAME.search("test_bad_input_cli")


def test_test_files_have_one_name_each_in_every_folder():
    """The folders mirror the package and hold no __init__.py: pytest imports each test file
    by its own name (its folder put first on sys.path, as tests/conftest.py's puts tests/ for
    the *tools.py helpers), so two files of one name would be one module."""
    seen: dict[str, list[str]] = {}
    for p in _test_files():
        seen.setdefault(p.name, []).append(p.relative_to(TESTS).as_posix())
    assert {name: where for name, where in seen.items() if len(where) > 1} == {}
    assert not [p for p in TESTS.rglob("__init__.py") if "node_modules" not in p.parts]
