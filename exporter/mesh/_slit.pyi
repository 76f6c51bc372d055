import numpy as np

def inside(
    positions: np.ndarray, ids: np.ndarray, start: np.ndarray, end: np.ndarray, tolerance: float, /
) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...
