# The C kernel _truth.c (its Python twins: coarse_truth.truth_caps_twin and
# caps.excess_rows_twin, the same signatures).
import numpy as np
import numpy.typing as npt

def truth_caps(
    x: npt.NDArray[np.float32],
    dw: npt.NDArray[np.float32],
    core: npt.NDArray[np.int32],
    core_at: npt.NDArray[np.int32],
    band: npt.NDArray[np.int32],
    band_at: npt.NDArray[np.int32],
    kernel: npt.NDArray[np.float32],
    normals: npt.NDArray[np.float64],
    out: npt.NDArray[np.float64],
) -> None: ...

def excess_rows(
    dirs: npt.NDArray[np.float32],
    flux: npt.NDArray[np.float32],
    normals: npt.NDArray[np.float32],
    rows: npt.NDArray[np.int32],
    out: npt.NDArray[np.float64],
) -> None: ...
