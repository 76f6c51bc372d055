import numpy as np

def upper(
    points: np.ndarray,
    probe_distance: np.ndarray,
    nearest: np.ndarray,
    owner: np.ndarray,
    tri: np.ndarray,
    /,
) -> np.ndarray: ...
def nearest_face(
    points: np.ndarray,
    reach: np.ndarray,
    centres: np.ndarray,
    radii: np.ndarray,
    normal: np.ndarray,
    offset: np.ndarray,
    margin: float,
    tri: np.ndarray,
    start: np.ndarray | None,
    cols: np.ndarray | None,
    /,
) -> np.ndarray: ...
def single_bound(
    tri: np.ndarray, cand: np.ndarray, trusted: np.ndarray, target: np.ndarray, /
) -> np.ndarray: ...
def chain_bound(
    tri: np.ndarray, cand: np.ndarray, start: np.ndarray, end: np.ndarray, slack: np.ndarray, /
) -> np.ndarray: ...
def pair_bound(
    tri: np.ndarray,
    nearest: np.ndarray,
    other: np.ndarray,
    trusted: np.ndarray,
    normal: np.ndarray,
    offset: np.ndarray,
    target: np.ndarray,
    /,
) -> np.ndarray: ...
def centres_radii(tri: np.ndarray, /) -> tuple[np.ndarray, np.ndarray]: ...
def planes(
    tri: np.ndarray, cross: np.ndarray, region: np.ndarray, r: int, /
) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...
def project(tri: np.ndarray, u: np.ndarray, v: np.ndarray, region: np.ndarray, /) -> np.ndarray: ...
def split4(tri: np.ndarray, /) -> np.ndarray: ...
