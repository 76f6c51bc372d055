import numpy as np

def labels(
    positions: np.ndarray,
    faces: np.ndarray,
    groups: np.ndarray,
    use_groups: bool,
    keys: np.ndarray,
    order: np.ndarray,
    cos_limit: float,
    plane_m: float,
    /,
) -> np.ndarray: ...
