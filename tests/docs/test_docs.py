"""The documentation site (mkdocs.yml, docs/): it builds strictly, every page is in its nav,
the API reference is rendered from the docstrings, and the README stays an entrance.

``mkdocs build --strict`` fails on any warning: a broken link or anchor, a page under docs/
that the nav leaves out, a docstring mkdocstrings cannot parse. The site is built into a
temporary folder, never into the checkout's site/.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
CONFIG = ROOT / "mkdocs.yml"
MKDOCS = Path(sys.executable).with_name("mkdocs")
SETUP = "run `bash scripts/setup.sh test` (it installs mkdocs, mkdocs-material, mkdocstrings)"
README_MAX_LINES = 300


def _mkdocs() -> Path:
    if not MKDOCS.exists():
        pytest.fail(f"mkdocs is missing next to {sys.executable}: {SETUP}")
    return MKDOCS


def _nav_pages(items) -> list[str]:
    """The page paths of a nav (strings, {title: path} and {title: [...]}, nested)."""
    pages = []
    for item in items:
        if isinstance(item, str):
            pages.append(item)
        elif isinstance(item, dict):
            for value in item.values():
                pages.extend(_nav_pages(value) if isinstance(value, list) else [value])
    return [p for p in pages if not re.match(r"^[a-z]+://", p)]


@pytest.fixture(scope="module")
def nav() -> list[str]:
    """The nav's pages, read by mkdocs itself (the same parse the build does)."""
    _mkdocs()
    try:
        from mkdocs.config import load_config
    except ImportError:
        pytest.fail(f"mkdocs cannot be imported by {sys.executable}: {SETUP}")
    config = load_config(str(CONFIG))
    assert config["nav"], "mkdocs.yml has no nav"
    return _nav_pages(config["nav"])


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    run = subprocess.run([str(_mkdocs()), "build", "--strict", "--config-file", str(CONFIG),
                          "--site-dir", str(out)], cwd=ROOT, capture_output=True, text=True,
                         timeout=600, env=env)
    assert run.returncode == 0, f"mkdocs build --strict failed:\n{run.stdout}\n{run.stderr}"
    return out


def _built(site: Path, page: str) -> Path:
    """Where mkdocs (use_directory_urls) writes a page: a.md -> a/index.html."""
    path = Path(page).with_suffix("")
    return site / (path.parent if path.name == "index" else path) / "index.html"


def test_site_builds_strictly_with_every_nav_page(site, nav):
    assert len(nav) >= 8, nav
    missing = [p for p in nav if not _built(site, p).is_file()]
    assert not missing, f"nav pages not built: {missing}"


def test_every_page_is_in_the_nav(nav):
    pages = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")}
    assert not pages - set(nav), f"pages under docs/ missing from mkdocs.yml's nav: {sorted(pages - set(nav))}"
    assert not set(nav) - pages, f"nav entries with no page: {sorted(set(nav) - pages)}"


def test_api_reference_is_rendered_from_the_docstrings(site):
    html = _built(site, "api/library.md").read_text()
    assert ":::" not in html, "a mkdocstrings block was left unrendered"
    assert "SH9Projector" in html
    # SH9Projector's own docstring, and a parameter from its numpy "Parameters" section.
    assert "Projects frames of one size and projection onto SH9." in html
    assert "Frame size in pixels." in html
    assert "compute_environment" in html and "find_marker" in html


def test_readme_is_an_entrance():
    readme = (ROOT / "README.md").read_text()
    lines = readme.count("\n") + (not readme.endswith("\n"))
    assert lines <= README_MAX_LINES, f"README.md has {lines} lines (at most {README_MAX_LINES})"
    # Its links into the repository (the docs pages among them) point at files that exist.
    for target in re.findall(r"\]\(([^)\s]+)\)", readme):
        if re.match(r"^[a-z]+:", target):
            continue
        path = target.split("#")[0]
        assert (ROOT / path).exists(), f"README.md links to a missing {target}"
