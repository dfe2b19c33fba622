"""The engine's per-frame calls run with numpy's ufunc buffers cache-sized
(provider/core/ufunc_buffers.py) and leave the caller's setting as it was."""
from __future__ import annotations

import numpy as np
import pytest

from provider.core.sh9.engine import SH9Projector
from provider.core.ufunc_buffers import UFUNC_BUFFER, cache_sized_buffers


def test_a_frame_runs_with_small_buffers_and_restores_the_callers(monkeypatch):
    from provider.core.lights import extractor
    seen, analyse = [], extractor.LightExtractor.analyse

    def spy(self, *args, **kwargs):
        seen.append(np.getbufsize())
        return analyse(self, *args, **kwargs)
    monkeypatch.setattr(extractor.LightExtractor, "analyse", spy)
    p = SH9Projector(256, 128, "equirect", lights="auto")
    frame = np.full((128, 256, 3), 40, np.uint8)
    frame[20:24, 100:104] = 255                         # a lamp for the lights to see
    with np.errstate():
        np.setbufsize(4096)                             # the caller's own choice
        p.project(frame)
        assert np.getbufsize() == 4096
    assert seen == [UFUNC_BUFFER]


def test_the_callers_size_comes_back_after_an_error():
    @cache_sized_buffers
    def fails():
        assert np.getbufsize() == UFUNC_BUFFER
        raise ValueError("a bad frame")
    before = np.getbufsize()
    with pytest.raises(ValueError, match="a bad frame"):
        fails()
    assert np.getbufsize() == before
