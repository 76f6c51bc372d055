import numpy as np

def boundary(
    faces: np.ndarray, k: int, region: np.ndarray, r: int, tri2: np.ndarray, tjunction: float, /
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...
