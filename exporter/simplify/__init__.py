"""Mesh levels of detail the paper's way: quadric edge collapse with locks and a geometric filter.

Entry point: :func:`build_mesh_chain` (levels with their ``exact`` and ``surface_exact`` flags);
:func:`build_mesh_lods` is the same without the flags. Data form: :class:`~exporter.model.Part` lists (positions
(n, 3) float64 metres in the building-local East/Up/North frame, triangles (m, 3) wound outward,
per-vertex UVs (n, 2) in glTF convention, optional normals).

Sources: Garland & Heckbert, "Surface Simplification Using Quadric Error Metrics" (1997) and
Hoppe, "New Quadric Metric for Simplifying Meshes with Appearance Attributes" (1999), via
meshoptimizer (zeux, ``meshopt_simplifyWithAttributes``; default) or pymeshlab; the geometric filter
and Table II options of "A Method for Constructing and Managing Level of Detail for Non-Closed
Boundary Models of Buildings" (VWorld). See ``docs/simplification.md``.

Pipeline per level (each level is built from the level above; measured, see the docs):

1. join the parts into one mesh, weld positions (``vertex_link_distance``, always 1 um noise);
2. lossless: re-triangulate every flat polygon from its outline (``planar_retriangulation``);
3. lock: vertices shared by two parts (no cracks), non-manifold edges, the open border;
4. protect: the largest ``protect_largest`` share of faces by area (the paper's filter) and, with
   ``protect_walls``, the walls standing on the footprint, are kept out of the collapse;
5. collapse as far as the level's screen error budget (:func:`screen_tolerance`, metres) allows,
   never above ``round(source triangles x lods[k].mesh)`` faces when the budget lets the level
   get there, refusing seam crossings and UV foldovers (``simplify.engine``: meshoptimizer searched
   on its error target, pymeshlab on the count); the error guard certifies every candidate;
6. split back into parts with per-vertex UVs and normals.
"""

from __future__ import annotations

import dataclasses
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from ..config import LodSpec, SimplifyOptions
from ..errors import ProcessError
from ..mesh._component import lowest
from ..mesh.geometry import longest_edges, triangle_cross, unique_float_rows
from ..mesh.topology import border_vertices, nonmanifold_vertices
from ..mesh.weld import weld_positions
from ..model import Part
from . import meshopt
from .guard import Reference, certify, exceeds, silhouette_iou
from .planar import retriangulate_planar_checked
from .protect import face_areas, footprint_wall_faces, largest_faces, part_border_vertices
from .quadric import Collapsed, collapse

__all__ = ["MeshLevel", "build_mesh_chain", "build_mesh_lods", "clean_part", "degenerate_only"]

# Faces below this area (square metres) are degenerate: dropped from level 0.
ZERO_AREA_M2 = 1e-12
# Metres: positions closer than this are one vertex (the quality metrics weld the same way).
NOISE_M = 1e-6


def _check_part(part: Part, index: int) -> None:
    where = f"part {index} ({part.name or 'unnamed'})"
    if not np.all(np.isfinite(part.positions)):
        raise ProcessError(f"{where}: positions contain NaN or infinity")
    if len(part.triangles) and (
        part.triangles.min() < 0 or part.triangles.max() >= len(part.positions)
    ):
        raise ProcessError(f"{where}: triangle index outside 0..{len(part.positions) - 1}")
    if part.uvs is not None and len(part.uvs) != len(part.positions):
        raise ProcessError(f"{where}: {len(part.uvs)} UVs for {len(part.positions)} positions")
    if part.normals is not None and len(part.normals) != len(part.positions):
        raise ProcessError(
            f"{where}: {len(part.normals)} normals for {len(part.positions)} positions"
        )


def clean_part(part: Part) -> Part:
    """The part without zero-area faces (area < 1e-12 m^2, including repeated indices)."""
    areas = face_areas(part.positions, part.triangles)
    if np.all(areas >= ZERO_AREA_M2):
        return part
    return dataclasses.replace(part, triangles=part.triangles[areas >= ZERO_AREA_M2])


