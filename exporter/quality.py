"""How far a simplified level of detail is from its source: six numbers per level, fast.

Data form: both sides are lists of :class:`~exporter.model.Part` (positions (n, 3) float64 metres
in the building-local East/Up/North frame, y = Up; triangles (m, 3) wound outward). Parts are
joined and welded by exact position (to 1e-6 m) so texture seams and part junctions do not count
as open boundary. Every length is relative to the source's bounding-box diagonal (metres / metres).

Entry point: :func:`measure_lod` returns a :class:`LevelQuality` (:func:`exact_quality`
gives the same keys without measuring, for a level known to be a lossless re-triangulation;
:func:`boundary_quality` for a level with the source's surface but a changed open boundary
measures only the boundary keys; ``to_manifest()`` gives the manifest's ``quality`` object):

- ``triangle_ratio``: level triangles / source triangles.
- ``hausdorff_rel``: symmetric Hausdorff distance / diagonal, a certified upper bound
  (:mod:`exporter.mesh.hausdorff`: never below the true value, within ``HAUSDORFF_RTOL`` of a certified
  lower bound or below ``HAUSDORFF_ATOL``; the error guard's own bound, which the pipeline passes
  in for the levels it certified, is refined no finer than ``guard.BUDGET_SHARE`` of the level's
  budget), also for the levels :func:`exact_quality` and :func:`boundary_quality` report (a
  re-triangulated polygon is flat only to rounding).
- ``silhouette_iou``: minimum over the orthographic views from the top and the four sides of the
  IoU of the two silhouettes rasterised at ``RESOLUTION`` pixels on the source's box (an
  orthographic silhouette seen from the back is the mirror of the front, so three rasters
  give the five views).
- ``wall_coverage``: share of the source's wall area (near-vertical faces, |normal . Up| <
  ``WALL_MAX_UP``), estimated from area-weighted samples on the walls, within
  ``COVER_TOLERANCE`` x diagonal of the level's surface.
- ``boundary_length_change``: (level open-boundary length - source's) / source's; the open
  boundary of a floorless building is its footprint outline (when the source has none, the
  level's boundary length / diagonal). Both sides are measured as surfaces: a slit (a T-junction
  crack of zero width, :mod:`exporter.mesh.slits`) is not part of the open boundary, so closing one
  changes nothing here.
- ``new_holes``: how many more boundary loops the level has than the source (never negative).

Cost: the source side (weld, outline, silhouettes, wall samples, certification surface) is
prepared once per building (:class:`Source`), each piece when a level first needs it; a level
known to keep the source's surface is not measured (:func:`exact_quality`,
:func:`boundary_quality`), and wall coverage needs neither distances nor wall samples when the
certified bound is within its tolerance. Measurement history: docs/performance.md.
"""

from __future__ import annotations

import functools
import hashlib
import threading
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np

from .mesh import hausdorff
from .mesh.distance import (
    PROBE_MARGIN_M,
    SEED,
    SurfaceIndex,
    face_normals,
    row_lengths,
    sample_surface,
)
from .mesh.raster import RESOLUTION, min_iou, silhouettes
from .mesh.slits import open_boundary
from .mesh.weld import WeldedMesh, join_meshes
from .model import Part

SAMPLES = 256  # area-weighted surface samples per side for the Hausdorff distance
WALL_SAMPLES = 256  # area-weighted samples on the source's walls
WALL_MAX_UP = 0.3  # |unit normal . Up| below this is a wall
COVER_TOLERANCE = 0.01  # wall sample covered when within this x diagonal of the level
HAUSDORFF_RTOL = 0.02  # hausdorff_rel's certified upper bound is refined to 2 % of the lower one
HAUSDORFF_ATOL = 1e-5  # ... or until it is below this x the diagonal (lossless levels: flatness)

__all__ = [
    "LevelQuality",
    "measure_lod",
    "exact_quality",
    "boundary_quality",
    "certified_hausdorff_rel",
    "prepare_source",
    "Source",
    "RESOLUTION",
    "COVER_TOLERANCE",
]


