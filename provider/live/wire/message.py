"""The wire contract (docs/contract.md §3): one JSON object per coefficient message.

Every message is flat enough for Unity's ``JsonUtility`` (arrays of numbers only, no
nested arrays, no null, no NaN). Output modes, as in Filament's cmgen:

* ``coefficients``: *raw radiance* projections L_lm (not pre-convolved, not divided by π);
* ``matrices``: *irradiance* E (a Lambertian surface of albedo ρ shows ρ·E/π).

Every message also says what its numbers are: ``frame`` (``rh-y-up``), ``basis``
(``sh9-real``: the real SH of docs/contract.md §1), ``condon_shortley`` (false: no
Condon-Shortley phase), ``coefficients_mode`` / ``matrices_mode`` (the quantity) and
``units`` (``input-linear``: linear in the input's units). Other engines' layouts:
:mod:`provider.live.wire.export`.

Lights (docs/contract.md §10) are in every message: ``lights`` (k), ``light_directions`` (3k: unit
vectors toward each light), ``light_irradiance`` (3k: RGB irradiance on a surface facing
it), ``light_angular_radius_deg`` (k: the radius in degrees of the disc that casts each
light's shadows, 0 for a point), ``ambient_coefficients`` (27) and ``ambient_matrices``
(48), so that E(n) = ñᵀAñ + Σ_k I_k max(0, n·d_k). With lights off, or when a scene needs none: k = 0,
empty light arrays and the ambient equal to the full SH9, so that formula holds for every
message and a client needs no special case. ``coefficients`` and ``matrices`` are always
the full SH9 of everything (clients that ignore lights are unaffected).

The JSON Schema ships as ``provider/live/wire/sh9_message.schema.json`` (:func:`load_schema`).
"""
from __future__ import annotations

import json
import math
import time as _time
from importlib import resources

import numpy as np

from ...core.radiometry.colour_temperature import colour_fields
from ...core.radiometry.photometry import UNITS_ABSOLUTE, photometric_fields


SCHEMA_VERSION = 1
FRAME = "rh-y-up"
BASIS = "sh9-real"
UNITS = "input-linear"

_STAT_NUMBERS = ("compute_ms", "clipped_fraction", "order_error", "error_estimate",
                 "coverage_sr", "negative_energy_fraction", "light_error", "sh9_error",
                 "clipped_light_fraction", "exposure_s", "gain", "f_number", "iso",
                 "meter_lux", "meter_camera_lux", "meter_closed_lux", "meter_solid_angle_sr")
_STAT_INTS = ("negative_pixels", "nonfinite_pixels", "order", "light_candidates")
#: What the numbers are (docs/contract.md §9): "srgb-assumed", "calibrated", "merged" or "linear";
#: the camera curve's method; where a lux meter's closed light got its colour (§14); the
#: exposure times of a merged set.
_STAT_STRINGS = ("radiometry", "response", "meter_colour")
_STAT_LISTS = ("exposures_s", "meter_direction", "meter_facing")


def _finite(x: float) -> float:
    x = float(x)
    if not math.isfinite(x):
        raise ValueError("non-finite value in a coefficient message")
    return x


