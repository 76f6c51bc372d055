"""Building kinds: VWorld-like floorless massing models, each drawn from a seed and a triangle budget.

Data form: a kind is a pair of pure functions, ``draw(rng, budget) -> dict`` (every random choice:
sizes in metres, floor counts, roof style) and ``build(params, cells, mb) -> list[ring]`` (the
geometry, deterministic given ``params`` and ``cells``, the number of wall-grid cells to spend),
which fills a :class:`~exporter.samplegen.mesh.MeshBuilder` and returns the footprint rings
((k, 2) CCW ``(x, z)`` metres in the building's local East/Up/North frame) that the open bottom
edges at y = 0 outline. Nothing has a bottom face: VWorld's building models are floorless.

Walls are cut into a grid of floors x window bays, as photogrammetric/modelled facades are; roof
slopes reuse the bay cuts of the wall below so the eave has no T-junctions. UV regions of the
atlas (glTF convention, v down): walls in :data:`FACADE`, roofs in :data:`ROOF`, parapets, rooftop
units, domes and spires in :data:`DETAIL`.

Sources: the VWorld paper's description of its input (non-closed, floorless boundary models with
one texture atlas per building, mean 326.29 triangles per building in Seoul).
"""

from __future__ import annotations

import math

import numpy as np

from .mesh import (
    UP,
    MeshBuilder,
    cap,
    edge_normals,
    fan,
    grid_triangles,
    inset,
    orient,
    patch,
    ring_points,
    shares,
    steps,
    subdivide,
)

MARGIN = 0.01  # UV inset of each atlas region, so JPEG/mip bleeding stays inside the region
FACADE = (0.0 + MARGIN, 0.0 + MARGIN, 1.0 - MARGIN, 0.625 - MARGIN)
ROOF = (0.0 + MARGIN, 0.625 + MARGIN, 0.5 - MARGIN, 1.0 - MARGIN)
DETAIL = (0.5 + MARGIN, 0.625 + MARGIN, 1.0 - MARGIN, 1.0 - MARGIN)

MAX_PERIMETER = 150.0  # metres: about 45 x 30 m, so a level-15 tile (about 100 x 120 m) holds a few of the largest

KINDS = (
    "box_flat",
    "box_gable",
    "box_hip",
    "box_mansard",
    "l_shape",
    "u_shape",
    "t_shape",
    "tower",
    "dome",
    "spire",
)


# --------------------------------------------------------------------------- shared pieces


def rect_ring(cx: float, cz: float, width: float, depth: float) -> np.ndarray:
    """CCW ring (4, 2) of an axis-aligned rectangle centred at ``(cx, cz)``; width along x, depth along z (metres)."""
    w, d = width / 2, depth / 2
    return np.array([[cx - w, cz - d], [cx + w, cz - d], [cx + w, cz + d], [cx - w, cz + d]])


def circle_ring(
    cx: float, cz: float, radius: float, segments: int, phase: float = 0.0
) -> np.ndarray:
    """CCW ring (segments, 2) on a circle of ``radius`` metres."""
    angle = phase + 2 * math.pi * np.arange(segments) / segments
    return np.stack([cx + radius * np.cos(angle), cz + radius * np.sin(angle)], 1)


def edge_lengths(ring: np.ndarray) -> np.ndarray:
    """Length (k,) in metres of each edge ``ring[i] -> ring[i+1]``."""
    return np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)


