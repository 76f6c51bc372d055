import numpy as np

def loops(
    half: np.ndarray, half_region: np.ndarray, region_count: int, k: int, droppable: np.ndarray, /
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, int, int]: ...
