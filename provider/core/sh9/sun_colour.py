"""The colour of a clipped sun when the lux meter reads no colour (no I/O).

A plain lux meter says how much light the camera clipped, not its colour; a chroma meter's
CCT and Duv say both (:mod:`.meter`). Without one, a clipped region is the sun when its core
(the pixels clipped in the most channels) is small (within :data:`SUN_SPREAD_DEG` of its
centre), above the horizon and the meter reads daylight (:data:`DAYLIGHT_LUX`). Then its
colour (:func:`sun_colour`; the message's ``meter_colour`` says which):

* ``modelled``: the direct beam's spectrum at the core's elevation from pvlib's SPECTRL2
  (Bird & Riordan 1986; the air mass by Kasten 1966; a clear sky of :data:`ATMOSPHERE`),
  integrated against the CIE 1931 2° colour matching functions (:data:`CMF_10NM`) and
  taken to linear Rec. 709 without chromatic adaptation: the frame's RGB as every colour
  field (``cct_k``) reads it. The day's haze is unknown: at 35° the beam is 5,190 K under a
  very clean sky (aerosol optical depth 0.03 at 500 nm), 5,070 K in the model's (0.1) and
  4,340 K under a hazy one (0.6); at 4°, 3,000, 2,740 and 1,650 K (:data:`AEROSOL_RANGE`).
* ``rim``: the partly clipped rim says more. A warm sun's glare clips red first: there
  green and blue are still measured and red is at least its clip level. Sun colours lie
  along one line (the Planckian locus, at the model's Duv): the measured channels' ratio
  (the sky around taken out: the median of the ring just outside the region) places the
  sun on it, each clipped channel's clip level bounds it, and it stays within the beams
  the haze range gives at that elevation (outside them the rim reads clouds or sky).
* ``neutral``: not a sun (a clipped sky, a lamp, a region below the horizon), or no pvlib:
  equal R, G, B.

The closed light goes into the core, where the sun is, not over the whole region: a low
sun's region is mostly circumsolar sky clipped in red and green (at 4°, 30° across), and
there the sun is the peak of the channel still measured.

pvlib (with pandas and scipy) is imported only here and only for a sun (``pip install
'shlight[sun]'``): a Raspberry Pi's core runs without it, and a sun is then closed neutral
with a warning.
"""
from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np

from ..radiometry.colour_temperature import (CCT_RANGE, RGB709_TO_XYZ, cct_duv,
                                             rgb_of_cct)
from ..radiometry.photometry import luminance

#: A clipped region whose samples all lie within this many degrees of its centre, centred
#: above the horizon, is taken for the sun (its disc and glare); wider is a clipped sky.
SUN_SPREAD_DEG = 20.0
#: SPECTRL2's clear sky (Bird & Riordan 1986's rural aerosol; pvlib's example atmosphere):
#: sea-level pressure (Pa), precipitable water (cm), ozone (atm-cm), aerosol optical depth
#: at 500 nm, ground albedo, day of the year (the Earth-Sun distance: ±3.3 %, no colour).
ATMOSPHERE = {"surface_pressure": 101325.0, "precipitable_water": 1.42, "ozone": 0.344,
              "aerosol_turbidity_500nm": 0.1, "ground_albedo": 0.2, "dayofyear": 172}
#: The CIE 1931 2° standard observer's x̄, ȳ, z̄ at 380-780 nm every 10 nm (CIE 015:2018,
#: as colour-science's MSDS_CMFS tabulates it; tests/core/radiometry/test_sun_colour.py checks them). 10 nm
#: is SPECTRL2's own spacing in the visible.
CMF_10NM = np.array([
    (380, 0.001368, 3.9e-05, 0.00645), (390, 0.004243, 0.00012, 0.02005),
    (400, 0.01431, 0.000396, 0.06785), (410, 0.04351, 0.00121, 0.2074),
    (420, 0.13438, 0.004, 0.6456), (430, 0.2839, 0.0116, 1.3856),
    (440, 0.34828, 0.023, 1.74706), (450, 0.3362, 0.038, 1.77211),
    (460, 0.2908, 0.06, 1.6692), (470, 0.19536, 0.09098, 1.28764),
    (480, 0.09564, 0.13902, 0.81295), (490, 0.03201, 0.20802, 0.46518),
    (500, 0.0049, 0.323, 0.272), (510, 0.0093, 0.503, 0.1582),
    (520, 0.06327, 0.71, 0.07825), (530, 0.1655, 0.862, 0.04216),
    (540, 0.2904, 0.954, 0.0203), (550, 0.43345, 0.99495, 0.00875),
    (560, 0.5945, 0.995, 0.0039), (570, 0.7621, 0.952, 0.0021),
    (580, 0.9163, 0.87, 0.00165), (590, 1.0263, 0.757, 0.0011),
    (600, 1.0622, 0.631, 0.0008), (610, 1.0026, 0.503, 0.00034),
    (620, 0.85445, 0.381, 0.00019), (630, 0.6424, 0.265, 5e-05),
    (640, 0.4479, 0.175, 2e-05), (650, 0.2835, 0.107, 0.0),
    (660, 0.1649, 0.061, 0.0), (670, 0.0874, 0.032, 0.0),
    (680, 0.04677, 0.017, 0.0), (690, 0.0227, 0.00821, 0.0),
    (700, 0.0113592, 0.004102, 0.0), (710, 0.00579035, 0.002091, 0.0),
    (720, 0.00289933, 0.001047, 0.0), (730, 0.00143997, 0.00052, 0.0),
    (740, 0.000690079, 0.0002492, 0.0), (750, 0.000332301, 0.00012, 0.0),
    (760, 0.000166151, 6e-05, 0.0), (770, 8.30753e-05, 3e-05, 0.0),
    (780, 4.15099e-05, 1.499e-05, 0.0)])
