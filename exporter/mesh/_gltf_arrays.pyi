import numpy as np

def arrays(
    positions: np.ndarray, normals: np.ndarray, triangles: np.ndarray, wide: bool, /
) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...
def bounds(
    positions: np.ndarray, /
) -> tuple[tuple[float, float, float], tuple[float, float, float]]: ...