def coefficient_message(result, *, probe: str = "default", seq: int = 0,
                        time: float | None = None, stale: bool = False,
                        age_s: float = 0.0, **extra) -> dict:
    """Build the wire message for an :class:`~provider.core.sh9.engine.SH9Result`.

    ``time`` is the unix time of the frame (defaults to now); ``extra`` adds fields
    (numbers, strings, booleans or flat number lists), e.g. ``fps``.
    """
    coeffs = np.asarray(result.coefficients, np.float64)
    mats = np.asarray(result.matrices, np.float64)
    if not (np.all(np.isfinite(coeffs)) and np.all(np.isfinite(mats))):
        raise ValueError("non-finite coefficients cannot be sent")
    msg = {
        "type": "sh9",
        "version": SCHEMA_VERSION,
        "probe": str(probe),
        "seq": int(seq),
        "time": _finite(_time.time() if time is None else time),
        "stale": bool(stale),
        "age_s": _finite(age_s),
        "frame": FRAME,
        "coefficients_mode": "radiance",
        "matrices_mode": "irradiance",
        "basis": BASIS,
        "condon_shortley": False,
        "units": UNITS,
        "coefficients": [float(v) for v in coeffs.reshape(-1)],   # L00.r, L00.g, L00.b, ...
        "matrices": [float(v) for v in mats.reshape(-1)],          # M_r, M_g, M_b row-major
        **light_fields(result),
    }
    stats = getattr(result, "stats", {}) or {}
    for k in _STAT_NUMBERS:
        if stats.get(k) is not None and math.isfinite(float(stats[k])):
            msg[k] = float(stats[k])
    for k in _STAT_INTS:
        if stats.get(k) is not None:
            msg[k] = int(stats[k])
    for k in _STAT_STRINGS:
        if stats.get(k) is not None:
            msg[k] = str(stats[k])
    for k in _STAT_LISTS:
        if stats.get(k) is not None:
            msg[k] = [_finite(v) for v in stats[k]]
    if "min_irradiance" in stats:
        msg["min_irradiance"] = [float(v) for v in stats["min_irradiance"]]
    if "ringing" in stats:
        msg["ringing"] = bool(stats["ringing"])
    # Photometry (docs/contract.md "Photometric units"): coefficient_units always; lux, EV100
    # and each light's lux only when the coefficients are absolute (cd/m²).
    msg.update(photometric_fields(coeffs, mats, result.lights,
                                  stats.get("coefficient_units") == UNITS_ABSOLUTE,
                                  stats.get("illuminance_lux")))
    # Colour (docs/contract.md "Photometric units"): CCT and Duv of L00 and of each light.
    msg.update(colour_fields(coeffs, result.lights))
    # JsonUtility has no null: 0 means "no window applied".
    msg["window_cutoff"] = float(stats.get("window_cutoff") or 0.0)
    for k, v in extra.items():
        msg[k] = v
    return msg


def light_fields(result) -> dict:
    """The six docs/contract.md §10 fields of an :class:`~provider.core.sh9.engine.SH9Result`
    (flat number lists; see the module docstring): its ``lights`` and its ambient, which is
    the full SH9 when it has no lights."""
    lights = list(result.lights)
    ambient, ambient_m = result.ambient, result.ambient_matrices
    directions = np.asarray([light.direction for light in lights], np.float64).reshape(-1)
    irradiance = np.asarray([light.irradiance for light in lights], np.float64).reshape(-1)
    radii = np.asarray([getattr(light, "angular_radius_deg", 0.0) for light in lights],
                       np.float64)
    arrays = [np.asarray(a, np.float64).reshape(-1)
              for a in (directions, irradiance, ambient, ambient_m, radii)]
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise ValueError("non-finite lights cannot be sent")
    return {"lights": len(lights),
            "light_directions": [float(v) for v in arrays[0]],
            "light_irradiance": [float(v) for v in arrays[1]],
            "light_angular_radius_deg": [float(v) for v in arrays[4]],
            "ambient_coefficients": [float(v) for v in arrays[2]],
            "ambient_matrices": [float(v) for v in arrays[3]]}


def dumps(message: dict) -> str:
    """Serialise compactly; refuses NaN/Infinity (not JSON, and JsonUtility rejects them)."""
    return json.dumps(message, allow_nan=False, separators=(",", ":"))


def load_schema() -> dict:
    """The JSON Schema of the messages (hello, sh9, error)."""
    text = resources.files("provider.live.wire").joinpath("sh9_message.schema.json").read_text()
    return json.loads(text)


def validate(message: dict) -> None:
    """Raise ``jsonschema.ValidationError`` unless ``message`` follows the schema."""
    import jsonschema
    jsonschema.validate(message, load_schema())
