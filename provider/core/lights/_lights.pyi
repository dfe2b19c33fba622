# The C kernel _lights.c (its Python twins: first_pass.first_pass_twin,
# coarse_truth.truth_caps_twin and
# caps.excess_rows_twin, the same signatures).
import numpy as np
import numpy.typing as npt

def truth_caps(
    x: npt.NDArray[np.float32],
    dw: npt.NDArray[np.float32],
    core: npt.NDArray[np.uint16],
    core_at: npt.NDArray[np.int32],
    band: npt.NDArray[np.uint16],
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

def first_pass(
    mid: npt.NDArray[np.float32],
    scale: float,
    luma: npt.NDArray[np.float32],
    omega: npt.NDArray[np.float32],
    Y: npt.NDArray[np.float32],
    coarse: npt.NDArray[np.float32] | None,
    factor: int,
    Ymax: npt.NDArray[np.float32],
) -> float: ...
