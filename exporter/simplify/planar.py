"""Lossless planar retriangulation: every flat polygon of the building re-triangulated from its
outline only (interior vertices dropped), before any lossy collapse.

Data form: a welded mesh, ``positions`` (k, 3) float64 metres (building-local East/Up/North),
``faces`` (m, 3) int64 wound outward, ``corner_uvs`` (m, 3, 2) float32 or None, ``face_chart``
(m,) int64 UV chart per face, ``locked`` (k,) bool vertices that must stay.

A planar region (edge-connected, coplanar, one chart: :func:`~exporter.mesh.topology.planar_regions`) is one
polygon of the source model, possibly with holes, that the source happened to cut into many
triangles (VWorld walls cut into floors x window bays, earcut-triangulated CityJSON polygons).
Its outline loops are kept vertex for vertex (so neighbours never see a T-junction) and
re-triangulated with earcut (mapbox_earcut, Mapbox's ear-clipping with hole bridging). The UV
mapping of one flat chart is affine, so the outline's UVs reproduce the texture exactly. Quadric
collapse (pymeshlab) cannot do this: an edge collapses only when both ends may move, so a flat
patch whose outline is locked keeps interior vertices.

A region is left alone when the result would not be exact: a pinched outline, a vertex with two
UVs in the region, or earcut's triangles not covering the region's area.

Regions are done in batches (:func:`_retriangulate_many`, ~19 regions per building): everything
but earcut and the per-region float reductions runs once per batch, with the results of the
one-region reference :func:`_retriangulate` bit for bit (``tests/test_perf_simplify.py``,
``tests/test_planar_reference.py``). What does not depend on the droppable vertices (outline
loops, UV check, normals, plane bases) is computed once per call (:func:`region_setup`). The
integer bookkeeping (loops, UV check, outline check, straight vertices) and the exact sequential
normal sums are compiled (``exporter/mesh/c/planar_batch.c``, ``outline.c``); the projections
(``@``, which may go through BLAS) and the other numpy float reductions stay numpy calls.
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import mapbox_earcut
import numpy as np

from ..mesh import _planar_batch
from ..mesh.geometry import cross3, cross_rows, sorted_edge_keys
from ..mesh.outline_kernels import outline_loops
from ..mesh.slits import close_slits, slit_vertices
from ..mesh.topology import border_vertices, edge_use, planar_regions


def _loops(region_faces: np.ndarray) -> list[list[int]] | None:
    """Outline loops (vertex lists, in the faces' winding) of a face set, or None if pinched."""
    half = region_faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).tolist()
    inner = set(map(tuple, half))
    following: dict[int, int] = {}
    for a, b in half:
        if (b, a) not in inner:
            if a in following:
                return None
            following[a] = b
    loops, seen = [], set()
    for start in following:
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen:
            seen.add(v)
            loop.append(v)
            nxt = following.get(v)
            if nxt is None:
                return None
            v = nxt
        if v != start:
            return None
        loops.append(loop)
    return loops