@dataclass(frozen=True)
class LevelQuality:
    """A level's quality against its source (LOD0): the six numbers of the module doc, in the
    manifest's order (each level's ``quality`` object)."""

    triangle_ratio: float
    hausdorff_rel: float
    silhouette_iou: float
    wall_coverage: float
    boundary_length_change: float
    new_holes: int

    def to_manifest(self) -> dict:
        """The manifest's ``quality`` object: ``{"triangle_ratio": ..., ..., "new_holes": ...}``
        (``dataclasses.asdict``'s, written out: the fields are plain numbers)."""
        return {
            "triangle_ratio": self.triangle_ratio,
            "hausdorff_rel": self.hausdorff_rel,
            "silhouette_iou": self.silhouette_iou,
            "wall_coverage": self.wall_coverage,
            "boundary_length_change": self.boundary_length_change,
            "new_holes": self.new_holes,
        }


# --------------------------------------------------------------------------- mesh helpers


def joined(parts: list[Part]) -> WeldedMesh:
    """All parts as one welded mesh (:func:`exporter.mesh.weld.join_meshes`): positions (k, 3)
    metres, triangles (m, 3) int64."""
    return join_meshes([(p.positions, p.triangles) for p in parts])


# --------------------------------------------------------------------------- the metrics


class Source:
    """A building's source side (its LOD0 parts, local East/Up/North metres), each piece made
    when a level first needs it and then shared by the building's levels: the welded mesh, its
    box and diagonal, open boundary, silhouettes, wall samples and certification surface.

    The pipeline prepares one per building (:func:`prepare_source`); every function below also
    takes the parts themselves and then finds the source in a small cache keyed by their bytes.
    """

    def __init__(self, parts: list[Part]) -> None:
        self.parts = parts
        self.triangles = sum(p.triangle_count for p in parts)

    @functools.cached_property
    def mesh(self) -> WeldedMesh:
        """``joined(parts)``: positions (k, 3) metres, faces (m, 3) int64."""
        return joined(self.parts)

    @property
    def positions(self) -> np.ndarray:
        return self.mesh.positions

    @property
    def faces(self) -> np.ndarray:
        return self.mesh.faces

    @functools.cached_property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """``(low (3,), high (3,))`` metres, the welded mesh's axis-aligned box."""
        return self.positions.min(axis=0), self.positions.max(axis=0)

    @property
    def low(self) -> np.ndarray:
        return self.box[0]

    @property
    def high(self) -> np.ndarray:
        return self.box[1]

    @functools.cached_property
    def diagonal(self) -> float:
        """The box's diagonal, metres (1e-9 at least: lengths are divided by it)."""
        return max(float(np.linalg.norm(self.high - self.low)), 1e-9)

    @functools.cached_property
    def outline(self) -> tuple[float, int]:
        """Open boundary length (metres) and loops (:func:`exporter.mesh.slits.open_boundary`)."""
        return open_boundary(self.positions, self.faces)

    @property
    def border_length(self) -> float:
        return self.outline[0]

    @property
    def loops(self) -> int:
        return self.outline[1]

    @functools.cached_property
    def silhouettes(self) -> np.ndarray:
        """(3, RESOLUTION, RESOLUTION) bool on the source's own box."""
        return silhouettes(self.positions, self.faces, self.low, self.high)

    @functools.cached_property
    def wall_points(self) -> np.ndarray:
        """(w, 3) metres: ``WALL_SAMPLES`` area-weighted samples on the walls (seeded: the
        same points whenever they are drawn)."""
        positions, faces = self.mesh
        rng = np.random.default_rng(SEED)
        normals = face_normals(positions, faces)
        lengths = row_lengths(normals)
        walls = (np.abs(normals[:, 1]) < WALL_MAX_UP * lengths) & (lengths > 0)
        if lengths.sum() > 0:
            # The stream skips the SAMPLES surface samples a sampled Hausdorff distance once took
            # (3 doubles each: rng.choice's uniform, then r1, r2), so the wall samples, and with
            # them wall_coverage, stay those earlier versions reported.
            rng.random(3 * SAMPLES)
        if not walls.any():
            return np.zeros((0, 3))
        return sample_surface(positions, faces[walls], WALL_SAMPLES, rng)

    @functools.cached_property
    def surface(self) -> hausdorff.Surface:
        """The welded mesh prepared for certified bounds (:class:`exporter.mesh.hausdorff.Surface`)."""
        return hausdorff.Surface(self.positions, self.faces)


_CACHE: OrderedDict[bytes, Source] = OrderedDict()
_CACHE_LOCK = threading.Lock()  # a Dask worker runs buildings in several threads


def _source_key(parts: list[Part]) -> bytes:
    digest = hashlib.blake2b(digest_size=16)
    for p in parts:
        digest.update(p.positions.tobytes())
        digest.update(p.triangles.tobytes())
    return digest.digest()


