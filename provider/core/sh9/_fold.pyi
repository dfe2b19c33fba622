# The C kernel _fold.c (its Python twin: fold_twin.fold_lens, the same signature).
import numpy as np
import numpy.typing as npt

def fold_lens(
    frame: npt.NDArray[np.uint8] | npt.NDArray[np.float32],
    table: npt.NDArray[np.float32] | None,
    geometry: tuple[int, int, int, int, int, int],
    others: npt.NDArray[np.int32],
    extents: npt.NDArray[np.int32],
    radial: npt.NDArray[np.float32],
    inv_step: float,
    fix_at: npt.NDArray[np.int32],
    fixes: npt.NDArray[np.float32],
    tables: npt.NDArray[np.float32],
    parities: npt.NDArray[np.int32],
    sums: npt.NDArray[np.float64],
    mid: npt.NDArray[np.float32] | None,
    factor: int,
    clear: bool,
    clip: npt.NDArray[np.float64] | None = None,
    residual: tuple | None = None,
    first: tuple | None = None,
    /,
) -> float | None:
    """One lens's folded SH projection of frame (uint8 through table, 256 or 768 float32
    entries; or linear float32 with table None) added to sums (1 + M, 9 + K, 3); geometry
    (xl, xr, yt, yb, nx, ny) the square about the lens centre, others (M, 2) the (xl, xr) of
    more lenses with the same weights, extents (ny,) the columns read per row pair, radial
    (B, 20) the SH9 weights as functions of the radius in bins of 1 / inv_step pixels,
    fix_at (F,) and fixes (F, 9) exact corrections of some quarter pixels' SH9 weights,
    tables (K, ny·nx) one quarter table an extra weight, parities (K,) its fold (0 to 3);
    mid (H // factor, W // factor, 3): the block sums of the pixels read added to it
    (zeroed first when clear); clip (4,) (8-bit frames only): the samples at code 255 in the
    lenses' squares added to clip[0], the L00 weight of the pixels whose channel c is at 255
    (those read) to clip[1 + c]; residual (starts (H + 1,), cols (R,), weights (R, C),
    sums (C, 3)): the unpaired pixels, their weights' sums added to sums, their clipped L00
    to clip, their samples to mid; first (luma, omega, Y, coarse, factor, scale, Ymax): the
    lights' first pass over mid, run as the fold completes each band of it (with mid and
    clear), its sum of Y omega returned. ValueError for arrays it does not take, TypeError
    for a residual or first that is not such a tuple."""

def count_top(frame: npt.NDArray[np.uint8], rects: npt.NDArray[np.int32], /) -> int:
    """The samples at code 255 of frame (H, W, 3) in the rectangles rects (R, 4) of
    (r0, r1, a, b): rows r0 <= y < r1, columns a <= x < b, inside the frame (the frame
    outside a fold's squares: the clip counter's rest). ValueError for arrays it does not
    take."""
