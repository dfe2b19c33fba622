"""``calibrate-response --checker PHOTO``: the camera's colour from a ColorChecker in a photo
(:mod:`provider.core.radiometry.checker`), into camera.json."""
from __future__ import annotations


def checker_params(response, path) -> dict:
    """camera.json's ``colour_matrix``, ``white_balance`` and ``checker`` from the chart in
    the 8-bit photo at ``path``, its patches linearised by ``response`` (the curve just
    fitted). InputError (one line) for a photo that cannot be read or holds no chart."""
    import numpy as np

    from ..core.errors import InputError
    from ..core.radiometry.checker import USABLE, checker_patches, fit_colour_matrix
    from ..core.radiometry.images import read_image
    rgb = read_image(str(path))
    if rgb.dtype != np.uint8:
        raise InputError(f"--checker {path}: an 8-bit photo is needed (the curve is 8-bit)")
    codes = checker_patches(rgb)
    table = np.asarray(response.table, np.float64).reshape(256, -1)
    table = np.broadcast_to(table, (256, 3)) if table.shape[1] == 1 else table
    linear = np.stack([np.interp(codes[:, c], np.arange(256), table[:, c])
                       for c in range(3)], axis=1)
    lo, hi = (255 * v for v in USABLE)
    usable = np.all((codes > lo) & (codes < hi), axis=1)
    return fit_colour_matrix(linear, usable)


def checker_lines(response) -> list[str]:
    """What the summary says of the camera's colour."""
    params = response.params
    if "colour_matrix" not in params:
        return []
    wb = params["white_balance"]
    rows = "; ".join(" ".join(f"{v:+.3f}" for v in row) for row in params["colour_matrix"])
    return [f"colour (ColorChecker, {params['checker']['patches']} patches, CIE 2000 loss "
            f"{params['checker']['loss']:.2f}): white balance R ×{wb[0]:.3f}, B ×{wb[2]:.3f}; "
            f"camera RGB → Rec. 709 [{rows}]"]
