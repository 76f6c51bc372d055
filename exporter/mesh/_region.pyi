import numpy as np

def settle(
    points: np.ndarray,
    level: np.ndarray,
    source: np.ndarray,
    rest_level: np.ndarray,
    rest_source: np.ndarray,
    region: np.ndarray,
    done_level: np.ndarray,
    done_source: np.ndarray,
    offset: float,
    max_bound: float,
    scale: float,
    same_normal_cos: float,
    oriented_eps: float,
    max_band_edges: int,
    half: float,
    sliver: float,
    sliver_rounds: int,
    /,
) -> float: ...
