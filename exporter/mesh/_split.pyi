import numpy as np

def fans(
    faces: np.ndarray,
    corner_uvs: np.ndarray,
    has_uvs: bool,
    side: np.ndarray,
    vertex: np.ndarray,
    t: np.ndarray,
    /,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...