#: The sources of the closed light's colour, as the message says them (``meter_colour``).
SOURCES = ("measured", "rim", "modelled", "neutral")


def spectrum_rgb(wavelength_nm, power) -> np.ndarray | None:
    """Linear Rec. 709 RGB of unit luminance of a spectral power distribution (any
    spacing; interpolated onto :data:`CMF_10NM`'s wavelengths), or None when it has no
    luminance."""
    wl = CMF_10NM[:, 0]
    p = np.interp(wl, np.asarray(wavelength_nm, np.float64).reshape(-1),
                  np.asarray(power, np.float64).reshape(-1), left=0.0, right=0.0)
    xyz = p @ CMF_10NM[:, 1:]
    if not xyz[1] > 0:
        return None
    return np.linalg.solve(RGB709_TO_XYZ, xyz / xyz[1])


def solar_spectrum(elevation_deg: float, direct: bool = True, **atmosphere):
    """(wavelength nm, spectral irradiance W/m²/nm) of SPECTRL2's direct beam (``direct``)
    or diffuse sky for the sun at ``elevation_deg`` (> 0), in :data:`ATMOSPHERE` updated by
    ``atmosphere``. Needs pvlib (ImportError without it)."""
    import pvlib     # lazy: pandas and scipy come with it, and a Pi's core does without
    air = {**ATMOSPHERE, **atmosphere}
    zenith = 90.0 - float(elevation_deg)
    with warnings.catch_warnings():     # (pvlib's pandas deprecations are not the user's)
        warnings.simplefilter("ignore")
        mass = pvlib.atmosphere.get_relative_airmass(zenith, "kasten1966")
        out = pvlib.spectrum.spectrl2(
            np.array([zenith]), np.array([0.0]), 0.0, air["ground_albedo"],
            air["surface_pressure"], np.array([mass]), air["precipitable_water"],
            air["ozone"], air["aerosol_turbidity_500nm"], dayofyear=air["dayofyear"])
    return out["wavelength"], out["dni" if direct else "dhi"][:, 0]


@functools.lru_cache(maxsize=1024)
def _beam_rgb(elevation_tenths: int, aerosol: float) -> tuple | None:
    rgb = spectrum_rgb(*solar_spectrum(elevation_tenths / 10.0,
                                       aerosol_turbidity_500nm=aerosol))
    return None if rgb is None else tuple(float(v) for v in rgb)


def modelled_sun_rgb(elevation_deg: float, aerosol: float | None = None) -> np.ndarray | None:
    """Linear Rec. 709 RGB (unit luminance) of the direct beam at ``elevation_deg`` in
    :data:`ATMOSPHERE` (its aerosol optical depth at 500 nm ``aerosol`` if given; cached per
    0.1°: a live meter asks every frame), or None below 0.5° (SPECTRL2's air mass diverges
    at the horizon) or without a beam in the visible. A red sun low in a hazy sky is
    beyond Rec. 709's gamut: its blue is then negative. ImportError without pvlib."""
    if not elevation_deg >= 0.5:
        return None
    tau = ATMOSPHERE["aerosol_turbidity_500nm"] if aerosol is None else float(aerosol)
    hit = _beam_rgb(int(round(min(float(elevation_deg), 90.0) * 10)), tau)
    return None if hit is None else np.array(hit)


