"""Derive moments.json from Ricoh's sample pair (not shipped: theta-api-specs has no licence).

The pair is one scene as a dual-fisheye still and as its stitched equirect, in
https://github.com/ricohapi/theta-api-specs (commit bf3b75e52590bc3d91b0e96e062e4c901cacdb66):
core/assets/img/dualfisheye.png (blob 3b9b96cc) and core/assets/img/equirectangular.png (blob
38b5b239), both 640×320 8-bit sRGB. Usage (from the repository root, PYTHONPATH=.):

    git -C THETA_API_SPECS show HEAD:core/assets/img/dualfisheye.png > dualfisheye.png
    git -C THETA_API_SPECS show HEAD:core/assets/img/equirectangular.png > equirectangular.png
    python tests/data/ricoh_sample_pair/derive.py dualfisheye.png equirectangular.png

It writes, for each circle, the SH9 projection of its pixels in the lens's own frame (local
+Z = the optical axis, +X = image right, +Y = image up; the Theta V profile at 640×320, the
overlap shared between back-to-back lenses), and the SH9 of the equirect in docs/contract.md
§1. Which circle is the front is not in these numbers: the test mounts them.
"""
import json
import sys
from pathlib import Path

import cv2
import numpy as np

from provider.core.geometry import sh
from provider.core.sh9.engine import SH9Projector


def lens_rotation(lens):
    f, r, u = lens.frame
    return np.stack([r, u, f], axis=1)      # columns: local x, y, z in the world


def main(dual_path, equirect_path):
    dual = cv2.imread(dual_path)[..., ::-1].copy()
    pano = cv2.imread(equirect_path)[..., ::-1].copy()
    proj = SH9Projector(dual.shape[1], dual.shape[0], "dual-fisheye", lens="theta-v")
    half = dual.shape[1] // 2
    local = []
    for i, cols in enumerate((slice(0, half), slice(half, None))):
        only = np.zeros_like(dual)
        only[:, cols] = dual[:, cols]
        world = proj.project(only).coefficients
        R = sh.sh_rotation(lens_rotation(proj.projection.lenses[i]))
        local.append((R.T @ world).tolist())
    eq = SH9Projector(pano.shape[1], pano.shape[0]).project(pano).coefficients
    out = {"source": "https://github.com/ricohapi/theta-api-specs",
           "commit": "bf3b75e52590bc3d91b0e96e062e4c901cacdb66",
           "files": {"core/assets/img/dualfisheye.png": "3b9b96cc9cf2bed4800695ffcad54482342b5d53",
                     "core/assets/img/equirectangular.png": "38b5b239297f8195df67f9300992e37a3cda48e4"},
           "derived_by": "tests/data/ricoh_sample_pair/derive.py (sRGB decoded, lens theta-v)",
           "left_circle_local": local[0], "right_circle_local": local[1],
           "equirect": eq.tolist()}
    path = Path(__file__).with_name("moments.json")
    path.write_text(json.dumps(out, indent=1) + "\n")
    print("wrote", path)


if __name__ == "__main__":
    main(*sys.argv[1:3])