def prepare_source(parts: list[Part] | Source) -> Source:
    """The :class:`Source` of LOD0 ``parts``: the one given, or the cached one of the same bytes
    (the last 16 kept), else a new one."""
    if isinstance(parts, Source):
        return parts
    key = _source_key(parts)
    with _CACHE_LOCK:
        source = _CACHE.get(key)
        if source is not None:
            _CACHE.move_to_end(key)
            return source
        source = _CACHE[key] = Source(parts)
        if len(_CACHE) > 16:
            _CACHE.popitem(last=False)
    return source


def _boundary_keys(
    src: Source, lod_parts: list[Part], lod_pos: np.ndarray, lod_faces: np.ndarray
) -> dict:
    """``triangle_ratio``, ``boundary_length_change`` and ``new_holes`` of a welded level
    (positions metres, local East/Up/North) against the source."""
    lod_tris = sum(p.triangle_count for p in lod_parts)
    lod_length, lod_loops = open_boundary(lod_pos, lod_faces)
    border_length, loops = src.outline
    change = (
        (lod_length - border_length) / border_length
        if border_length > 0
        else lod_length / src.diagonal
    )
    return {
        "triangle_ratio": float(lod_tris / src.triangles) if src.triangles else 1.0,
        "boundary_length_change": float(change),
        "new_holes": int(max(0, lod_loops - loops)),
    }


def _wall_coverage(src: Source, lod_pos: np.ndarray, lod_faces: np.ndarray, hausdorff: float):
    """Share of the source's wall samples within ``COVER_TOLERANCE`` x diagonal of the welded
    level (positions metres, local East/Up/North), given a certified upper bound of the
    Hausdorff distance (metres).

    No source point is farther from the level than the bound: when the bound (plus the rounding
    margin of a computed distance) is within the tolerance, every sample is covered and the
    exact distances (:meth:`SurfaceIndex.within`) would only confirm it (nor are the samples
    drawn).
    """
    tolerance = COVER_TOLERANCE * src.diagonal
    if hausdorff + PROBE_MARGIN_M * (1.0 + hausdorff) <= tolerance or len(src.wall_points) == 0:
        return 1.0
    covered = SurfaceIndex(lod_pos, lod_faces).within(src.wall_points, tolerance)
    return float(covered.mean())


def measure_lod(
    source_parts: list[Part] | Source, lod_parts: list[Part], hausdorff_m: float | None = None
) -> LevelQuality:
    """Quality of ``lod_parts`` against ``source_parts`` (both local East/Up/North metres; the
    source's parts or their :class:`Source`).

    Returns a :class:`LevelQuality` (floats, ``new_holes`` an int); see the module doc.
    Deterministic: the samples come from a fixed seed. The source side is prepared once per
    building (:func:`prepare_source`), so measuring every level of a building costs one source pass.
    ``hausdorff_m``: a certified upper bound (metres) of the level's Hausdorff distance to the
    source that the caller has already (the error guard's), used instead of certifying again.
    """
    src = prepare_source(source_parts)
    if src.triangles == 0:
        return LevelQuality(
            triangle_ratio=1.0,
            hausdorff_rel=0.0,
            silhouette_iou=1.0,
            wall_coverage=1.0,
            boundary_length_change=0.0,
            new_holes=0,
        )
    lod_pos, lod_faces = joined(lod_parts)

    # The Hausdorff distance certified from above (exporter.mesh.hausdorff, or the guard's), metres.
    hausdorff = (
        hausdorff_m
        if hausdorff_m is not None
        else certified_hausdorff_rel(src, lod_parts, (lod_pos, lod_faces)) * src.diagonal
    )
    wall_coverage = _wall_coverage(src, lod_pos, lod_faces, hausdorff)

    iou = min_iou(src.silhouettes, silhouettes(lod_pos, lod_faces, src.low, src.high))

    keys = _boundary_keys(src, lod_parts, lod_pos, lod_faces)
    return LevelQuality(
        triangle_ratio=keys["triangle_ratio"],
        hausdorff_rel=hausdorff / src.diagonal,
        silhouette_iou=iou,
        wall_coverage=wall_coverage,
        boundary_length_change=keys["boundary_length_change"],
        new_holes=keys["new_holes"],
    )