#: The clearest and the haziest days a sun's colour is read within (aerosol optical depth
#: at 500 nm: a very clean sky, a hazy one): the rim picks within the beams they span at
#: the sun's elevation (at 35°: 5,190-4,340 K; at 4°: 3,000-1,650 K). Outside it, what the
#: rim reads is the sky, clouds or glare around the sun, not the sun.
AEROSOL_RANGE = (0.03, 0.6)
#: The sun-colour line the rim is read along: Planckian colours 1,000-25,000 K, 400 steps
#: in mired (≈ 2.4 mired apart).
_LINE_MIRED = np.linspace(1e6 / CCT_RANGE[1], 1e6 / CCT_RANGE[0], 400)
#: The rim read for the sun's colour: the partly clipped pixels within this many degrees
#: of its core (farther out, a low sun's clipped region is circumsolar sky, bluer).
RIM_DEG = 3.0
#: A low sun clips red and green over a wide patch of sky and leaves blue measured: the sun
#: is where the blue rises over the patch's median at its elevation by at least this share
#: of its peak's rise, a peak that lifts it by at least this share of that median.
PEAK = 0.5
#: The meter reads daylight: at least this many lux (a lit room reads 100-500; the sun
#: 3° up under a hazy sky, 2,700). Below it a small clipped region is a lamp, not the sun.
DAYLIGHT_LUX = 1000.0
#: CIE D65's CCT: what equal R, G, B (Rec. 709's white) reads as, the neutral start.
D65_K = 6504.0


@functools.lru_cache(maxsize=64)
def _line(duv_e4: int) -> np.ndarray:
    """(K, 3) Rec. 709 RGB of unit luminance along the locus at Duv ``duv_e4``·10⁻⁴ (read
    only: built once per Duv)."""
    line = np.maximum(np.array([rgb_of_cct(1e6 / m, duv_e4 * 1e-4) for m in _LINE_MIRED]),
                      1e-9)
    line.setflags(write=False)
    return line


def rim_colour(measured: np.ndarray, clipped: np.ndarray, clip_level, sky,
               prior_k: float = D65_K, duv: float = 0.0,
               allowed_k=CCT_RANGE) -> tuple[np.ndarray, bool]:
    """(linear Rec. 709 RGB of unit luminance, whether the rim decided it) of the light
    whose rim is ``measured`` (N, 3) radiance with ``clipped`` (N, 3) channels at
    ``clip_level`` (3,). A point of the Planckian locus moved ``duv``:

    * the ratio of two channels measured together where the third clipped (the sky around,
      ``sky`` (3,), taken out first: the median log ratio over those pixels) places it;
    * every partly clipped pixel bounds it: a clipped channel over a measured one is at
      least the clip level over the measured value;
    * within the bounds and without a ratio, ``prior_k`` (the modelled sun, or D65) stands;
    * it stays within ``allowed_k`` (K, K): the colours a sun can have there.

    "Decided": a ratio placed it, or a bound moved it off the prior."""
    measured = np.asarray(measured, np.float64).reshape(-1, 3)
    clipped = np.asarray(clipped, bool).reshape(-1, 3)
    clip_level = np.asarray(clip_level, np.float64)
    line = _line(int(round(float(duv) * 1e4)))
    logs = np.log(line)
    prior = np.abs(_LINE_MIRED - 1e6 / float(prior_k))
    lo, hi = sorted(1e6 / np.asarray(allowed_k, np.float64))
    outside = np.where((_LINE_MIRED >= lo - 1e-9) & (_LINE_MIRED <= hi + 1e-9), 0.0, np.inf)
    partly = clipped.any(axis=1) & ~clipped.all(axis=1)
    if not partly.any():
        return line[int(np.argmin(prior))], False
    light = measured - np.asarray(sky, np.float64)[None, :]
    ratios = np.zeros(len(line))
    bounds = np.zeros(len(line))
    placed = False
    for k in range(3):
        for j in range(3):
            if j == k:
                continue
            # bound: channel k clipped, j measured: k/j ≥ clip_k / measured_j
            rows = partly & clipped[:, k] & ~clipped[:, j] & (measured[:, j] > 0)
            if rows.sum() >= 2:
                floor = float(np.median(np.log(clip_level[k] / measured[rows, j])))
                bounds += np.maximum(floor - (logs[:, k] - logs[:, j]), 0.0) ** 2
            # ratio: only k clipped, j and i measured (each pair once: j < i)
            i = 3 - k - j
            if j > i:
                continue
            rows = partly & clipped[:, k] & (clipped.sum(axis=1) == 1) & \
                (light[:, i] > 0) & (light[:, j] > 0)
            if rows.sum() >= 2:
                ratio = float(np.median(np.log(light[rows, j] / light[rows, i])))
                ratios += (logs[:, j] - logs[:, i] - ratio) ** 2
                placed = True
    if placed:
        best = int(np.argmin(ratios + bounds + outside))
    else:                   # the prior, or the nearest colour the bounds allow
        best = int(np.argmin(bounds + 1e-9 * prior + outside))
    return line[best], placed or bounds[int(np.argmin(prior + outside))] > 0


