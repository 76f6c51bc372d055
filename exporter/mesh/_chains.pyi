import numpy as np

def chains(
    positions: np.ndarray, faces: np.ndarray, straight: float, /
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...
