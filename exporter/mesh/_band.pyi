import numpy as np

def region_bands(
    region: np.ndarray,
    a: np.ndarray,
    b: np.ndarray,
    side: np.ndarray,
    by_start: np.ndarray,
    xy: np.ndarray,
    good: np.ndarray,
    width: np.ndarray,
    max_edges: int,
    half: float,
    /,
) -> None: ...
def walk(
    a: np.ndarray,
    b: np.ndarray,
    side: np.ndarray,
    by_start: np.ndarray,
    a_sorted: np.ndarray,
    lo: int,
    hi: int,
    max_edges: int,
    cycle_of: np.ndarray,
    order_in_cycle: np.ndarray,
    /,
) -> int: ...
def band_width(x: np.ndarray, y: np.ndarray, side: np.ndarray, half: float, /) -> float: ...