@dataclass
class SunColour:
    """What :func:`sun_colour` found: ``rgb`` (3,) the closed light's colour (unit
    luminance); ``source`` (:data:`SOURCES`); ``core``: (N,) bool, the region's pixels the
    sun is in (the most channels clipped), or None when the region is no sun; ``warning``: why
    a sun stayed neutral, or ''."""

    rgb: np.ndarray
    source: str
    core: np.ndarray | None = None
    warning: str = ""


def _angles_deg(rays: np.ndarray, centre: np.ndarray) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(rays @ centre, -1.0, 1.0)))


def _centre(rays: np.ndarray, omega: np.ndarray) -> np.ndarray:
    mean = (rays * omega[:, None]).sum(axis=0)
    return mean / max(float(np.linalg.norm(mean)), 1e-12)


def sun_colour(rays, omega, radiance, channels_clipped, clip_level, sky,
               lux: float, at_top=None) -> SunColour:
    """The colour of the light a plain lux meter (reading ``lux``) closes into the clipped
    region whose pixels look along ``rays`` (N, 3, world, +Y up), with solid angles
    ``omega`` (N,), ``radiance`` (N, 3, cd/m², clipped channels at ``clip_level`` (3,)),
    ``channels_clipped`` (N, 3; None: unknown) and ``at_top`` (N, 3: the channels at the
    top code itself, the core's; default ``channels_clipped``); ``sky`` (3,): the radiance
    around it.

    The region is the sun when its core (the pixels clipped in the most channels; all of it
    when the channels are unknown) lies within :data:`SUN_SPREAD_DEG` of its centre, above
    the horizon, and the meter reads daylight (:data:`DAYLIGHT_LUX`): then the modelled
    beam at the core's elevation, bounded (or placed) by the rim (:func:`rim_colour`).
    Anything else is neutral."""
    rays = np.asarray(rays, np.float64)
    omega = np.asarray(omega, np.float64)
    neutral = SunColour(np.ones(3), "neutral")
    if channels_clipped is None:
        core = np.ones(len(rays), bool)
    else:       # where the most channels clipped (a sun 2° up leaves its blue unclipped)
        top = np.asarray(channels_clipped if at_top is None else at_top, bool)
        count = top.sum(axis=1)
        core = count == count.max()
        if count.max() < 3:     # and there, the brightest of what still measures: its peak
            free = (np.asarray(radiance, np.float64) * ~top).sum(axis=1)
            # the sky's level of it at each elevation (a clear sky brightens toward the
            # horizon; the sun is a peak across it): the median of its 1° band of the core
            band = np.round(np.degrees(np.arcsin(np.clip(rays[:, 1], -1, 1)))).astype(int)
            rise = np.zeros(len(rays))
            for b in np.unique(band[core]):
                rows = core & (band == b)
                rise[rows] = (free[rows] - np.median(free[rows])) / max(
                    float(np.median(free[rows])), 1e-30)
            # a peak only where the sun lifts it clearly (a JPEG's chroma next to a red
            # sun's clipped pixels dips instead: then the whole core)
            if rise[core].max() >= PEAK:
                core &= rise >= PEAK * rise[core].max()
    centre = _centre(rays[core], omega[core])
    if not (float(lux) >= DAYLIGHT_LUX and centre[1] > 0 and
            _angles_deg(rays[core], centre).max() <= SUN_SPREAD_DEG):
        return neutral
    elevation = float(np.degrees(np.arcsin(np.clip(centre[1], -1.0, 1.0))))
    warning, prior_k, duv, allowed = "", D65_K, 0.0, CCT_RANGE
    try:
        model = modelled_sun_rgb(elevation)
        span = [modelled_sun_rgb(elevation, tau) for tau in AEROSOL_RANGE]
        if all(b is not None and cct_duv(b) for b in span):
            allowed = tuple(cct_duv(b)[0] for b in span)
    except ImportError:
        model = None
        warning = ("the clipped region is the sun but pvlib is not installed: its colour "
                   "is not modelled (pip install 'shlight[sun]', or a chroma meter's "
                   "--lux-cct)")
    told = cct_duv(model) if model is not None else None
    if told is not None:
        prior_k, duv = told
    if channels_clipped is not None:         # the rim: the glare next to the sun's core
        reach = _angles_deg(rays[core], centre).max() + RIM_DEG
        near = _angles_deg(rays, centre) <= reach
        rgb, decided = rim_colour(np.asarray(radiance)[near],
                                  np.asarray(channels_clipped)[near], clip_level, sky,
                                  prior_k, duv, allowed)
        if decided:
            return SunColour(rgb / float(luminance(rgb)), "rim", core, "")
    if told is not None:            # (a colour beyond Rec. 709 clamped into it)
        model = np.maximum(model, 0.0)
        return SunColour(model / float(luminance(model)), "modelled", core, "")
    return SunColour(np.ones(3), "neutral", core, warning)
