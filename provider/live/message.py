"""The wire contract (DESIGN.md §3): one JSON object per coefficient message.

Every message is flat enough for Unity's ``JsonUtility`` (arrays of numbers only, no
nested arrays, no null, no NaN). Output modes, as in Filament's cmgen:

* ``coefficients``: *raw radiance* projections L_lm (not pre-convolved, not divided by π);
* ``matrices``: *irradiance* E (a Lambertian surface of albedo ρ shows ρ·E/π).

The JSON Schema ships as ``provider/live/sh9_message.schema.json`` (:func:`load_schema`).
"""
from __future__ import annotations

import json
import math
import time as _time
from importlib import resources

import numpy as np

SCHEMA_VERSION = 1
FRAME = "rh-y-up"

_STAT_NUMBERS = ("compute_ms", "clipped_fraction", "order_error", "error_estimate",
                 "coverage_sr", "negative_energy_fraction",
                 "clipped_light_fraction", "exposure_s", "gain")
_STAT_INTS = ("negative_pixels", "nonfinite_pixels", "order")
#: What the numbers are (DESIGN.md §9): "srgb-assumed", "calibrated", "merged" or "linear";
#: the camera curve's method; the exposure times of a merged set.
_STAT_STRINGS = ("radiometry", "response")
_STAT_LISTS = ("exposures_s",)


def _finite(x: float) -> float:
    x = float(x)
    if not math.isfinite(x):
        raise ValueError("non-finite value in a coefficient message")
    return x


def coefficient_message(result, *, probe: str = "default", seq: int = 0,
                        time: float | None = None, stale: bool = False,
                        age_s: float = 0.0, **extra) -> dict:
    """Build the wire message for an :class:`~provider.core.engine.SH9Result`.

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
        "coefficients": [float(v) for v in coeffs.reshape(-1)],   # L00.r, L00.g, L00.b, ...
        "matrices": [float(v) for v in mats.reshape(-1)],          # M_r, M_g, M_b row-major
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
    # JsonUtility has no null: 0 means "no window applied".
    msg["window_cutoff"] = float(stats.get("window_cutoff") or 0.0)
    for k, v in extra.items():
        msg[k] = v
    return msg


def dumps(message: dict) -> str:
    """Serialise compactly; refuses NaN/Infinity (not JSON, and JsonUtility rejects them)."""
    return json.dumps(message, allow_nan=False, separators=(",", ":"))


def load_schema() -> dict:
    """The JSON Schema of the messages (hello, sh9, error)."""
    text = resources.files("provider.live").joinpath("sh9_message.schema.json").read_text()
    return json.loads(text)


def validate(message: dict) -> None:
    """Raise ``jsonschema.ValidationError`` unless ``message`` follows the schema."""
    import jsonschema
    jsonschema.validate(message, load_schema())
