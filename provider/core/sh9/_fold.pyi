# The C kernel _fold.c (its Python twin: fold_twin.fold_lens, the same signature).
import numpy as np
import numpy.typing as npt

def fold_lens(
    frame: npt.NDArray[np.uint8] | npt.NDArray[np.float32],
    table: npt.NDArray[np.float32] | None,
    geometry: tuple[int, int, int, int, int, int],
    extents: npt.NDArray[np.int32],
    tables: npt.NDArray[np.float32],
    parities: npt.NDArray[np.int32],
    sums: npt.NDArray[np.float64],
    mid: npt.NDArray[np.float32] | None,
    factor: int,
    clear: bool,
    /,
) -> None:
    """One lens's folded SH projection of frame (uint8 through table, 256 or 768 float32
    entries; or linear float32 with table None) added to sums (K, 3); geometry (xl, xr, yt,
    yb, nx, ny) the square about the lens centre, extents (ny,) the columns read per row
    pair, tables (K, ny·nx) one quarter table a weight, parities (K,) its fold (0 to 3);
    mid (H // factor, W // factor, 3): the block sums of the pixels read added to it
    (zeroed first when clear). ValueError for arrays it does not take."""