def _plane_basis(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = normal.tolist()
    helper = (1.0, 0.0, 0.0) if abs(n[0]) < 0.9 else (0.0, 1.0, 0.0)
    u = cross3(n, helper)
    u /= np.linalg.norm(u)
    return u, cross3(n, u.tolist())


def straight_vertices(
    positions: np.ndarray,
    faces: np.ndarray,
    regions: np.ndarray,
    locked: np.ndarray,
    tolerance: float = 1e-6,
    on_border: bool = True,
    edge_keys: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """(k,) bool: unlocked vertices on exactly two outline edges (edges on the open border or
    between two regions) that run straight through them (collinear within ``tolerance``
    metres): dropping such a vertex from every region that has it changes no outline.
    ``edge_keys``: :func:`~exporter.mesh.geometry.sorted_edge_keys` of ``faces`` and k when the caller has them."""
    keys, order = edge_keys if edge_keys is not None else sorted_edge_keys(faces, len(positions))
    # Compiled (exporter/mesh/c/planar_batch.c): the outline edges from the sorted keys, each
    # degree-2 vertex's two outline neighbours (edges ascending, low ends first) and the test.
    return _planar_batch.straight(
        positions, keys, order, regions, locked, float(tolerance), bool(on_border)
    )


def _retriangulate(positions, region_faces, region_uvs, droppable):
    """New (faces (t, 3), corner uvs (t, 3, 2)) for one region, or None when not exact."""
    loops = _loops(region_faces)
    if not loops:
        return None
    loops = [[v for v in loop if not droppable[v]] for loop in loops]
    if any(len(loop) < 3 for loop in loops):
        return None
    if region_uvs is not None:
        # One UV per vertex in the region (the first corner's, compared exactly).
        corners = region_faces.reshape(-1)
        order = np.argsort(corners, kind="stable")
        ordered = corners[order]
        first = np.ones(len(order), dtype=bool)
        first[1:] = ordered[1:] != ordered[:-1]
        corner_uv = region_uvs.reshape(-1, 2)[order]
        owner_uv = corner_uv[np.maximum.accumulate(np.where(first, np.arange(len(order)), 0))]
        if not ((corner_uv == owner_uv).all(axis=1) | first).all():
            return None
        uv_vertices, uv_values = ordered[first], corner_uv[first]
    a, b, c = (positions[region_faces[:, i]] for i in range(3))
    normal = cross_rows(b - a, c - a).sum(axis=0)
    area = 0.5 * np.linalg.norm(normal)
    if area <= 0:
        return None
    normal /= 2 * area
    u, v = _plane_basis(normal)
    # Outer ring first (largest area), then the holes.
    flat = [positions[loop] @ np.stack([u, v], axis=1) for loop in loops]
    order = np.array([0])
    if len(loops) > 1:
        signed = [
            0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
            for p in flat
        ]
        order = np.argsort(-np.abs(signed))
    rings = [loops[i] for i in order]
    vertices = np.concatenate([loop for loop in rings])
    points = np.concatenate([flat[i] for i in order])
    ends = np.cumsum([len(loop) for loop in rings]).astype(np.uint32)
    tri = np.asarray(mapbox_earcut.triangulate_float64(points, ends), dtype=np.int64).reshape(-1, 3)
    if len(tri) != len(vertices) - 2 + 2 * (len(rings) - 1):
        return None
    new_faces = vertices[tri]
    # The new triangles' outline must be exactly the (dropped) loops: no edge across a hole.
    expected = {
        tuple(sorted((loop[i], loop[(i + 1) % len(loop)])))
        for loop in rings
        for i in range(len(loop))
    }
    # Regions are small (tens of faces): counting edges in a dict beats np.unique's overhead.
    use: dict[tuple, int] = {}
    for x, y in new_faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).tolist():
        edge = (x, y) if x < y else (y, x)
        use[edge] = use.get(edge, 0) + 1
    if {e for e, count in use.items() if count == 1} != expected or max(use.values()) > 2:
        return None
    n = cross_rows(
        positions[new_faces[:, 1]] - positions[new_faces[:, 0]],
        positions[new_faces[:, 2]] - positions[new_faces[:, 0]],
    )
    new_faces = np.where(((n @ normal) < 0)[:, None], new_faces[:, ::-1], new_faces)
    areas = 0.5 * np.linalg.norm(n, axis=1)  # reversing a face keeps its area
    # Earcut may emit zero-area slivers along collinear outline vertices: not exact, refuse.
    if abs(areas.sum() - area) > 1e-6 * max(area, 1.0) or areas.min() < 1e-9 * max(area, 1.0):
        return None
    new_uvs = None
    if region_uvs is not None:
        new_uvs = uv_values[np.searchsorted(uv_vertices, new_faces)].astype(np.float32)
    return new_faces, new_uvs


# Batches of at most this many regions are done one region at a time (same results).
SMALL_BATCH = 2


def _row_dots(rows: np.ndarray) -> np.ndarray:
    """(n,) ``row @ row`` of (n, 3) rows with the arithmetic of ``np.dot`` on one row (which
    ``np.linalg.norm`` of a vector uses): a stacked matmul, not an elementwise sum."""
    return np.matmul(rows[:, None, :], rows[:, :, None])[:, 0, 0]


def _region_loops(
    half: np.ndarray, half_region: np.ndarray, region_count: int, k: int, droppable
) -> list:
    """:func:`_loops` of many regions at once, droppable vertices already removed: per region a
    list of loops (vertex lists) or None (pinched, open chain, no outline, or a loop under 3).

    ``half`` (h, 2) int64 directed half-edges of all regions' faces in face order, ``half_region``
    (h,) their region (0..region_count-1, ascending), ``k`` the vertex count
    (``region_count * k * k < 2**62``); the walks are compiled
    (:func:`exporter.mesh.outline_kernels.outline_loops`).
    """
    half = np.ascontiguousarray(half, np.int64).reshape(-1, 2)
    half_region = np.ascontiguousarray(half_region, np.int64)
    if len(half) and (half.min() < 0 or half.max() >= k):
        raise ValueError("_region_loops: a vertex id is out of range")
    if len(droppable) < k:
        raise ValueError("_region_loops: droppable has fewer than k entries")
    if len(half_region) > 1 and (np.diff(half_region) < 0).any():
        raise ValueError("_region_loops: the regions are not ascending")
    bad, vertices, bounds, loop_region = outline_loops(  # compiled
        half, half_region, int(region_count), int(k), np.asarray(droppable, dtype=bool)
    )
    loops: list = [None if b else [] for b in bad.tolist()]
    flat, ends = vertices.tolist(), bounds.tolist()
    for i, region in enumerate(loop_region.tolist()):
        if loops[region] is not None:
            loops[region].append(flat[ends[i] : ends[i + 1]])
    return loops


class RegionSetup(NamedTuple):
    """What :func:`_retriangulate_many` needs of regions that does not depend on the droppable
    vertices, for regions ``0..count-1`` (the ``members`` it was made from): computed once per
    :func:`retriangulate_planar_checked` call, shared by every batch of both passes."""

    loop_vertices: np.ndarray  # (v,) int64 the outline loops' vertices (nothing dropped), flat
    loop_bounds: np.ndarray  # (l + 1,) int64 loop i is loop_vertices[loop_bounds[i]:...[i + 1]]
    region_loops: np.ndarray  # (count + 1,) int64 region r's loops (none used when not ok)
    ok: np.ndarray  # (count,) bool: loops closed, one UV per vertex, area > 0
    normal: np.ndarray  # (count, 3) unit normal (outward sum of the faces' cross products)
    area: np.ndarray  # (count,) m²
    basis: np.ndarray  # (count, 3, 2) the plane's (u, v) axes as columns
    uv_keys: np.ndarray | None  # (c,) ascending region * k + vertex
    uv_values: np.ndarray | None  # (c, 2) float32: that vertex's UV in that region


def region_setup(positions, faces, corner_uvs, members: list) -> RegionSetup | None:
    """:class:`RegionSetup` of the regions ``members`` (list of (f_r,) face indices), or None
    when its int64 keys could overflow (then batches go one region at a time). Loops, the UV
    check and the normal sums are compiled (``exporter/mesh/c/outline.c``, ``planar_batch.c``)."""
    count, k = len(members), len(positions)
    if count * k * k >= 2**62:
        return None
    sizes = np.array([len(m) for m in members], dtype=np.int64)
    member_faces = np.concatenate(members)
    region_faces = faces[member_faces]
    bad, loop_vertices, loop_bounds, loop_region = outline_loops(  # compiled
        region_faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2),
        np.repeat(np.arange(count), 3 * sizes),
        count,
        k,
        np.zeros(k, dtype=bool),
    )
    region_loops = np.searchsorted(loop_region, np.arange(count + 1))
    ok = ~bad
    uv_keys = uv_values = None
    if corner_uvs is not None:
        # One UV per vertex in each region (the first corner's in face order, compared exactly).
        keys, values, conflict, n = _planar_batch.uvs(
            region_faces, corner_uvs[member_faces], sizes, k
        )
        ok &= ~conflict
        uv_keys, uv_values = keys[:n], values[:n]
    normal = _planar_batch.sums(positions, region_faces, sizes)
    # _plane_basis per row with helper (1, 0, 0) or (0, 1, 0), the same IEEE operations
    # (compiled); the dot products, which np.dot may do in BLAS, stay numpy's.
    area, normal, u = _planar_batch.plane(normal, _row_dots(normal))
    ok &= area > 0
    basis = _planar_batch.basis(normal, u, _row_dots(u))  # (regions, 3, 2): axes as columns
    return RegionSetup(
        loop_vertices, loop_bounds, region_loops, ok, normal, area, basis, uv_keys, uv_values
    )


