# The C kernel _truth.c (its Python twin: coarse_truth.truth_caps_twin, the same signature).
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
