# The C kernel _equirect.c (its Python twin: equirect_pass._equirect_rows_py, the same signature).
import numpy as np
import numpy.typing as npt

def equirect_rows(
    frame: npt.NDArray[np.uint8],
    table: npt.NDArray[np.float32],
    rows: npt.NDArray[np.float32],
    acc: npt.NDArray[np.float32],
    counts: npt.NDArray[np.int32] | None,
    /,
) -> None:
    """acc (K, W·3) float32, its first half (i < 3W/2), += an 8-bit equirect frame (H, W, 3),
    W even, pixels contiguous, decoded through table (256 or 768 float32 entries) and summed
    against rows (K = 6 or 7, H): the six row functions folded about the equator (their
    rows below it not read) and a half turn (row 0 not read: rows 3 and 5 added, as
    sin θ = sin θ cos² θ + sin θ sin² θ), and the up-facing row; counts (H, 3) int32:
    written, the samples at code 255 per row and channel. ValueError for arrays it does not
    take."""
