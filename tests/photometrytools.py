"""What the photometry tests share (tests/core/radiometry/test_photometry_absolute.py,
test_meter_closes_the_sun.py, test_luxmeter_sources.py, test_meter_cost.py,
test_meter_mqtt_bounds.py, test_unity_exposure.py): the simulated filmic camera's stills
with EXIF, the scenes, the exact up-facing illuminance, and the absolutely calibrated
camera.json (the ``camera`` fixture, in conftest.py)."""
from __future__ import annotations

import json
import subprocess
import sys
from fractions import Fraction

import numpy as np
from PIL import Image
from PIL.TiffImagePlugin import IFDRational, ImageFileDirectory_v2

from provider.bench.camera_sim import CameraSim
from provider.core.geometry import sh
from provider.core.geometry.projections import Equirect
from provider.core.radiometry.photometry import NOMINAL_CD_M2, luminance
from provider.core.sh9.meter import up_weights
from provider.live.wire.message import validate

from conftest import load_hdri

NOISY = dict(shot=5e-5, read=2e-4)
#: The simulated camera's own constant: X = k · L · t · (S/100) / N² (an ideal ISO 12232
#: camera has k = 1 / NOMINAL_CD_M2 ≈ 1.17; this one is 30 % more sensitive).
CAMERA_K = 1.3 / NOMINAL_CD_M2
#: Mean luminance (cd/m²) each scene is scaled to: an indoor room, a bright overcast day.
ROOM_CD_M2 = 60.0


def shlight(*args, timeout=300):
    return subprocess.run([sys.executable, "-m", "provider.cli", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)


def rational(v: float) -> IFDRational:
    f = Fraction(v).limit_denominator(1_000_000)
    return IFDRational(f.numerator, f.denominator)


def save_still(path, rgb: np.ndarray, t: float, n: float, iso: float) -> None:
    """An 8-bit still with EXIF ExposureTime, FNumber and ISO as a camera writes them
    (JPEG: the Exif IFD; TIFF: Pillow puts the tags in IFD0, which readers accept too)."""
    img = Image.fromarray(np.ascontiguousarray(rgb))
    if str(path).endswith(".jpg"):
        exif = Image.Exif()
        ifd = exif.get_ifd(0x8769)
        ifd[0x829A], ifd[0x829D], ifd[0x8827] = rational(t), rational(n), int(iso)
        img.save(path, exif=exif, quality=95)
    else:
        info = ImageFileDirectory_v2()
        info[0x829A], info[0x829D], info[0x8827] = rational(t), rational(n), int(iso)
        img.save(path, tiffinfo=info)


def exact_illuminance_up(hdr: np.ndarray) -> float:
    """Rec. 709 luminance of the exact irradiance on an up-facing surface of an equirect
    radiance map: Σ L Δφ ∫ max(cos θ, 0) sin θ dθ per row (the truth a lux meter reads)."""
    h, w = hdr.shape[:2]
    edges = np.linspace(0, np.pi, h + 1)
    s2 = np.sin(np.minimum(edges, np.pi / 2)) ** 2
    row = 0.5 * (s2[1:] - s2[:-1]) * (2 * np.pi / w)
    return float(luminance((hdr * row[:, None, None]).sum(axis=(0, 1))))


def exact_mean_luminance(hdr: np.ndarray) -> float:
    """Mean luminance over the sphere (solid-angle weighted) of an equirect radiance map."""
    h = hdr.shape[0]
    edges = np.linspace(0, np.pi, h + 1)
    row = np.cos(edges[:-1]) - np.cos(edges[1:])
    return float(luminance((hdr.mean(axis=1) * row[:, None]).sum(axis=0) / row.sum()))


def scene(name: str) -> np.ndarray:
    """The panorama scaled to a room's mean luminance (cd/m²)."""
    hdr = np.maximum(load_hdri(name), 0).astype(np.float64)
    return hdr * (ROOM_CD_M2 / float(luminance(hdr.reshape(-1, 3)).mean()))


def write_bracket(folder, name, hdr, evs, n, iso, ext="tif", seed=0):
    """A bracket around a metered exposure (mean luminance → mid-grey, K = 12.5) at f/n
    and ISO iso: paths of stills whose EXIF carries the exposure (no @SECONDS)."""
    cam = CameraSim(gain=CAMERA_K * (iso / 100.0) / n ** 2, seed=seed, **NOISY)
    t0 = 12.5 * n ** 2 / (float(luminance(hdr.reshape(-1, 3)).mean()) * iso)
    frames, times = cam.bracket(hdr, t0, evs)
    paths = []
    for ev, f, t in zip(evs, frames, times):
        path = folder / f"{name}_{ev:+g}.{ext}"
        save_still(path, f, t, n, iso)
        paths.append(path)
    return paths


def message(p):
    assert p.returncode == 0, p.stderr
    msg = json.loads(p.stdout)
    validate(msg)
    return msg


def relative_rms(coefficients, truth_coefficients) -> float:
    """Relative RMS irradiance error over the sphere of normals."""
    e, t = sh.sphere_irradiance(np.asarray(coefficients)), sh.sphere_irradiance(truth_coefficients)
    return float(np.sqrt(np.mean((e - t) ** 2)) / np.sqrt(np.mean(t ** 2)))


def facing_reading(hdr: np.ndarray, normal) -> tuple[float, tuple]:
    """(lux, (CCT, Duv)) a meter facing ``normal`` reads of an equirect panorama: Σ Y(L)
    max(d·n, 0) dω over its pixels (pixel centres), and the CCT/Duv of that light."""
    from provider.core.radiometry.colour_temperature import cct_duv
    from provider.core.radiometry.photometry import luminance
    _, omega, dirs = up_weights(Equirect(hdr.shape[1], hdr.shape[0]))
    rgb = np.tensordot(np.maximum(dirs @ np.asarray(normal), 0) * omega, hdr,
                       axes=([0, 1], [0, 1]))
    return float(luminance(rgb)), cct_duv(rgb)


def calibrated_camera(folder) -> str:
    """camera.json of the simulated camera, calibrated with ``--lux`` on a ±4 EV bracket of
    the apartment (absolute units)."""
    hdr = scene("apartment")
    paths = write_bracket(folder, "cal", hdr, (-4, -2, 0, 2, 4), n=2.0, iso=100)
    p = shlight("calibrate-response", *paths, "--lux", exact_illuminance_up(hdr),
                "-o", folder / "camera.json")
    assert p.returncode == 0, p.stderr
    return folder / "camera.json"
