"""Issue 31: colour temperature (``cct_k``, ``duv``) of the ambient light and of each light,
from linear Rec. 709 RGB; the numpy core against colour-science (the kept library), and
scenes tinted by 2,700, 4,000 and 6,500 K blackbodies (their RGB from colour-science) read
through the engine, an HDR panorama and the simulated 8-bit camera's frames."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from provider.bench.camera_sim import CameraSim, auto_exposure
from provider.core.radiometry.bracket import merge
from provider.core.radiometry.colour_temperature import cct_duv, uv_to_cct_duv
from provider.core.sh9.engine import SH9Projector
from provider.live.wire.message import coefficient_message, validate

from conftest import load_hdri

with warnings.catch_warnings():
    warnings.simplefilter("ignore")
    colour = pytest.importorskip("colour")


def blackbody_rgb(t_k: float) -> np.ndarray:
    """Linear Rec. 709 RGB of a blackbody (CIE 1931 2°, no chromatic adaptation), max 1."""
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    xyz = colour.sd_to_XYZ(colour.sd_blackbody(t_k), cmfs)
    rgb = colour.XYZ_to_RGB(xyz, colour.RGB_COLOURSPACES["ITU-R BT.709"], None,
                            chromatic_adaptation_transform=None)
    assert np.all(rgb > 0)
    return rgb / rgb.max()


def tinted(name: str, t_k: float) -> np.ndarray:
    """The panorama made grey on average (each channel over its mean), then lit by a
    blackbody: its mean radiance has the blackbody's colour, its detail stays."""
    hdr = np.maximum(load_hdri(name), 0).astype(np.float64)
    edges = np.linspace(0, np.pi, hdr.shape[0] + 1)
    row = np.cos(edges[:-1]) - np.cos(edges[1:])          # solid angle of each row
    mean = (hdr.mean(axis=1) * row[:, None]).sum(axis=0) / row.sum()
    return (hdr / mean * blackbody_rgb(t_k)).astype(np.float32)


@pytest.mark.parametrize("t_k", [1500, 2000, 2700, 4000, 5000, 6500, 8000, 10000])
@pytest.mark.parametrize("duv", [-0.02, -0.005, 0.0, 0.005, 0.02])
def test_cct_and_duv_agree_with_colour_science(t_k, duv):
    uv = colour.temperature.CCT_to_uv_Ohno2013(np.array([t_k, duv]))
    cct, d = uv_to_cct_duv(uv)
    ref_cct, ref_duv = colour.temperature.uv_to_CCT_Ohno2013(uv)
    assert cct == pytest.approx(ref_cct, rel=0.005)
    assert d == pytest.approx(ref_duv, abs=3e-4)


def test_no_cct_for_black_or_far_from_white():
    assert cct_duv([0.0, 0.0, 0.0]) is None
    assert cct_duv([0.0, 1.0, 0.0]) is None          # pure green: |Duv| far above 0.05
    assert cct_duv([0.0, 0.0, 1.0]) is None          # pure blue: beyond 25,000 K
    assert cct_duv([1.0, 1.0, 1.0])[0] == pytest.approx(6504, rel=0.005)   # D65 white


@pytest.mark.parametrize("t_k", [2700, 4000, 6500])
def test_hdr_scene_tinted_by_a_blackbody(t_k):
    hdr = tinted("apartment", t_k)
    msg = coefficient_message(SH9Projector(512, 256, "equirect", lights="auto").project(hdr))
    validate(msg)
    assert msg["cct_k"] == pytest.approx(t_k, rel=0.02)
    assert abs(msg["duv"]) < 0.003
    assert len(msg["light_cct_k"]) == msg["lights"] == len(msg["light_duv"])


@pytest.mark.parametrize("name", ["forest", "city"])
@pytest.mark.parametrize("t_k", [2700, 4000, 6500])
def test_camera_bracket_tinted_by_a_blackbody(name, t_k):
    """8-bit frames of the simulated camera (white balance off: the tint is recorded), a
    −6…+2 EV bracket merged with its own curve: the ambient CCT within 2 %. (One auto-exposed
    frame is not enough where the sky clips: the brightest channel loses most, forest at
    6,500 K reads 5,050 K with 36 % of the light clipped; docs/photometry.md.)"""
    hdr = tinted(name, t_k)
    cam = CameraSim()
    frames, times = cam.bracket(hdr, auto_exposure(hdr), (-6, -4, -2, 0, 2))
    radiance = merge(frames, times, cam.true_response()).radiance
    msg = coefficient_message(SH9Projector(512, 256, "equirect").project(radiance))
    validate(msg)
    assert msg["cct_k"] == pytest.approx(t_k, rel=0.02), msg["cct_k"]


def test_each_light_has_its_colour():
    """A warm sun (2,700 K) in a cool sky (10,000 K): the light is warm, the ambient cool."""
    h, w = 128, 256
    sky = np.ones((h, w, 3)) * blackbody_rgb(10000) * 0.5
    sun = blackbody_rgb(2700) * 4000.0
    sky[20:23, 100:103] = sun
    msg = coefficient_message(SH9Projector(w, h, "equirect", lights="auto")
                              .project(sky.astype(np.float32)))
    validate(msg)
    assert msg["lights"] >= 1
    assert msg["light_cct_k"][0] == pytest.approx(2700, rel=0.03)
    assert msg["cct_k"] < 4500          # the sun dominates the mean radiance