def degenerate_only(parts: list[Part]) -> bool:
    """Whether no face of ``parts`` is wider than the pipeline's noise (``NOISE_M``): every
    triangle's least altitude (twice its area over its longest edge, metres) is below 1 um.

    Such a model has nothing to show: collinear input that reprojection to the local frame turned
    into ~1e-9 m^2 slivers passes level 0's area test (1e-12 m^2) yet draws no pixel."""
    for part in parts:
        t = part.positions[part.triangles]
        if not len(t):
            continue
        area2 = np.sqrt((triangle_cross(part.positions, part.triangles) ** 2).sum(1))
        if np.any(area2 >= NOISE_M * longest_edges(t)):
            return False
    return True


def uv_charts(faces: np.ndarray, vertex_count: int) -> np.ndarray:
    """(m,) int64 chart of every face: faces sharing a (split, per-UV) vertex are one texture island.

    Components of the face-vertex graph (faces are nodes 0..m-1, vertex v is node m + v),
    numbered in the order of their lowest face (as ``connected_components`` of the face-face
    graph numbers them): union-find (``exporter/mesh/c/component.c``) labels each face with its
    component's lowest node, a face."""
    m = len(faces)
    if m == 0:
        return np.zeros(0, np.int64)
    faces = np.ascontiguousarray(faces, np.int64).reshape(-1, 3)
    if faces.min() < 0 or faces.max() >= vertex_count:
        raise ValueError("uv_charts: a face's vertex index is out of range")
    labels = lowest(m + vertex_count, np.repeat(np.arange(m), 3), faces.reshape(-1) + m)[:m]
    root = labels == np.arange(m)
    return (np.cumsum(root) - 1)[labels]


class JoinedParts(NamedTuple):
    """A building's parts as the one welded mesh the simplifier works on (unpacks as the six
    values; ``[:2]`` is the ``(positions, faces)`` pair the mesh layer takes)."""

    positions: np.ndarray  # (k, 3) float64 metres, building-local East/Up/North, welded
    faces: np.ndarray  # (m, 3) int64 into positions, wound outward
    face_part: np.ndarray  # (m,) int64: the part of each face
    corner_uvs: np.ndarray | None  # (m, 3, 2) float32 per face corner (glTF UV convention)
    face_chart: np.ndarray  # (m,) int64: the UV chart (texture island) of each face
    merged: bool  # welding merged vertices further apart than NOISE_M (link_distance > NOISE_M)


def _join(parts: list[Part], link_distance: float) -> JoinedParts:
    """One welded mesh from all parts (:class:`JoinedParts`)."""
    return _join_welded(parts, link_distance)[0]