def wall_grid(ring: np.ndarray, floors: int, cells: float) -> tuple[int, list[int]]:
    """Rows and per-edge bay cuts spending about ``cells`` grid cells; fewer rows than floors on tiny budgets."""
    n = len(ring)
    rows = int(np.clip(floors, 1, max(1, cells // n)))
    return rows, shares(round(cells / rows), edge_lengths(ring))


def walls(
    mb: MeshBuilder, ring: np.ndarray, cuts: list[int], y0: float, y1: float, rows: int
) -> None:
    """One facade grid per footprint edge, from height ``y0`` to ``y1`` metres, facing out of the ring.

    Each wall has its own vertices (u runs 0..1 across every wall: a UV seam at each corner).
    """
    nxt = np.roll(ring, -1, axis=0)
    normals = edge_normals(ring)
    heights = y0 + (y1 - y0) * steps(rows)
    u0, v0, u1, v1 = FACADE
    v = v1 - steps(rows) * (v1 - v0)
    positions, uvs, triangles, outward, offset = [], [], [], [], 0
    for a, b, n, cols in zip(ring, nxt, normals, cuts):
        s = steps(cols)
        grid = np.empty((rows + 1, cols + 1, 3))
        grid[:, :, 0] = a[0] + s * (b[0] - a[0])
        grid[:, :, 1] = heights[:, None]
        grid[:, :, 2] = a[1] + s * (b[1] - a[1])
        uv = np.empty((rows + 1, cols + 1, 2))
        uv[:, :, 0] = u0 + s * (u1 - u0)
        uv[:, :, 1] = v[:, None]
        positions.append(grid.reshape(-1, 3))
        uvs.append(uv.reshape(-1, 2))
        triangles.append(grid_triangles(rows, cols) + offset)
        outward.append(np.broadcast_to([n[0], 0.0, n[1]], (2 * rows * cols, 3)))
        offset += (rows + 1) * (cols + 1)
    points = np.vstack(positions)
    mb.add(
        (points, np.vstack(uvs), orient(points, np.vstack(triangles), np.vstack(outward))),
        "wall",
    )


def edge_runs(ring: np.ndarray, cuts: list[int]) -> list[np.ndarray]:
    """Per edge, its cut points including both corners ((cuts[i] + 1, 2) each)."""
    points = subdivide(ring, cuts)
    starts = np.concatenate([[0], np.cumsum(cuts)])
    closed = np.vstack([points, points[:1]])
    return [closed[s : s + c + 1] for s, c in zip(starts[:-1], cuts)]


def lift(points2: np.ndarray, y: float) -> np.ndarray:
    return np.column_stack([points2[:, 0], np.full(len(points2), y), points2[:, 1]])


# --------------------------------------------------------------------------- roofs


def flat_roof(
    mb: MeshBuilder, ring: np.ndarray, cuts: list[int], y: float, parapet: float, thickness: float
) -> np.ndarray:
    """Roof slab at ``y`` inside a parapet ``parapet`` m high and ``thickness`` m thick; returns the inner ring.

    The walls must already reach ``y + parapet``: the parapet's outer face is the facade.
    """
    if parapet <= 0:
        mb.add(cap(ring, y, ROOF), "roof")
        return ring
    inner_corners = inset(ring, thickness)
    top = y + parapet
    for run, n in zip(edge_runs(ring, cuts), edge_normals(ring)):
        run_in = inset_run(run, ring, thickness)
        mb.add(patch(np.stack([lift(run, top), lift(run_in, top)]), DETAIL, UP), "roof")
        mb.add(
            patch(
                np.stack([lift(run_in, y), lift(run_in, top)]),
                DETAIL,
                np.array([-n[0], 0.0, -n[1]]),
            ),
            "roof",
        )
    mb.add(cap(inner_corners, y, ROOF), "roof")
    return inner_corners


def inset_run(run: np.ndarray, ring: np.ndarray, distance: float) -> np.ndarray:
    """The cut points ``run`` of one edge moved inward like :func:`inset` moves the ring (mitred ends)."""
    moved = inset(ring, distance)
    start = int(np.argmin(np.linalg.norm(ring - run[0], axis=1)))
    end = (start + 1) % len(ring)
    s = steps(len(run) - 1)[:, None]
    return (1 - s) * moved[start] + s * moved[end]


def mansard_roof(
    mb: MeshBuilder, ring: np.ndarray, cuts: list[int], y: float, rise: float, depth: float
) -> None:
    """Steep lower slopes rising ``rise`` m while stepping ``depth`` m in, then a flat top."""
    for run, n in zip(edge_runs(ring, cuts), edge_normals(ring)):
        mb.add(
            patch(
                np.stack([lift(run, y), lift(inset_run(run, ring, depth), y + rise)]),
                ROOF,
                np.array([n[0], 0.5, n[1]]),
            ),
            "roof",
        )
    mb.add(cap(inset(ring, depth), y + rise, ROOF), "roof")


def pitched_roof(
    mb: MeshBuilder,
    width: float,
    depth: float,
    cuts: list[int],
    y: float,
    rise: float,
    hip: bool,
    rows: int,
) -> None:
    """Gable or hip roof over the centred rectangle ``width`` (x) x ``depth`` (z) metres, ridge along x.

    ``cuts`` are the wall cuts of :func:`rect_ring`'s edges (south, east, north, west). A hip roof
    whose ridge would be shorter than 0.5 m becomes a pyramid (spires).
    """
    w, d, top = width / 2, depth / 2, y + rise
    ridge = max(w - d, 0.0) if hip else w
    r0, r1 = np.array([-ridge, top, 0.0]), np.array([ridge, top, 0.0])
    runs = [
        lift(run, y) for run in edge_runs(rect_ring(0, 0, width, depth), cuts)
    ]  # south, east, north, west
    south, north = np.array([0.0, 1.0, -1.0]), np.array([0.0, 1.0, 1.0])
    if ridge > 0.25:
        mb.add(patch(_slope(runs[0], r0, r1, rows), ROOF, south), "roof")
        mb.add(patch(_slope(runs[2], r1, r0, rows), ROOF, north), "roof")
    else:
        r0 = r1 = (r0 + r1) / 2
        mb.add(fan(r0, runs[0], ROOF, south), "roof")
        mb.add(fan(r0, runs[2], ROOF, north), "roof")
    if hip:
        mb.add(fan(r1, runs[1], ROOF, np.array([1.0, 1.0, 0.0])), "roof")
        mb.add(fan(r0, runs[3], ROOF, np.array([-1.0, 1.0, 0.0])), "roof")
    else:  # gable ends are facade
        mb.add(fan(r1, runs[1], FACADE, np.array([1.0, 0.0, 0.0])), "wall")
        mb.add(fan(r0, runs[3], FACADE, np.array([-1.0, 0.0, 0.0])), "wall")


def _slope(eave: np.ndarray, r_start: np.ndarray, r_end: np.ndarray, rows: int) -> np.ndarray:
    """Grid points (rows+1, k, 3) from the eave polyline up to the ridge segment."""
    ridge = np.linspace(r_start, r_end, len(eave))
    t = steps(rows)[:, None, None]
    return (1 - t) * eave[None] + t * ridge[None]


# --------------------------------------------------------------------------- round parts


def cylinder(
    mb: MeshBuilder,
    cx: float,
    cz: float,
    radius: float,
    segments: int,
    y0: float,
    y1: float,
    rows: int,
    region=FACADE,
    group="wall",
) -> None:
    """Smooth round wall (open at both ends); the UV seam is a duplicated column at angle 0."""
    ring = circle_ring(cx, cz, radius, segments)
    ring = np.vstack([ring, ring[:1]])
    points = ring_points(ring, y0 + (y1 - y0) * steps(rows))
    centre = np.array([cx, 0.0, cz])
    mb.add(patch(points, region, lambda m: (m - centre) * [1.0, 0.0, 1.0]), group)


def dome(
    mb: MeshBuilder,
    cx: float,
    cz: float,
    radius: float,
    segments: int,
    y0: float,
    rings: int,
    height_ratio: float = 1.0,
) -> None:
    """Half UV-sphere (``height_ratio`` stretches it vertically) on the circle at ``y0``; pole closed by a fan."""
    polar = np.linspace(0.0, math.pi / 2, rings + 1)[:-1]
    angle = 2 * math.pi * np.arange(segments + 1) / segments
    points = np.empty((len(polar), segments + 1, 3))
    points[..., 0] = cx + radius * np.cos(polar)[:, None] * np.cos(angle)[None]
    points[..., 1] = y0 + height_ratio * radius * np.sin(polar)[:, None]
    points[..., 2] = cz + radius * np.cos(polar)[:, None] * np.sin(angle)[None]
    centre = np.array([cx, y0, cz])
    outward = lambda m: m - centre
    mb.add(patch(points, DETAIL, outward), "detail")
    apex = np.array([cx, y0 + height_ratio * radius, cz])
    mb.add(fan(apex, points[-1], DETAIL, outward), "detail")


def cone(
    mb: MeshBuilder,
    cx: float,
    cz: float,
    radius: float,
    segments: int,
    y0: float,
    height: float,
    rows: int,
) -> None:
    """Spire: rings shrinking to an apex ``height`` m above ``y0``; the last row is a fan."""
    ring = circle_ring(cx, cz, 1.0, segments)
    ring = np.vstack([ring, ring[:1]])
    t = steps(rows)[:-1]
    points = np.empty((len(t), segments + 1, 3))
    points[..., 0] = cx + (ring[:, 0] - cx)[None] * radius * (1 - t)[:, None]
    points[..., 1] = (y0 + height * t)[:, None]
    points[..., 2] = cz + (ring[:, 1] - cz)[None] * radius * (1 - t)[:, None]
    centre = np.array([cx, 0.0, cz])
    outward = lambda m: (m - centre) * [1.0, 0.0, 1.0]
    if len(t) > 1:
        mb.add(patch(points, DETAIL, outward), "detail")
    mb.add(fan([cx, y0 + height, cz], points[-1], DETAIL, outward), "detail")


def box(
    mb: MeshBuilder,
    cx: float,
    cz: float,
    width: float,
    depth: float,
    y0: float,
    height: float,
    group: str = "detail",
    region=DETAIL,
    rows: int = 1,
    cols: int = 1,
) -> None:
    """A floorless box (4 sides and a top) standing on ``y0``: rooftop units, stair houses, antennas."""
    ring = rect_ring(cx, cz, width, depth)
    walls_ = MeshBuilder()
    walls(walls_, ring, [cols] * 4, y0, y0 + height, rows)
    for primitive in zip(walls_.positions, walls_.uvs, walls_.triangles):
        mb.add((primitive[0], _remap(primitive[1], FACADE, region), primitive[2]), group)
    mb.add(cap(ring, y0 + height, region), group)


def _remap(uvs: np.ndarray, source: tuple, target: tuple) -> np.ndarray:
    s = (uvs - [source[0], source[1]]) / [source[2] - source[0], source[3] - source[1]]
    return s * [target[2] - target[0], target[3] - target[1]] + [target[0], target[1]]


def rooftop_details(
    mb: MeshBuilder, rng_values: np.ndarray, wings: list[tuple], y: float, keep_out: float
) -> None:
    """AC units, a stair house and an antenna on flat roofs, placed by pre-drawn uniforms ``rng_values`` (k, 5).

    ``wings`` are ``(x0, z0, width, depth)`` rectangles (metres) covering the roof; ``keep_out``
    (metres) keeps details off the parapet.
    """
    for i, (pick, fx, fz, size, height) in enumerate(rng_values):
        x0, z0, ww, dd = wings[int(pick * len(wings))]
        if i == 0:
            w, d, h = 2.5 + 1.5 * size, 3.0 + 2.0 * size, 2.6 + 0.6 * height  # stair house
        elif i == len(rng_values) - 1 and len(rng_values) > 2:
            w, d, h = 0.15, 0.15, 3.0 + 5.0 * height  # antenna
        else:
            w, d, h = 0.8 + 1.2 * size, 0.8 + 1.0 * size, 0.6 + 0.9 * height  # AC unit
        free_w, free_d = ww - 2 * keep_out - w, dd - 2 * keep_out - d
        if free_w <= 0 or free_d <= 0:
            continue
        box(
            mb, x0 + keep_out + w / 2 + fx * free_w, z0 + keep_out + d / 2 + fz * free_d, w, d, y, h
        )


# --------------------------------------------------------------------------- parameters shared by kinds


def common(
    rng: np.random.Generator, budget: float, floors_scale: tuple = (0.3, 0.8), max_floors: int = 50
) -> dict:
    """Floors, floor height (m), bay width (m) and facade perimeter (m) sized for ``budget`` triangles."""
    cells = 0.35 * budget
    floors = int(np.clip(round(math.sqrt(cells) * rng.uniform(*floors_scale)), 1, max_floors))
    bay = rng.uniform(2.6, 4.2)
    perimeter = float(np.clip(cells / floors * bay, 16.0, MAX_PERIMETER))
    # Big budgets beyond the largest footprint go into more floors (or, capped, narrower bays).
    floors = int(np.clip(round(cells * bay / perimeter), floors, max_floors))
    return {
        "floors": floors,
        "floor_height": rng.uniform(3.0, 3.8),
        "perimeter": perimeter,
        "details": rng.uniform(size=(int(rng.integers(1, 6)), 5)),
        "parapet": rng.uniform(0.6, 1.2) if rng.random() < 0.8 else 0.0,
        "slope_rows": int(rng.integers(1, 3)),
    }


def rect_dims(perimeter: float, aspect: float) -> tuple[float, float]:
    """Width >= depth (metres) of a rectangle with this perimeter and width/depth ``aspect``."""
    depth = perimeter / 2 / (1 + aspect)
    return aspect * depth, depth


# --------------------------------------------------------------------------- kinds


def draw_box(rng, budget, roof):
    p = common(rng, budget, max_floors=6 if roof in ("gable", "hip") else 50)
    p["roof"] = roof
    p["width"], p["depth"] = rect_dims(p["perimeter"], rng.uniform(1.0, 2.5))
    p["rise"] = (
        p["depth"] / 2 * rng.uniform(0.5, 1.1)
        if roof in ("gable", "hip")
        else rng.uniform(2.5, 4.0)
    )
    return p


def build_box(p, cells, mb):
    ring = rect_ring(0, 0, p["width"], p["depth"])
    h = p["floors"] * p["floor_height"]
    roof = p["roof"]
    rows, cuts = wall_grid(ring, p["floors"], cells)
    if roof == "flat":
        walls(mb, ring, cuts, 0.0, h + p["parapet"], rows)
        flat_roof(mb, ring, cuts, h, p["parapet"], 0.3)
        rooftop_details(
            mb, p["details"], [(-p["width"] / 2, -p["depth"] / 2, p["width"], p["depth"])], h, 0.6
        )
    elif roof == "mansard":
        walls(mb, ring, cuts, 0.0, h, rows)
        mansard_roof(mb, ring, cuts, h, p["rise"], min(1.2, 0.2 * p["depth"]))
    else:
        walls(mb, ring, cuts, 0.0, h, rows)
        pitched_roof(mb, p["width"], p["depth"], cuts, h, p["rise"], roof == "hip", p["slope_rows"])
    return [ring]


def draw_polygon(rng, budget, shape):
    p = common(rng, budget)
    p["shape"] = shape
    p["width"], p["depth"] = rect_dims(p["perimeter"] * 0.85, rng.uniform(1.0, 1.8))
    p["notch"] = rng.uniform(0.35, 0.6, size=2)  # share of width / depth removed
    p["roof"] = "mansard" if rng.random() < 0.3 else "flat"
    p["rise"] = rng.uniform(2.5, 4.0)
    return p


def polygon_outline(
    shape: str, width: float, depth: float, notch
) -> tuple[np.ndarray, list[tuple]]:
    """CCW ring and covering wings ``(x0, z0, w, d)`` of an L, U or T footprint, in metres from the SW corner."""
    W, D = width, depth
    nw, nd = notch[0] * W, notch[1] * D
    if shape == "l_shape":
        ring = [(0, 0), (W, 0), (W, D - nd), (W - nw, D - nd), (W - nw, D), (0, D)]
        wings = [(0, 0, W, D - nd), (0, D - nd, W - nw, nd)]
    elif shape == "u_shape":
        a = (W - nw) / 2
        ring = [(0, 0), (W, 0), (W, D), (W - a, D), (W - a, D - nd), (a, D - nd), (a, D), (0, D)]
        wings = [(0, 0, W, D - nd), (0, D - nd, a, nd), (W - a, D - nd, a, nd)]
    else:  # t_shape: a bar along the north side on a centred stem
        stem = W - nw
        s0, s1 = (W - stem) / 2, (W + stem) / 2
        ring = [
            (s0, 0),
            (s1, 0),
            (s1, D - nd),
            (W, D - nd),
            (W, D),
            (0, D),
            (0, D - nd),
            (s0, D - nd),
        ]
        wings = [(s0, 0, stem, D - nd), (0, D - nd, W, nd)]
    shift = np.array([W / 2, D / 2])
    return np.array(ring, float) - shift, [
        (x0 - shift[0], z0 - shift[1], w, d) for x0, z0, w, d in wings
    ]


def build_polygon(p, cells, mb):
    ring, wings = polygon_outline(p["shape"], p["width"], p["depth"], p["notch"])
    h = p["floors"] * p["floor_height"]
    rows, cuts = wall_grid(ring, p["floors"], cells)
    if p["roof"] == "mansard":
        walls(mb, ring, cuts, 0.0, h, rows)
        mansard_roof(mb, ring, cuts, h, p["rise"], min(1.0, 0.15 * min(w for _, _, w, _ in wings)))
    else:
        walls(mb, ring, cuts, 0.0, h + p["parapet"], rows)
        flat_roof(mb, ring, cuts, h, p["parapet"], 0.3)
        rooftop_details(mb, p["details"], wings, h, 0.6)
    return [ring]


def draw_tower(rng, budget):
    p = common(rng, budget, floors_scale=(0.7, 1.3), max_floors=60)
    p["floors"] = max(p["floors"], 4)
    p["segments"] = int(np.clip(round(math.sqrt(budget) * 0.9), 10, 40))
    p["radius"] = float(np.clip(p["perimeter"] / (2 * math.pi), 4.0, 18.0))
    p["top"] = ["cone", "dome", "flat"][int(rng.integers(3))]
    p["top_height"] = p["radius"] * rng.uniform(1.0, 2.5)
    return p


def build_tower(p, cells, mb):
    segs, r = p["segments"], p["radius"]
    h = p["floors"] * p["floor_height"]
    rows = int(np.clip(round(cells / segs), 1, 4 * p["floors"]))
    cylinder(mb, 0.0, 0.0, r, segs, 0.0, h, rows)
    top_rows = max(1, segs // 6)
    if p["top"] == "cone":
        cone(mb, 0.0, 0.0, r, segs, h, p["top_height"], top_rows)
    elif p["top"] == "dome":
        dome(mb, 0.0, 0.0, r, segs, h, top_rows, height_ratio=p["top_height"] / r / 2)
    else:
        mb.add(cap(circle_ring(0.0, 0.0, r, segs), h, ROOF), "roof")
        box(mb, 0.0, 0.0, 0.2, 0.2, h, p["top_height"])
    return [circle_ring(0.0, 0.0, r, segs)]


def draw_dome(rng, budget):
    p = common(rng, budget, floors_scale=(0.15, 0.3), max_floors=4)
    p["width"], p["depth"] = rect_dims(p["perimeter"] * 0.8, rng.uniform(1.0, 1.5))
    p["segments"] = int(np.clip(round(math.sqrt(budget) * 0.8), 8, 36))
    p["drum"] = rng.uniform(1.5, 4.0)
    p["parapet"] = max(p["parapet"], 0.6)
    return p


def build_dome(p, cells, mb):
    ring = rect_ring(0, 0, p["width"], p["depth"])
    h = p["floors"] * p["floor_height"]
    segs = p["segments"]
    radius = 0.35 * p["depth"]
    drum_rows = 1 if cells < 4 * segs else 2
    rows, cuts = wall_grid(ring, p["floors"], max(4.0, cells - drum_rows * segs))
    walls(mb, ring, cuts, 0.0, h + p["parapet"], rows)
    flat_roof(mb, ring, cuts, h, p["parapet"], 0.3)
    cylinder(mb, 0.0, 0.0, radius, segs, h, h + p["drum"], drum_rows)
    dome(mb, 0.0, 0.0, radius, segs, h + p["drum"], max(2, segs // 5))
    return [ring]


def draw_spire(rng, budget):
    p = common(rng, budget, floors_scale=(0.15, 0.3), max_floors=3)
    p["floor_height"] = rng.uniform(4.5, 7.0)
    p["width"], p["depth"] = rect_dims(p["perimeter"] * 0.8, rng.uniform(1.6, 2.6))
    p["rise"] = p["depth"] / 2 * rng.uniform(0.8, 1.3)
    p["tower_side"] = p["depth"] * rng.uniform(0.35, 0.5)
    p["tower_shift"] = p["depth"] * rng.uniform(-0.15, 0.15)
    p["tower_extra"] = rng.uniform(6.0, 15.0)
    p["spire"] = p["tower_side"] * rng.uniform(1.5, 3.0)
    return p


def build_spire(p, cells, mb):
    """A church: gable nave and, touching its west end, a square tower with a pyramid spire."""
    W, D, s = p["width"], p["depth"], p["tower_side"]
    h = p["floors"] * p["floor_height"]
    nave = rect_ring(0, 0, W, D)
    rows, cuts = wall_grid(nave, p["floors"], cells * 0.7)
    walls(mb, nave, cuts, 0.0, h, rows)
    pitched_roof(mb, W, D, cuts, h, p["rise"], False, p["slope_rows"])
    # The tower is built about its own centre then moved, so the pyramid code is reused.
    tower_h = h + p["rise"] + p["tower_extra"]
    cx, cz = -W / 2 - s / 2, p["tower_shift"]
    t_floors = max(1, round(tower_h / 3.5))
    t_rows, t_cuts = wall_grid(rect_ring(0, 0, s, s), t_floors, max(4.0, cells * 0.3))
    local = MeshBuilder()
    walls(local, rect_ring(0, 0, s, s), t_cuts, 0.0, tower_h, t_rows)
    pitched_roof(local, s, s, t_cuts, tower_h, p["spire"], True, 1)
    for positions, uvs, triangles, group in zip(
        local.positions, local.uvs, local.triangles, local.groups
    ):
        mb.add((positions + [cx, 0.0, cz], uvs, triangles), group)
    return [nave, rect_ring(cx, cz, s, s)]


DRAW = {
    "box_flat": lambda rng, b: draw_box(rng, b, "flat"),
    "box_gable": lambda rng, b: draw_box(rng, b, "gable"),
    "box_hip": lambda rng, b: draw_box(rng, b, "hip"),
    "box_mansard": lambda rng, b: draw_box(rng, b, "mansard"),
    "l_shape": lambda rng, b: draw_polygon(rng, b, "l_shape"),
    "u_shape": lambda rng, b: draw_polygon(rng, b, "u_shape"),
    "t_shape": lambda rng, b: draw_polygon(rng, b, "t_shape"),
    "tower": draw_tower,
    "dome": draw_dome,
    "spire": draw_spire,
}
BUILD = {
    "box_flat": build_box,
    "box_gable": build_box,
    "box_hip": build_box,
    "box_mansard": build_box,
    "l_shape": build_polygon,
    "u_shape": build_polygon,
    "t_shape": build_polygon,
    "tower": build_tower,
    "dome": build_dome,
    "spire": build_spire,
}


# Measured share cells / budget after fitting (median over 400 buildings): a first guess that
# usually lands within tolerance on the first or second build.
CELL_SHARE = {
    "box_flat": 0.31,
    "box_gable": 0.41,
    "box_hip": 0.415,
    "box_mansard": 0.41,
    "l_shape": 0.355,
    "u_shape": 0.35,
    "t_shape": 0.395,
    "tower": 0.42,
    "dome": 0.275,
    "spire": 0.37,
}


def fit_to_budget(
    kind: str, params: dict, budget: float, tries: int = 4, tolerance: float = 0.04
) -> tuple[MeshBuilder, list[np.ndarray]]:
    """Build ``kind`` choosing the wall-cell count whose triangle total comes closest to ``budget``.

    Each retry moves the cell count by the missing triangles / 2 (two triangles a cell).
    """
    cells, best = max(2.0, CELL_SHARE[kind] * budget), None
    for _ in range(tries):
        mb = MeshBuilder()
        rings = BUILD[kind](params, cells, mb)
        total = mb.triangle_count
        if best is None or abs(total - budget) < abs(best[0].triangle_count - budget):
            best = (mb, rings)
        if abs(total - budget) <= tolerance * budget:
            break
        cells = max(1.0, cells + (budget - total) / 2.0)
    assert best is not None  # tries >= 1
    return best
