"""``shlight calibrate-lens``: a fisheye lens curve from chessboard photos of one lens, written
as a lens file that ``compute``, ``environment``, ``export``, ``serve`` and ``register`` take
(``--lens FILE``; docs/cameras.md)."""
from __future__ import annotations

import json
import os
import re
import sys


def add_arguments(p) -> None:
    p.description = ("Fit one fisheye lens's curve r(θ) to chessboard photos (OpenCV's fisheye "
                     "calibration, Kannala-Brandt) and write a lens file for --lens FILE. "
                     "Photograph a flat chessboard with one lens, 10-20 photos, the board at "
                     "many places across the circle, nearer the rim than the centre, and at "
                     "several distances and tilts; it must be whole in each photo.")
    p.add_argument("photos", nargs="+", metavar="PHOTO",
                   help="images of the chessboard through one lens (all one size)")
    p.add_argument("--board", required=True, metavar="COLSxROWS",
                   help="inner corners of the chessboard, e.g. 9x6 for a board of 10×7 squares")
    p.add_argument("--fov", type=float, default=200.0,
                   help="the lens's field of view in degrees: the curve must hold up to half "
                        "of it (default 200, a Theta)")
    p.add_argument("--profile", default="theta-s",
                   help="for a dual-fisheye frame: the Theta profile whose layout (the other "
                        "circle's centre, the front) the lens file keeps (default theta-s)")
    p.add_argument("-o", "--output", required=True, metavar="LENS.json",
                   help="where to write the lens file ('-': standard output)")


def _board(text: str) -> tuple:
    from ..core.errors import InputError
    m = re.fullmatch(r"\s*(\d+)\s*[xX×]\s*(\d+)\s*", text)
    if not m or min(int(m[1]), int(m[2])) < 2:
        raise InputError(f"--board {text!r}: inner corners COLSxROWS, each at least 2 (e.g. 9x6)")
    return int(m[1]), int(m[2])


def _check_header(path: str) -> None:
    """Refuse a photo whose header declares a size OpenCV would not decode (one line, not
    OpenCV's exception)."""
    from ..core.errors import InputError
    from ..core.radiometry.image_size import HEADER_BYTES, check_decodable, header_size
    if not os.path.isfile(path):      # missing: said by the reading; a FIFO is not opened twice
        return
    try:
        with open(path, "rb") as f:
            data = f.read(HEADER_BYTES)
    except OSError as exc:
        raise InputError(f"cannot read {path}: {exc.strerror or exc}") from None
    size = header_size(data)
    if size is not None:
        check_decodable(*size, data, f"cannot read {path}")


def run(args) -> int:
    import cv2
    from ..core.errors import InputError
    from ..core.geometry.checks import ProjectionError
    from ..core.geometry.lens_calibration import calibrate_lens, find_board
    board = _board(args.board)
    if not 0 < args.fov <= 360:
        raise InputError(f"--fov {args.fov:g}: a field of view is in (0, 360] degrees")
    from .outputs import output_file
    out = output_file(args.output, inputs=[(p, "an input photo") for p in args.photos],
                      product="lens file", extension=".json", stdout=True)
    for path in args.photos:        # every photo's size from its header, before any work
        _check_header(path)
    corners, size, missed = [], None, []
    for path in args.photos:
        img = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
        if img is None:
            raise InputError(f"cannot read {path} as an image")
        if size is None:
            size = (img.shape[1], img.shape[0])
        elif size != (img.shape[1], img.shape[0]):
            raise InputError(f"{path} is {img.shape[1]}×{img.shape[0]}, the first photo "
                             f"{size[0]}×{size[1]}: every photo must be one size")
        found = find_board(img, board)
        if found is None:
            missed.append(os.path.basename(path))
        else:
            corners.append(found)
    if missed:
        print(f"the {board[0]}x{board[1]} board was not found whole in {len(missed)} of "
              f"{len(args.photos)} photos (left out): {', '.join(missed)}", file=sys.stderr)
    try:
        lens = calibrate_lens(corners, board, size, fov_deg=args.fov, profile=args.profile)
    except ProjectionError as exc:
        raise InputError(str(exc)) from None
    out.write(json.dumps(lens, indent=1) + "\n")
    said = sys.stderr if out.stdout else sys.stdout     # the lens file alone on stdout
    print(f"{lens['views']} photos, reprojection error {lens['rms_px']:.3f} px RMS; focal "
          f"{lens['focal']:.2f} px, centre ({lens['center'][0]:.2f}, {lens['center'][1]:.2f}), "
          f"corners seen up to {lens['max_corner_deg']:.0f}° from the axis (the curve beyond "
          f"is extrapolated to {args.fov / 2:g}°)", file=said)
    if not out.stdout:
        print(f"wrote {args.output}")
    return 0
