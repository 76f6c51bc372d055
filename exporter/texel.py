"""On-surface texel size: how many metres of a building's surface one texel of its atlas covers.

Data form: one textured part as a triangle mesh in any metric frame (the building-local
East/Up/North frame in the exporter): ``positions`` (n, 3) float64 metres, ``faces`` (m, 3) int
vertex indices, ``uvs`` (n, 2) float in texture units (0..1 spans the atlas once; glTF's
convention, but only areas are used so the v direction does not matter), and the atlas size
``(width, height)`` in pixels.

Per face, a texel's edge on the surface is ``sqrt(area_3d / (area_uv * width * height))``
metres: the face's surface area over the number of texels mapped onto it. A building's texel size
is the **area-weighted median** of its faces' values (:func:`texel_size_m`):

- area-weighted, because a client shows a surface in proportion to its area: a sliver face whose
  UV triangle is squeezed (a huge or tiny ratio) covers almost none of the screen;
- the median rather than the mean or the maximum, because a few faces mapped onto a handful of
  texels (a parapet, a chimney stretched over one atlas row) would otherwise decide the texel of
  the whole building;
- faces with no UV area (mapped onto a line or a point: one flat colour) and faces with no surface
  area are left out: a finer atlas adds nothing to them.

A texture LoD that halves the atlas per side doubles every face's value, so the statistic doubles
too: the error model sees the paper's quarter-of-the-pixels step exactly.
"""

from __future__ import annotations

import math

import numpy as np

# The texture error of a level coarser in texture than LOD0, in texels of that level: see the
# module doc (chosen by the camera-path benchmark, benchmarks/bench_texel_path.py).
TEXEL_ERROR_FACTOR = 4.0

# Relative to the largest value in the set: areas below this are rounding, not surface.
_NEGLIGIBLE = 1e-12


def triangle_areas(corners: np.ndarray) -> np.ndarray:
    """Areas of triangles given as (m, 3, k) corners (k = 2 or 3), in the corners' unit squared."""
    corners = np.asarray(corners, dtype=np.float64)
    u = corners[:, 1] - corners[:, 0]
    v = corners[:, 2] - corners[:, 0]
    if corners.shape[2] == 2:
        return 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])
    return 0.5 * np.linalg.norm(np.cross(u, v), axis=1)


def face_texels(
    positions: np.ndarray, faces: np.ndarray, uvs: np.ndarray, atlas_size: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray]:
    """Per face: (texel edge in metres, surface area in m^2), for the faces that have both.

    ``atlas_size`` is (width, height) in pixels. Returns two (k,) float64 arrays, k <= m.
    """
    texels, area, _ = kept_face_texels(positions, faces, uvs, atlas_size)
    return texels, area


def kept_face_texels(
    positions: np.ndarray, faces: np.ndarray, uvs: np.ndarray, atlas_size: tuple[int, int]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`face_texels` and the (m,) bool mask of the faces it kept."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    width, height = atlas_size
    if len(faces) == 0 or width <= 0 or height <= 0:
        return np.zeros(0), np.zeros(0), np.zeros(len(faces), bool)
    area = triangle_areas(np.asarray(positions, dtype=np.float64)[faces])
    texels = triangle_areas(np.asarray(uvs, dtype=np.float64)[faces]) * (float(width) * height)
    keep = (area > _NEGLIGIBLE * max(area.max(), 0.0)) & (
        texels > _NEGLIGIBLE * max(texels.max(), 0.0)
    )
    keep &= np.isfinite(area) & np.isfinite(texels)
    return np.sqrt(area[keep] / texels[keep]), area[keep], keep


def weighted_quantile(values: np.ndarray, weights: np.ndarray, q: float = 0.5) -> float:
    """The smallest value whose cumulative weight reaches ``q`` of the total (NaN when empty)."""
    values = np.asarray(values, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    if values.size == 0 or not weights.sum() > 0:
        return float("nan")
    order = np.argsort(values, kind="stable")
    cumulative = np.cumsum(weights[order])
    index = int(np.searchsorted(cumulative, q * cumulative[-1], side="left"))
    return float(values[order][min(index, values.size - 1)])


def texel_size_m(
    positions: np.ndarray,
    faces: np.ndarray,
    uvs: np.ndarray,
    atlas_size: tuple[int, int],
    q: float = 0.5,
) -> float:
    """Area-weighted ``q`` quantile of the faces' texel edges, metres (NaN without usable faces).

    One part; for a building of several parts (each with its own atlas) concatenate the
    :func:`face_texels` of its parts and call :func:`weighted_quantile` once.
    """
    sizes, areas = face_texels(positions, faces, uvs, atlas_size)
    return weighted_quantile(sizes, areas, q)


def level_texel_m(
    pieces: list[tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, int]]], q: float = 0.5
) -> float | None:
    """One level's texel size, metres: the area-weighted ``q`` quantile over the faces of all its
    textured parts together, each piece ``(positions, faces, uvs, (width, height))`` as for
    :func:`face_texels`. None when no face maps texels (an untextured level)."""
    found = [face_texels(*piece) for piece in pieces]
    if not found:
        return None
    sizes = np.concatenate([s for s, _ in found])
    areas = np.concatenate([a for _, a in found])
    value = weighted_quantile(sizes, areas, q)
    return value if math.isfinite(value) else None


def texture_error_m(texel: float | None, coarser_texture: bool) -> float:
    """Metres: a level's texture error, :data:`TEXEL_ERROR_FACTOR` x its texel size when its
    atlas is coarser than LOD0's (fewer pixels), else 0 (LOD0's own texture, or none)."""
    if texel is None or not coarser_texture or not math.isfinite(texel):
        return 0.0
    return TEXEL_ERROR_FACTOR * texel


def level_error_m(geometric: float | None, texel: float | None, coarser_texture: bool) -> float:
    """Metres: a level's error, the larger of its certified geometric bound ``geometric``
    (metres; None for LOD0, whose error is 0) and its :func:`texture_error_m`."""
    if geometric is None:
        return 0.0
    return max(float(geometric), texture_error_m(texel, coarser_texture))