def _retriangulate_many(
    positions,
    faces,
    corner_uvs,
    members: list,
    droppable: np.ndarray,
    setup: RegionSetup | None = None,
    ids: list | None = None,
) -> list:
    """``[_retriangulate(positions, faces[m], corner_uvs[m], droppable) for m in members]``, bit for
    bit, with the per-region work batched: the loops, the outline check, cross products, area
    sums and orientation, the UV lookup run once over all regions (compiled:
    ``exporter/mesh/c/planar_batch.c``); per region only numpy's projection (``@``, which may go
    through BLAS, as the reference's), earcut, and for faces almost edge-on to the plane the
    reference's matmul remain.

    ``setup``: :func:`region_setup` of a list of regions of which ``members`` are those at ``ids``
    (made here when not given).
    """
    count, k = len(members), len(positions)
    if count == 0:
        return []
    if setup is None:
        # One or two regions: the setup's fixed cost (measured ~2 regions' worth) is not worth it.
        setup = (
            None if count <= SMALL_BATCH else region_setup(positions, faces, corner_uvs, members)
        )
        ids = list(range(count))
    if setup is None or count * k * k >= 2**62:
        return [
            _retriangulate(
                positions, faces[m], None if corner_uvs is None else corner_uvs[m], droppable
            )
            for m in members
        ]
    assert ids is not None
    # The loops with the droppable vertices removed, flat (compiled): the ok regions (todo)'s
    # ring vertices, each one's predecessor in its ring, the rings' ends and each region's rings.
    ok, ring_vertices, previous, ring_ends, region_rings, todo_slots, ring_sizes = (
        _planar_batch.rings(
            setup.loop_vertices,
            setup.loop_bounds,
            setup.region_loops,
            setup.ok,
            np.asarray(ids, dtype=np.int64),
            droppable,
        )
    )
    normal, area = setup.normal[ids], setup.area[ids]
    todo = todo_slots.tolist()
    if not todo:
        return [None] * count
    projected_from = positions[ring_vertices]
    first_ring, ends_of = region_rings.tolist(), [0, *ring_ends.tolist()]
    tris, offsets, sizes, done = [], [], [], []
    for j, r in enumerate(todo):
        lo_ring, hi_ring = first_ring[j], first_ring[j + 1]
        at, size = ends_of[lo_ring], ends_of[hi_ring] - ends_of[lo_ring]
        points = projected_from[at : at + size] @ setup.basis[ids[r]]
        local = None
        if hi_ring - lo_ring > 1:
            # Outer ring first (largest area), then the holes.
            ends = np.array(ends_of[lo_ring : hi_ring + 1]) - at
            flat = [points[ends[i] : ends[i + 1]] for i in range(hi_ring - lo_ring)]
            signed = [
                0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])
                for p in flat
            ]
            order = np.argsort(-np.abs(signed))
            local = np.concatenate([np.arange(ends[i], ends[i + 1]) for i in order])
            points = np.concatenate([flat[i] for i in order])
            ring_end = np.array(list(itertools.accumulate(len(flat[i]) for i in order)), np.uint32)
        else:
            ring_end = ring_sizes[lo_ring : lo_ring + 1]  # earcut's ends of one ring
        tri = mapbox_earcut.triangulate_float64(points, ring_end)
        if len(tri) != 3 * (size - 2 + 2 * (hi_ring - lo_ring - 1)):
            continue
        # Earcut's indices into this region's slice of ring_vertices (in the original ring order).
        tris.append(tri if local is None else local[tri])
        offsets.append(at)
        sizes.append(size)
        done.append(r)
    results: list = [None] * count
    if not done:
        return results
    face_counts = [len(t) // 3 for t in tris]
    # Vertex ids and the outline check (compiled): the new triangles' outline must be exactly
    # the (dropped) loops, no edge across a hole, none used by three triangles.
    new_faces, broken = _planar_batch.outline(
        np.concatenate(tris), offsets, sizes, face_counts, ring_vertices, previous, k
    )
    done_array = np.array(done)
    ok[done_array[broken]] = False
    face_bounds = [0, *itertools.accumulate(face_counts)]
    # Cross products, the area checks and the orientation (compiled, the reference's
    # arithmetic): earcut may emit zero-area slivers along collinear outline vertices, not
    # exact, refused. Faces almost edge-on to the plane take their orientation from the
    # reference's per-region matmul (numpy: it may go through BLAS).
    n, flip, bad, recheck = _planar_batch.finish(
        positions, new_faces, face_counts, normal[done], area[done]
    )
    ok[done_array[bad]] = False
    for i in np.flatnonzero(recheck).tolist():
        lo, hi = face_bounds[i], face_bounds[i + 1]
        flip[lo:hi] = (n[lo:hi] @ normal[done[i]]) < 0
    new_faces = np.where(flip[:, None], new_faces[:, ::-1], new_faces)
    new_uvs = None
    if setup.uv_keys is not None and setup.uv_values is not None:
        new_uvs = _planar_batch.uv_lookup(
            setup.uv_keys,
            setup.uv_values,
            np.array(ids)[done_array],
            face_counts,
            new_faces,
            k,
        )
    kept = ok.tolist()
    for i, r in enumerate(done):
        if kept[r]:
            lo, hi = face_bounds[i], face_bounds[i + 1]
            results[r] = (new_faces[lo:hi], None if new_uvs is None else new_uvs[lo:hi])
    return results


def _boundary(positions: np.ndarray, faces: np.ndarray) -> float:
    """Open-boundary length (metres): the edges used once, np.linalg.norm and np.sum's
    arithmetic (compiled: ``planar_batch.border_length``)."""
    edges, counts = edge_use(faces)
    return _planar_batch.border_length(positions, edges, counts)


def retriangulate_planar(
    positions: np.ndarray, faces: np.ndarray, corner_uvs, face_chart: np.ndarray, locked: np.ndarray
):
    """Every planar region with droppable vertices re-triangulated from its outline (see the
    module doc); straight vertices on the open border are dropped too unless that would close a
    slit of the source (the open boundary's length must not change).

    Returns ``(faces (m', 3), corner_uvs (m', 3, 2) or None, source (m',) int64)`` where
    ``source`` is, for every output face, an input face of the same region (for chart, part and
    UV orientation). Lossless: same surface, same texture mapping, same outlines.
    """
    return retriangulate_planar_checked(positions, faces, corner_uvs, face_chart, locked)[:3]


def retriangulate_planar_checked(
    positions: np.ndarray,
    faces: np.ndarray,
    corner_uvs,
    face_chart: np.ndarray,
    locked: np.ndarray,
    close: bool = True,
):
    """:func:`retriangulate_planar` plus whether the open boundary of the surface kept its length
    (within 1e-9 relative): False when a slit or T-junction was closed that
    :func:`.slits.close_slits` leaves open (same surface, but edges that were open are shared
    now), so the result is not LOD0's mesh in every metric.

    Slits are closed first (:func:`exporter.mesh.slits.close_slits`; a slit is no part of the open
    boundary of the surface, see :func:`exporter.mesh.slits.open_boundary`): their vertices then lie
    on outlines between two regions, where the planar stage can drop them from both. ``close``
    False skips that (a level collapsed from one whose slits were closed has none: an edge
    collapse moves no vertex into another's edge)."""
    if not close:
        return _retriangulate_keeping_boundary(positions, faces, corner_uvs, face_chart, locked)
    closed, closed_uvs, closed_source = close_slits(positions, faces, corner_uvs)
    out_faces, out_uvs, source, kept = _retriangulate_keeping_boundary(
        positions, closed, closed_uvs, face_chart[closed_source], locked
    )
    if len(out_faces) >= len(faces) and len(closed) > len(faces):
        # Closing the slits split faces that no region could merge again: not worth it.
        return _retriangulate_keeping_boundary(positions, faces, corner_uvs, face_chart, locked)
    return out_faces, out_uvs, closed_source[source], kept


def _retriangulate_keeping_boundary(
    positions: np.ndarray, faces: np.ndarray, corner_uvs, face_chart: np.ndarray, locked: np.ndarray
):
    """:func:`retriangulate_planar_checked` without closing slits first: the planar stage keeps
    the open border's straight vertices where dropping them would change its length (first
    those inside a slit, then, if that is not enough, all)."""
    before = _boundary(positions, faces)
    m, k = len(faces), len(positions)
    if m == 0:
        return faces, corner_uvs, np.arange(m), True
    # One sort of the faces' edges for the regions and the straight vertices.
    edge_keys = sorted_edge_keys(faces, k)
    regions = planar_regions(positions, faces, face_chart, edge_keys)
    # Vertices inside one region (off the open border) go; so do straight outline vertices.
    # Faces of every region, ascending (one stable counting sort instead of a scan per region).
    one_region, used, by_region, region_start = _planar_batch.spans(
        faces, regions, int(regions.max()) + 1, k
    )
    border = border_vertices(faces, k)
    interior = one_region & ~border & ~locked
    straight = straight_vertices(
        positions, faces, regions, locked, on_border=True, edge_keys=edge_keys
    )
    done: dict = {}  # both passes share the regions their different border choice does not touch
    droppable = (interior | straight) & used
    # Droppable vertices only ever become fewer (failures keep theirs; the second pass drops a
    # subset), so only regions holding one now are ever redone: the setup is theirs only.
    faces_by_region = faces[by_region]
    held = _planar_batch.held(droppable, faces_by_region, region_start)
    candidates = np.flatnonzero(held).tolist()
    members = [by_region[region_start[r] : region_start[r + 1]] for r in candidates]
    setup = region_setup(positions, faces, corner_uvs, members) if members else None
    slot = {region: i for i, region in enumerate(candidates)}
    result = _retriangulate_regions(
        positions,
        faces,
        corner_uvs,
        regions,
        droppable,
        done,
        by_region,
        region_start,
        setup,
        slot,
    )
    length = _boundary(positions, result[0])
    # A slit closed: keep the straight border vertices inside a slit, then, if the boundary
    # still changes, every straight border vertex (straight_vertices(on_border=False)).
    fallbacks = [lambda: straight & ~slit_vertices(positions, faces), lambda: straight & ~border]
    while abs(length - before) > 1e-9 * max(before, 1.0) and fallbacks:
        result = _retriangulate_regions(
            positions,
            faces,
            corner_uvs,
            regions,
            (interior | fallbacks.pop(0)()) & used,
            done,
            by_region,
            region_start,
            setup,
            slot,
        )
        length = _boundary(positions, result[0])
    return (*result, abs(length - before) <= 1e-9 * max(before, 1.0))


def _retriangulate_regions(
    positions,
    faces,
    corner_uvs,
    regions,
    droppable,
    done: dict,
    by_region,
    region_start,
    setup,
    slot: dict,
):
    """One pass of :func:`retriangulate_planar` with the vertices ``droppable`` (k,) bool (changed
    in place where a region fails). ``done``: region -> (droppable bits of its corners, result),
    reused when the bits are the same; ``by_region`` / ``region_start``: faces of region r are
    ``by_region[region_start[r]:region_start[r + 1]]``; ``setup``: :func:`region_setup` of the
    regions that can be redone (or None: one region at a time), region r at ``slot[r]``."""
    m = len(faces)
    faces_by_region = faces[by_region]
    bounds = region_start.tolist()

    def drop_state() -> tuple[np.ndarray, list]:
        """The droppable bits (m, 3) of the faces in region order and the regions holding one."""
        held = _planar_batch.held(droppable, faces_by_region, region_start)
        return droppable[faces_by_region], np.flatnonzero(held).tolist()

    # Every region holding a droppable vertex is redone; a region that cannot be done exactly
    # keeps its vertices, so its neighbours must keep them too: repeat until consistent.
    for _ in range(8):
        bits, candidates = drop_state()
        keys = [bits[bounds[region] : bounds[region + 1]].tobytes() for region in candidates]
        # All regions not cached are done in one batch with this round's droppable bits; regions
        # whose bits a failure earlier in the round changed are redone below, in one batch too.
        todo = [
            i
            for i, region in enumerate(candidates)
            if not (region in done and done[region][0] == keys[i])
        ]
        if todo:
            batch = _retriangulate_many(
                positions,
                faces,
                corner_uvs,
                [by_region[bounds[candidates[i]] : bounds[candidates[i] + 1]] for i in todo],
                droppable,
                setup,
                [slot[candidates[i]] for i in todo],
            )
            for i, result in zip(todo, batch):
                done[candidates[i]] = (keys[i], result)
        results: dict = {}
        failed = False
        for index, (region, key) in enumerate(zip(candidates, keys)):
            if failed:
                key = bits[bounds[region] : bounds[region + 1]].tobytes()
            if not (region in done and done[region][0] == key):
                # A failure earlier in this pass changed this region's bits: redo it together with
                # every later region and every next-round candidate whose bits changed too (results
                # depend on the bits only, so whatever is computed ahead is reused or ignored).
                later = sorted(set(candidates[index:]) | set(drop_state()[1]))
                bits_of = [bits[bounds[r] : bounds[r + 1]].tobytes() for r in later]
                stale = [
                    i for i, r in enumerate(later) if not (r in done and done[r][0] == bits_of[i])
                ]
                redone = _retriangulate_many(
                    positions,
                    faces,
                    corner_uvs,
                    [by_region[bounds[later[i]] : bounds[later[i] + 1]] for i in stale],
                    droppable,
                    setup,
                    [slot[later[i]] for i in stale],
                )
                for i, result in zip(stale, redone):
                    done[later[i]] = (bits_of[i], result)
            result = done[region][1]
            if result is None:
                droppable[faces_by_region[bounds[region] : bounds[region + 1]].reshape(-1)] = False
                bits = droppable[faces_by_region]
                failed = True
            else:
                results[region] = result
        if not failed:
            break
    else:
        results = {}
    if not results:
        return faces, corner_uvs, np.arange(m)
    redone_regions = list(results)
    kept = np.ones(len(bounds) - 1, dtype=bool)
    kept[redone_regions] = False
    keep = kept[regions]
    tris = [results[r][0] for r in redone_regions]
    out_faces = np.concatenate([faces[keep]] + tris)
    out_uvs = None
    if corner_uvs is not None:
        out_uvs = np.concatenate([corner_uvs[keep]] + [results[r][1] for r in redone_regions])
    # Every new face's source: its region's first face.
    source = np.repeat(by_region[region_start[redone_regions]], [len(t) for t in tris])
    return out_faces, out_uvs, np.concatenate([np.flatnonzero(keep), source])
