import numpy as np

def sums(positions: np.ndarray, faces: np.ndarray, sizes: np.ndarray, /) -> np.ndarray: ...
def uvs(
    faces: np.ndarray, corner_uvs: np.ndarray, sizes: np.ndarray, k: int, /
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]: ...
def rings(
    loop_vertices: np.ndarray,
    loop_bounds: np.ndarray,
    region_loops: np.ndarray,
    setup_ok: np.ndarray,
    ids: np.ndarray,
    droppable: np.ndarray,
    /,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...
def outline(
    tris: np.ndarray,
    offsets: np.ndarray | list[int],
    sizes: np.ndarray | list[int],
    face_counts: np.ndarray | list[int],
    ring_vertices: np.ndarray,
    previous: np.ndarray,
    k: int,
    /,
) -> tuple[np.ndarray, np.ndarray]: ...
def straight(
    positions: np.ndarray,
    keys: np.ndarray,
    order: np.ndarray,
    regions: np.ndarray,
    locked: np.ndarray,
    tolerance: float,
    on_border: bool,
    /,
) -> np.ndarray: ...
def plane(sums: np.ndarray, dots: np.ndarray, /) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...
def basis(normal: np.ndarray, u: np.ndarray, dots: np.ndarray, /) -> np.ndarray: ...
def spans(
    faces: np.ndarray, regions: np.ndarray, count: int, k: int, /
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...
def held(droppable: np.ndarray, faces: np.ndarray, region_start: np.ndarray, /) -> np.ndarray: ...
def border_length(positions: np.ndarray, edges: np.ndarray, counts: np.ndarray, /) -> float: ...
def pairwise(values: np.ndarray, /) -> float: ...
def finish(
    positions: np.ndarray,
    new_faces: np.ndarray,
    face_counts: np.ndarray | list[int],
    normal: np.ndarray,
    total: np.ndarray,
    /,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]: ...
def uv_lookup(
    keys: np.ndarray,
    values: np.ndarray,
    region: np.ndarray,
    face_counts: np.ndarray | list[int],
    faces: np.ndarray,
    k: int,
    /,
) -> np.ndarray: ...
