import numpy as np

def facing(
    positions: np.ndarray,
    faces: np.ndarray,
    sides: np.ndarray,
    start: np.ndarray,
    end: np.ndarray,
    side: np.ndarray,
    vertex: np.ndarray,
    /,
) -> np.ndarray: ...
