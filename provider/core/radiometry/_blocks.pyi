# The C kernel _blocks.c (its Python twin: blocks._decode_blocks_py, the same signature).
import numpy as np
import numpy.typing as npt

def decode_blocks(
    frame: npt.NDArray[np.uint8],
    table: npt.NDArray[np.float32],
    factor: int,
    out: npt.NDArray[np.float32],
    spans: npt.NDArray[np.int32] | None = None,
    /,
) -> None:
    """out (H // factor, W // factor, C) float32 = the block means of table[frame]:
    frame (H, W, C) uint8, pixels contiguous, 1 to 4 channels; table 256 or 256·C float32
    (entry v·C + c); spans (H // factor, 2) int32: only blocks [first, stop) of each row
    are read, the rest written 0. ValueError for arrays it does not take."""
