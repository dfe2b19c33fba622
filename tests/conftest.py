"""Shared fixtures: the real HDR panoramas in tests/data/hdri (CC0, see its README)."""
from pathlib import Path

import pytest

DATA = Path(__file__).resolve().parent / "data"
HDRI_DIR = DATA / "hdri"
HDRI_NAMES = sorted(p.stem for p in HDRI_DIR.glob("*.exr"))


def load_hdri(name: str):
    """(256, 512, 3) float32 linear RGB radiance of a bundled panorama."""
    from provider.core.images import read_image
    return read_image(HDRI_DIR / f"{name}.exr")


@pytest.fixture(scope="session")
def hdri():
    """name -> float32 panorama, loaded once per session."""
    cache = {}

    def get(name):
        if name not in cache:
            cache[name] = load_hdri(name)
        return cache[name]
    return get