def certified_hausdorff_rel(
    source_parts: list[Part] | Source,
    lod_parts: list[Part],
    lod_mesh: tuple[np.ndarray, np.ndarray] | None = None,
) -> float:
    """Certified upper bound of the symmetric Hausdorff distance between the level and the source
    (both local East/Up/North metres; the source's parts or their :class:`Source`) / the
    source's diagonal: refined until it is within ``HAUSDORFF_RTOL`` of the lower bound or below
    ``HAUSDORFF_ATOL`` (then its value is what the refinement reached;
    :func:`exporter.mesh.hausdorff.hausdorff_bounds`); inf for an empty level, 0 for an empty
    source and level. ``lod_mesh``: ``joined(lod_parts)`` when the caller has it (not welded
    twice)."""
    src = prepare_source(source_parts)
    if not src.triangles:
        return 0.0 if not any(p.triangle_count for p in lod_parts) else float("inf")
    upper = hausdorff.hausdorff_bounds(
        src.surface,
        joined(lod_parts) if lod_mesh is None else lod_mesh,
        rtol=HAUSDORFF_RTOL,
        atol=HAUSDORFF_ATOL * src.diagonal,
    )[1]
    return upper / src.diagonal


def boundary_quality(source_parts: list[Part] | Source, lod_parts: list[Part]) -> LevelQuality:
    """:func:`measure_lod`'s metrics for a level whose *surface* is the source's but whose open
    boundary may not be (both local East/Up/North metres; the source's parts or their
    :class:`Source`).

    The lossless planar pass can close a zero-width slit or T-junction of the source: the
    surface stays the same, part of the open boundary becomes shared edges. The surface keys are
    then identity's (``silhouette_iou`` and ``wall_coverage`` 1, as in
    :func:`exact_quality`); ``triangle_ratio``, ``boundary_length_change`` and ``new_holes`` are
    computed as measure_lod computes them (the same values bit for bit), ``hausdorff_rel`` is
    measure_lod's certified bound (the re-triangulated polygons are flat only to rounding). The
    caller vouches that the surface is unchanged (not checked).
    """
    src = prepare_source(source_parts)
    if src.triangles == 0:
        return measure_lod(src, lod_parts)
    lod_pos, lod_faces = joined(lod_parts)
    keys = _boundary_keys(src, lod_parts, lod_pos, lod_faces)
    if src.triangles and not keys["triangle_ratio"]:
        raise ValueError(
            "boundary_quality: an empty level cannot have the surface of a non-empty source"
        )
    return LevelQuality(
        triangle_ratio=keys["triangle_ratio"],
        hausdorff_rel=certified_hausdorff_rel(src, lod_parts, (lod_pos, lod_faces)),
        silhouette_iou=1.0,
        wall_coverage=1.0,
        boundary_length_change=keys["boundary_length_change"],
        new_holes=keys["new_holes"],
    )


def exact_quality(source_parts: list[Part] | Source, lod_parts: list[Part]) -> LevelQuality:
    """What :func:`measure_lod` would ideally give for a level whose surface *is* the source's.

    For a lossless level (the source re-triangulated: same surface, same outline, same UV
    mapping, e.g. ``planar_retriangulation`` meeting the target) the geometric metrics follow
    from "same surface": ``silhouette_iou`` and ``wall_coverage`` 1,
    ``boundary_length_change`` 0, ``new_holes`` 0. Only ``triangle_ratio`` depends on the
    triangulation and is computed as measure_lod does; ``hausdorff_rel`` is measure_lod's
    certified bound (the source's polygons are flat only to rounding: true values ~3e-8 on
    generated VWorld-like tiles, float32 vertices, up to 1.1e-5 on real Zürich LoD2 roofs; the
    bound is typically <= 1e-5, up to ~1e-4 with slivers). No rasterising: the caller vouches for
    exactness (this function does not check it); every other metric agrees with measure_lod's
    within 2e-13 (see tests/test_quality.py).
    """
    src = prepare_source(source_parts)
    source_tris = src.triangles
    lod_tris = sum(p.triangle_count for p in lod_parts)
    if source_tris and not lod_tris:
        raise ValueError(
            "exact_quality: an empty level cannot be a re-triangulation of a non-empty source"
        )
    return LevelQuality(
        triangle_ratio=float(lod_tris / source_tris) if source_tris else 1.0,
        hausdorff_rel=certified_hausdorff_rel(src, lod_parts),
        silhouette_iou=1.0,
        wall_coverage=1.0,
        boundary_length_change=0.0,
        new_holes=0,
    )
