"""An analytic clear sky with a sun, in cd/m² (tooling, not product): rooms with a sun whose
colour is known, for the clipped sun's colour (docs/photometry.md).

* the sun: SPECTRL2's direct beam (pvlib) at the given elevation and atmosphere, its colour
  from the CIE 1931 CMFs (:func:`provider.core.sh9.sun_colour.spectrum_rgb`), its
  illuminance 683 lm/W · ∫ E(λ) ȳ(λ) dλ; drawn as a Gaussian disc of
  :data:`SUN_SIGMA_DEG` with a glare (the lens's, around any photographed sun) of
  :data:`GLARE` of its light falling off as exp(−γ / :data:`GLARE_DEG`), of its colour;
* the sky: the CIE standard clear sky (ISO 15469 type 12) in luminance, scaled to
  SPECTRL2's diffuse horizontal illuminance; its colour the diffuse spectrum's, turning to
  the sun's in the circumsolar brightening;
* the ground: a brown albedo (0.20, 0.16, 0.12) under the global horizontal light, Lambertian.

An atmosphere other than the product's modelled one
(:data:`provider.core.sh9.sun_colour.ATMOSPHERE`) keeps a test from reading back its own
model: :data:`HAZY` is the tests' day.
"""
from __future__ import annotations

import numpy as np

from ..core.geometry.projections import Equirect
from ..core.sh9.meter import up_weights
from ..core.sh9.sun_colour import CMF_10NM, solar_spectrum, spectrum_rgb

SUN_SIGMA_DEG = 0.35
GLARE = 0.03
GLARE_DEG = 1.2
#: A hazier, wetter day than the modelled clear sky (aerosol optical depth 0.25 at 500 nm
#: against 0.1): its sun is warmer than the model's at the same elevation.
HAZY = {"aerosol_turbidity_500nm": 0.25, "precipitable_water": 2.5, "ozone": 0.30}
GROUND_ALBEDO = np.array([0.20, 0.16, 0.12])
#: CIE standard clear sky, type 12 (a, b, c, d, e).
CLEAR_SKY = (-1.0, -0.32, 10.0, -3.0, 0.45)


def lux_of(wavelength_nm, power) -> float:
    """Illuminance (lux) of a spectral irradiance (W/m²/nm): 683 lm/W · ∫ E ȳ dλ."""
    wl = CMF_10NM[:, 0]
    p = np.interp(wl, np.asarray(wavelength_nm).reshape(-1), np.asarray(power).reshape(-1))
    return float(683.0 * np.sum(p * CMF_10NM[:, 2]) * 10.0)


def direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """World unit vector (azimuth from −Z toward +X, elevation up: as --lux-facing)."""
    a, e = np.radians(azimuth_deg), np.radians(elevation_deg)
    return np.array([np.sin(a) * np.cos(e), np.sin(e), -np.cos(a) * np.cos(e)])


def sunny_sky(width: int, height: int, elevation_deg: float, azimuth_deg: float = 40.0,
              atmosphere=None) -> tuple[np.ndarray, dict]:
    """(equirect (H, W, 3) float64 radiance in cd/m², truth): ``truth`` holds the sun's
    ``direction``, its ``rgb`` (unit luminance), ``sun_lux`` (normal to it) and the
    diffuse horizontal ``sky_lux``."""
    air = dict(HAZY if atmosphere is None else atmosphere)
    beam = solar_spectrum(elevation_deg, direct=True, **air)
    diffuse = solar_spectrum(elevation_deg, direct=False, **air)
    sun_rgb, sky_rgb = spectrum_rgb(*beam), spectrum_rgb(*diffuse)
    sun_lux, sky_lux = lux_of(*beam), lux_of(*diffuse)
    _, omega, rays = up_weights(Equirect(width, height))
    rays = np.asarray(rays, np.float64)
    sun = direction(azimuth_deg, elevation_deg)
    gamma = np.arccos(np.clip(rays @ sun, -1.0, 1.0))
    up = rays[..., 1]
    zenith = np.arccos(np.clip(up, -1.0, 1.0))
    a, b, c, d, e = CLEAR_SKY
    zs = np.radians(90.0 - elevation_deg)

    def indicatrix(g):
        return 1 + c * (np.exp(d * g) - np.exp(d * np.pi / 2)) + e * np.cos(g) ** 2

    with np.errstate(divide="ignore", over="ignore"):
        gradation = 1 + a * np.exp(b / np.maximum(np.cos(zenith), 1e-6))
    relative = indicatrix(gamma) * gradation / (indicatrix(zs) * (1 + a * np.exp(b)))
    sky_up = up > 0
    relative = np.where(sky_up, relative, 0.0)
    # scale to the diffuse horizontal illuminance: Σ L cos Z dω = sky_lux
    lz = sky_lux / float(np.sum(relative * np.maximum(up, 0) * omega))
    circumsolar = np.clip(c * np.exp(d * gamma) / indicatrix(gamma), 0.0, 1.0)
    colour = (1 - circumsolar)[..., None] * sky_rgb + circumsolar[..., None] * sun_rgb
    hdr = (lz * relative)[..., None] * colour
    # the sun: a Gaussian disc and its glare, Σ L dω = sun_lux (normal to it)
    disc = np.exp(-0.5 * (np.degrees(gamma) / SUN_SIGMA_DEG) ** 2)
    glare = np.exp(-np.degrees(gamma) / GLARE_DEG)
    for shape, share in ((disc, 1 - GLARE), (glare, GLARE)):
        shape = np.where(sky_up, shape, 0.0)
        hdr += (share * sun_lux / float(np.sum(shape * omega)) * shape)[..., None] * sun_rgb
    # the ground: Lambertian under the global horizontal light (sun and sky)
    global_rgb = sun_lux * np.sin(np.radians(elevation_deg)) * sun_rgb + sky_lux * sky_rgb
    hdr[~sky_up] = GROUND_ALBEDO * global_rgb / np.pi
    return hdr, {"direction": sun, "rgb": sun_rgb, "sun_lux": sun_lux, "sky_lux": sky_lux}
