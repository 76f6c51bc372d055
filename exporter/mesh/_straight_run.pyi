import numpy as np

def runs(
    region: np.ndarray,
    seg: np.ndarray,
    start_key: np.ndarray,
    end_key: np.ndarray,
    order_out: np.ndarray,
    keys_in: np.ndarray,
    oriented: np.ndarray,
    t_junction: float,
    half: float,
    gap: np.ndarray,
    out_region: np.ndarray,
    out_seg: np.ndarray,
    /,
) -> int: ...
