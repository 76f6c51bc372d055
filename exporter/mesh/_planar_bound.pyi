import numpy as np

def bound(
    tri: np.ndarray,
    row: np.ndarray,
    face: np.ndarray,
    region: np.ndarray,
    planes: np.ndarray,
    tri2: np.ndarray,
    seg_start: np.ndarray,
    seg: np.ndarray,
    cap: np.ndarray | None,
    loose: np.ndarray,
    scale: float,
    shrink: float,
    plane_slack_max: float,
    out: np.ndarray,
    /,
) -> None: ...
