"""Shared by the shader tests: build an evaluator, or skip the test where the HLSL tools are
missing."""
from __future__ import annotations

import os

import pytest


def evaluator_or_skip(make, *args):
    """``make(*args)``; where it needs glslangValidator/spirv-cross and they are missing
    (:class:`~provider.verify.hlsl.HlslToolsMissing`) the test skips, saying what to install
    (SHLIGHT_REQUIRE_HLSL=1: it fails instead)."""
    from provider.verify.hlsl import HlslToolsMissing
    try:
        return make(*args)
    except HlslToolsMissing as exc:
        if os.environ.get("SHLIGHT_REQUIRE_HLSL"):
            raise
        pytest.skip(str(exc))