def _join_welded(parts: list[Part], link_distance: float):
    """:func:`_join`'s mesh, the parts' vertices concatenated (n, 3) metres and the welded vertex
    of each (n,) int64 (for :func:`weld_offset`, with no second welding)."""
    offsets = np.cumsum([0] + [p.vertex_count for p in parts])
    positions = np.concatenate([p.positions for p in parts]) if parts else np.zeros((0, 3))
    faces = (
        np.concatenate([p.triangles + offsets[i] for i, p in enumerate(parts)])
        if parts
        else np.zeros((0, 3), np.int64)
    )
    face_part = np.repeat(np.arange(len(parts), dtype=np.int64), [p.triangle_count for p in parts])
    has_uv = any(p.uvs is not None for p in parts)
    uvs = (
        np.concatenate(
            [
                p.uvs if p.uvs is not None else np.zeros((p.vertex_count, 2), np.float32)
                for p in parts
            ]
        )
        if has_uv
        else None
    )
    # Float noise (a vertex repeated with 1e-7 m differences) is welded whatever the option says.
    welded, welded_positions = weld_positions(positions, max(link_distance, NOISE_M))
    merged = link_distance > NOISE_M and len(welded_positions) < len(
        weld_positions(positions, NOISE_M)[1]
    )
    corner_uvs = uvs[faces] if uvs is not None else None
    face_chart = uv_charts(faces, len(positions))
    faces = welded[faces]
    # Welding closer than link_distance can fold slivers to edges: drop those.
    distinct = (
        (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    )
    joined = JoinedParts(
        welded_positions,
        faces[distinct],
        face_part[distinct],
        None if corner_uvs is None else corner_uvs[distinct],
        face_chart[distinct],
        merged,
    )
    return joined, positions, welded


def _locks(positions, faces, face_part, options: SimplifyOptions) -> np.ndarray:
    k = len(positions)
    locked = part_border_vertices(faces, face_part, k) | nonmanifold_vertices(faces, k)
    if options.preserve_border_edges:
        locked |= border_vertices(faces, k)
    return locked


def _protected(positions, faces, options: SimplifyOptions) -> np.ndarray:
    """(m,) bool faces the geometric filter keeps out of the quadric collapse: the largest
    ``protect_largest`` share by area (the paper's filter) and, with ``protect_walls``, the
    near-vertical faces standing on the open bottom border."""
    protected = largest_faces(face_areas(positions, faces), options.protect_largest)
    if options.protect_walls:
        protected |= footprint_wall_faces(positions, faces, border_vertices(faces, len(positions)))
    return protected


def _split(parts: list[Part], result, face_part_in) -> list[Part]:
    """Back to one Part per input part, vertices split where a position has several UVs."""
    out = []
    part_of_face = face_part_in[result.face_ids]
    for i, part in enumerate(parts):
        mine = part_of_face == i
        corners = result.faces[mine].reshape(-1)
        if part.uvs is not None:
            uv = result.corner_uvs[mine].reshape(-1, 2)
            keys = np.column_stack([corners.astype(np.float64), uv.astype(np.float64)])
        else:
            keys = corners.astype(np.float64)[:, None]
        first, inverse = unique_float_rows(keys)
        vertex = corners[first]
        positions = result.positions[vertex]
        uvs = result.corner_uvs[mine].reshape(-1, 2)[first] if part.uvs is not None else None
        normals = None
        if part.normals is not None and len(vertex):
            # The source vertex nearest in position (and UV) gives the normal; unmoved vertices
            # find their own exactly.
            src = (
                part.positions if part.uvs is None else np.column_stack([part.positions, part.uvs])
            )
            query = positions if uvs is None else np.column_stack([positions, uvs])
            normals = part.normals[nearest_rows(src, query, part.normals)]
        out.append(
            dataclasses.replace(
                part,
                positions=positions,
                triangles=inverse.reshape(-1, 3),
                uvs=uvs,
                normals=normals,
            )
        )
    return out


def nearest_rows(src: np.ndarray, query: np.ndarray, values: np.ndarray) -> np.ndarray:
    """(q,) int64: for every ``query`` row (q, w) float, a ``src`` row (n, w) nearest to it
    whose ``values`` row (n, ...) is the value ``cKDTree(src).query(query)``'s nearest row has.

    A query row equal to src rows (every column ``==``) takes the first of them when they all
    hold the same value bytes: its nearest rows are those at distance 0 (an other row would need
    every coordinate difference below ~1e-162 for its squared distance to round to 0); the other
    rows are queried from the tree (which alone knows which of equal rows it returns)."""
    first, group = unique_float_rows(np.concatenate([src, query]))
    n = len(src)
    src_group, query_group = group[:n], group[n:]
    count = np.bincount(src_group, minlength=len(first))
    # Groups whose src rows all hold their first row's value bytes.
    raw = np.ascontiguousarray(values).view(np.uint8).reshape(n, -1)
    uniform = np.ones(len(first), dtype=bool)
    uniform[src_group[(raw[first[src_group]] != raw).any(axis=1)]] = False
    nearest = first[query_group]  # a src row: src rows precede the queries in their group
    other = (count[query_group] == 0) | ~uniform[query_group]
    if other.any():
        nearest[other] = cKDTree(src).query(query[other])[1]
    return nearest


# Bisection steps of the error guard on the pymeshlab engine (the target is raised at most this
# many times); halvings of meshopt's error target on the meshoptimizer engine.
GUARD_STEPS = 5
# meshopt's error target when a level has no error limit (metres; float32-representable).
NO_LIMIT_M = 1e30


def simplify_parts(
    parts: list[Part],
    target: int,
    options: SimplifyOptions,
    reference: tuple[np.ndarray, np.ndarray] | Reference | None = None,
    tolerance: float = float("inf"),
) -> list[Part]:
    """One level: the parts jointly simplified towards ``target`` triangles (never more than given)
    while staying within ``tolerance`` metres of ``reference`` (the error guard).

    ``reference``: the LOD0 mesh ``(positions (k, 3) metres, faces (m, 3))`` the error guard
    measures against, or that mesh prepared as a :class:`~.guard.Reference` (default: ``parts``
    themselves).
    """
    return _simplify_level(parts, target, options, reference, tolerance=tolerance)[0]


def _simplify_level(
    parts: list[Part],
    target: int,
    options: SimplifyOptions,
    reference: tuple[np.ndarray, np.ndarray] | Reference | None = None,
    joined: JoinedParts | None = None,
    tolerance: float = float("inf"),
    planar_done: bool = False,
    slits_closed: bool = False,
) -> tuple[list[Part], bool, bool, tuple[float, float] | None]:
    """:func:`simplify_parts`, whether the step kept the surface (only noise welding and the
    planar re-triangulation: no collapse, no link-distance welding) and whether it also kept the
    open boundary's length (lossless). ``joined``: ``_join(parts, link distance)`` when the caller
    has it already (level 1 shares LOD0's with the guard's reference). ``planar_done``: the parts
    are the planar stage's own output (the level above kept LOD0's surface), so it is not rerun.
    ``slits_closed``: the parts descend from a planar stage that closed their slits (a collapse
    opens none), so the planar stage does not look for any.
    Last: the guard's certified ``(lower, upper)`` metres to ``reference`` for the level it
    accepted (None when the guard did not run on the result)."""
    total = sum(p.triangle_count for p in parts)
    capped = options.engine == "pymeshlab" or not np.isfinite(tolerance)
    if total == 0 or (total <= target and capped):
        return parts, True, True, None
    positions, faces, face_part, corner_uvs, face_chart, welded = joined or _join(
        parts, options.vertex_link_distance
    )
    boundary_kept = True
    reference = reference if reference is not None else (positions, faces)
    if not isinstance(reference, Reference):
        reference = Reference(*reference)
    # Lossless first: flat polygons re-triangulated from their outlines.
    if options.planar_retriangulation and not planar_done:
        of_lod0 = positions is reference.positions and faces is reference.faces
        # Lossless, so only non-manifold vertices are held: straight vertices on the open border or
        # between two parts are dropped from both sides at once (no T-junction, no crack).
        faces, corner_uvs, source, boundary_kept = retriangulate_planar_checked(
            positions,
            faces,
            corner_uvs,
            face_chart,
            nonmanifold_vertices(faces, len(positions)),
            close=not slits_closed,
        )
        face_part, face_chart = face_part[source], face_chart[source]
        if of_lod0:
            # LOD0 itself, re-triangulated losslessly: the guard's bounds close faster on it.
            reference.offer_twin(faces)
    # Without an error budget (or on pymeshlab, whose search runs on the count) a level ends at its
    # cap; with one, meshoptimizer goes on as far as the budget allows.
    if len(faces) <= target and capped:
        # The planar pass met the target: no collapse, nothing to lock or protect.
        if len(faces) >= total:
            return parts, True, True, None
        # Closing a slit of the source keeps the surface but not its open boundary.
        return (
            _split(parts, Collapsed.unchanged(positions, faces, corner_uvs), face_part),
            not welded,
            not welded and boundary_kept,
            None,
        )
    locked = _locks(positions, faces, face_part, options)
    movable = ~_protected(positions, faces, options)
    flat = Collapsed.unchanged(positions, faces, corner_uvs)
    # Nothing may move: the collapse would return the flat mesh unchanged and every search step
    # the same, so there is nothing to run or measure.
    bounds = None
    if not movable.any():
        result = flat
    elif options.engine == "meshoptimizer":
        result, bounds = _search_meshopt(
            positions, faces, corner_uvs, face_chart, face_part, movable, locked,
            target, options, reference, tolerance,
        )  # fmt: skip
    else:
        result = _search_pymeshlab(
            positions, faces, corner_uvs, face_chart, movable, locked,
            target, options, reference, tolerance if np.isfinite(tolerance) else 0.0,
        )  # fmt: skip
    if len(result.faces) >= total:
        return parts, True, True, None
    # The surface stays only if the collapse changed nothing: no face removed, every vertex where it was.
    surface_kept = (
        not welded
        and len(result.faces) == len(faces)
        and np.array_equal(result.positions, positions[result.vertex_ids])
    )
    return _split(parts, result, face_part), surface_kept, surface_kept and boundary_kept, bounds


def _search_meshopt(
    positions, faces, corner_uvs, face_chart, face_part, movable, locked,
    target, options, reference, tolerance,
) -> tuple[Collapsed, tuple[float, float] | None]:  # fmt: skip
    """The meshoptimizer level (and the guard's certified bounds of it, metres, or None): as far as the error budget ``tolerance`` (metres) allows, never
    above ``target`` faces when the budget lets the level get there.

    meshopt runs with no face target and ``tolerance`` as its error target; its error is an
    estimate, so the guard checks the result and the error target is halved (``GUARD_STEPS``
    times) while the guard finds the level above ``tolerance``; the uncollapsed mesh when no step
    passes. A result above ``target`` faces (meshopt's estimate stopped it) is replaced by the
    collapse to ``target`` faces if the guard accepts that one. Without a budget: to ``target``."""

    def attempt(goal: int, error: float) -> Collapsed:
        return meshopt.collapse(
            positions,
            faces,
            corner_uvs,
            face_chart,
            face_part,
            movable,
            locked,
            goal,
            error,
            preserve_curvature=options.preserve_surface_curvature,
            keep_seams=options.preserve_uv_seam_edges,
            refuse_foldovers=options.preserve_uv_foldover_edges,
            max_iterations=options.max_iterations,
        )

    flat = Collapsed.unchanged(positions, faces, corner_uvs)
    if not np.isfinite(tolerance):
        return attempt(target, NO_LIMIT_M), None
    error = tolerance
    for _ in range(GUARD_STEPS):
        trial = attempt(0, error)
        if len(trial.faces) >= len(faces):
            break  # nothing collapses at this error target: a smaller one collapses nothing either
        # Certified with the manifest's tightness at once: the accepted level is not measured again.
        bounds = certify(reference, trial.positions, trial.faces, tolerance)
        if bounds is not None and _keeps_silhouette(reference, trial, options):
            if len(trial.faces) > target:
                capped = attempt(target, NO_LIMIT_M)
                capped_bounds = certify(reference, capped.positions, capped.faces, tolerance)
                if capped_bounds is not None and _keeps_silhouette(reference, capped, options):
                    return capped, capped_bounds
            return trial, bounds
        error *= 0.5
    return flat, None


def _search_pymeshlab(
    positions, faces, corner_uvs, face_chart, movable, locked,
    target, options, reference, tolerance,
) -> Collapsed:  # fmt: skip
    """The pymeshlab level: collapse to ``target`` faces; when the guard finds it above
    ``tolerance`` metres (0 = no limit), the target raised by bisection (``GUARD_STEPS``)."""

    def attempt(goal: int) -> Collapsed:
        return collapse(
            positions,
            faces,
            corner_uvs,
            face_chart,
            movable,
            locked,
            goal,
            preserve_curvature=options.preserve_surface_curvature,
            keep_seams=options.preserve_uv_seam_edges,
            refuse_foldovers=options.preserve_uv_foldover_edges,
            max_iterations=options.max_iterations,
        )

    def refused(trial: Collapsed) -> bool:
        # Without a budget (0) the level goes to its cap: no guard, no silhouette floor.
        return tolerance > 0 and (
            exceeds(reference, trial.positions, trial.faces, tolerance)
            or not _keeps_silhouette(reference, trial, options)
        )

    flat = Collapsed.unchanged(positions, faces, corner_uvs)
    result = attempt(target)
    if refused(result):
        # Raise the target until the level stays within the tolerance (bisection on the count).
        best, low, high = flat, target, len(faces)
        for _ in range(GUARD_STEPS):
            middle = (low + high) // 2
            if middle <= low or middle >= high:
                break
            trial = attempt(middle)
            if not refused(trial):
                best, high = trial, middle
            else:
                low = middle
        result = best
    return result


def _keeps_silhouette(reference: Reference, trial: Collapsed, options: SimplifyOptions) -> bool:
    """Whether the candidate keeps at least ``min_silhouette_iou`` of LOD0's silhouettes (always
    when the option is 0). The Hausdorff budget scales with the building's size, so a thin part
    (a tower on a wide base) may move by a large share of its own width within it."""
    if options.min_silhouette_iou <= 0:
        return True
    return silhouette_iou(reference, trial.positions, trial.faces) >= options.min_silhouette_iou


def screen_tolerance(size: float, shown_up_to: float, options: SimplifyOptions) -> float:
    """Metres a level may deviate from LOD0 (inf = no limit): ``max_screen_error_px`` pixels when
    the building is drawn ``shown_up_to`` of the screen high (the transition of the level above)
    on a ``reference_screen_height_px`` screen. ``size``: the LODGroup size, the largest side of
    the building's bounds (metres); Unity's screen-relative height is size / (2 d tan(fov / 2)),
    so one metre then covers ``shown_up_to x reference_screen_height_px / size`` pixels."""
    if options.max_screen_error_px <= 0 or size <= 0:
        return float("inf")
    return options.max_screen_error_px * size / (shown_up_to * options.reference_screen_height_px)


@dataclasses.dataclass(frozen=True)
class MeshLevel:
    """One level of :func:`build_mesh_chain`: its parts and whether it is exactly LOD0's surface.

    ``surface_exact``: only zero-area cleaning, noise welding (<= ``NOISE_M``) and the lossless
    planar re-triangulation happened since LOD0 (no quadric collapse removed or moved anything, no
    ``vertex_link_distance`` welding of distinct vertices), so every distance to LOD0 is zero; the
    planar pass may still have closed a zero-width slit of the source (shared edges that were open).
    ``exact``: ``surface_exact`` and the open boundary kept its length too (no slit closed), so
    every metric is LOD0's. ``exact`` implies ``surface_exact``; level 0 is both; a level built
    from a level that is not (surface-)exact is not either.
    """

    parts: list[Part]
    exact: bool
    surface_exact: bool
    # Metres the level may deviate from LOD0 (its screen error budget; inf = no limit, 0 for LOD0).
    tolerance: float = 0.0
    # Certified upper bound (metres) of the level's symmetric Hausdorff distance to LOD0's parts
    # as given (the guard's, plus LOD0's noise welding), when the guard measured it; else None.
    deviation: float | None = None


def build_mesh_chain(
    parts: list[Part], lods: list[LodSpec], options: SimplifyOptions
) -> list[MeshLevel]:
    """Mesh LoD chain: one :class:`MeshLevel` per level, LOD0 first.

    ``parts``: the building's source parts (local East/Up/North metres). Level 0 is the source
    with zero-area faces removed (nothing else changes). Level k is built from level k-1 and
    goes as far as its screen error budget (:func:`screen_tolerance`, certified against LOD0 by
    the guard) allows; ``round(source triangles x lods[k].mesh)`` is a cap on its triangles that
    holds whenever the budget lets the level reach it (the budget wins otherwise). A level is
    never larger than the level above. Parts keep their ``texture``, ``color`` and ``name``. Raises
    :class:`~exporter.errors.ProcessError` on unusable parts (NaN positions, bad indices).
    """
    for i, part in enumerate(parts):
        _check_part(part, i)
    source_triangles = sum(p.triangle_count for p in parts)
    chain = [MeshLevel([clean_part(p) for p in parts], True, True)]
    joined, lod0_positions, lod0_welded = _join_welded(chain[0].parts, 0.0)
    reference = Reference(joined.positions, joined.faces)  # the guard's reference: LOD0, welded
    size = largest_side(joined.positions)
    offset = None  # LOD0's noise welding, metres (weld_offset), when a bound needs it
    for k, spec in enumerate(lods[1:], start=1):
        target = int(round(source_triangles * spec.mesh))
        # Level k is shown at most lods[k-1].transition of the screen high.
        tolerance = screen_tolerance(size, lods[k - 1].transition, options)
        # Level 1 starts from LOD0 welded the same way as the reference: joined once; so does
        # a level whose level above is LOD0's own parts (nothing changed on the way).
        from_lod0 = k == 1 or chain[-1].parts is chain[0].parts
        shared = joined if from_lod0 and options.vertex_link_distance <= NOISE_M else None
        # A level above that kept LOD0's surface is the planar stage's output: not redone.
        planar_done = k > 1 and chain[-1].surface_exact
        # Slits were closed by the first level that is not LOD0's own parts.
        slits_closed = chain[-1].parts is not chain[0].parts
        level, surface_kept, lossless, bounds = _simplify_level(
            chain[-1].parts,
            target,
            options,
            reference,
            shared,
            tolerance,
            planar_done,
            slits_closed,
        )
        if bounds is not None:
            if offset is None:
                offset = weld_offset(lod0_positions, joined[0][lod0_welded])
            deviation: float | None = bounds[1] + offset
        elif level is chain[-1].parts:
            deviation = chain[-1].deviation  # the level above, unchanged
        else:
            deviation = None
        chain.append(
            MeshLevel(
                level,
                chain[-1].exact and lossless,
                chain[-1].surface_exact and surface_kept,
                tolerance,
                deviation,
            )
        )
    return chain


def weld_offset(positions: np.ndarray, welded: np.ndarray) -> float:
    """Metres: the largest distance between a vertex (``positions`` (n, 3)) and its position after
    welding (``welded`` (n, 3)); 0 for none. A bound measured against the welded mesh plus this
    holds against the mesh as given (moving every vertex by at most d moves no point of a face by
    more than d)."""
    if len(positions) == 0:
        return 0.0
    return float(np.sqrt(((positions - welded) ** 2).sum(1)).max())


def largest_side(positions: np.ndarray) -> float:
    """The largest side of the axis-aligned bounds (metres): Unity's ``LODGroup.size`` of the
    building after ``RecalculateBounds`` (0 for no positions)."""
    return float(np.ptp(positions, axis=0).max()) if len(positions) else 0.0


def build_mesh_lods(
    parts: list[Part], lods: list[LodSpec], options: SimplifyOptions
) -> list[list[Part]]:
    """Mesh LoD chain: one list of parts per level, LOD0 first (:func:`build_mesh_chain` without
    the ``exact`` flags)."""
    return [level.parts for level in build_mesh_chain(parts, lods, options)]
