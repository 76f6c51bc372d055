"""Crafted floorless test buildings for the simplifier and quality tests (and the benchmark fallback).

Every position is in the building-local East/Up/North frame, metres (y = Up); triangles wound so
``(b - a) x (c - a)`` points outward; UVs (glTF convention) are islands packed into one atlas, one
island per wall / roof face / dome, so every junction is a UV seam as in VWorld's models. No
building has a floor: the bottom is an open border (the footprint outline).
"""

from __future__ import annotations

import numpy as np

from exporter.model import Part, Texture

ATLAS = Texture(data=b"", mime="image/jpeg", width=1024, height=1024, name="atlas.jpg")
CLUTTER = Texture(data=b"", mime="image/jpeg", width=256, height=256, name="clutter.jpg")


class Atlas:
    """Hands out UV rectangles (u0, v0, u1, v1) from an 8 x 8 grid of cells."""

    def __init__(self, cells: int = 8) -> None:
        self.cells, self.used = cells, 0

    def rect(self) -> tuple:
        i = self.used % (self.cells * self.cells)
        self.used += 1
        size = 1.0 / self.cells
        u, v = (i % self.cells) * size, (i // self.cells) * size
        return (u + 0.05 * size, v + 0.05 * size, u + 0.95 * size, v + 0.95 * size)


class Builder:
    """Accumulates positions / triangles / uvs of one part."""

    def __init__(self) -> None:
        self.positions, self.triangles, self.uvs = [], [], []
        self.count = 0

    def add(self, positions, triangles, uvs) -> None:
        self.positions.append(np.asarray(positions, float))
        self.uvs.append(np.asarray(uvs, float))
        self.triangles.append(np.asarray(triangles, np.int64) + self.count)
        self.count += len(positions)

    def grid(self, origin, du, dv, nu: int, nv: int, rect: tuple) -> None:
        """A planar grid origin + s*du + t*dv (metres), outward = du x dv."""
        s, t = np.meshgrid(np.linspace(0, 1, nu + 1), np.linspace(0, 1, nv + 1))
        pos = (
            np.asarray(origin, float)
            + s.reshape(-1, 1) * np.asarray(du, float)
            + t.reshape(-1, 1) * np.asarray(dv, float)
        )
        u0, v0, u1, v1 = rect
        uvs = np.column_stack([u0 + s.reshape(-1) * (u1 - u0), v1 - t.reshape(-1) * (v1 - v0)])
        self.add(pos, _grid_triangles(nv, nu), uvs)

    def part(self, texture=ATLAS, name="") -> Part:
        return Part(
            positions=np.concatenate(self.positions),
            triangles=np.concatenate(self.triangles),
            uvs=np.concatenate(self.uvs),
            texture=texture,
            name=name,
        )


def _grid_triangles(rows: int, cols: int) -> np.ndarray:
    r, c = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    a = (r * (cols + 1) + c).ravel()
    b, d = a + 1, a + cols + 1
    return np.concatenate([np.stack([a, b, d + 1], 1), np.stack([a, d + 1, d], 1)])


def add_walls(builder: Builder, atlas: Atlas, x0, z0, x1, z1, y0, y1, nu: int, nv: int) -> None:
    """Four walls of the box [x0,x1] x [z0,z1] from y0 to y1 metres, counter-clockwise seen from above."""
    corners = [(x0, z0), (x1, z0), (x1, z1), (x0, z1)]
    for (ax, az), (bx, bz) in zip(corners, corners[1:] + corners[:1]):
        # Going counter-clockwise in (x, z) seen from +y... outward = du x dv with dv = up.
        du = np.array([ax - bx, 0.0, az - bz])
        builder.grid((bx, y0, bz), du, (0, y1 - y0, 0), nu, nv, atlas.rect())


def add_flat_roof(builder: Builder, atlas: Atlas, x0, z0, x1, z1, y, n: int) -> None:
    # outward +y = du x dv with du = +z, dv = +x
    builder.grid((x0, y, z0), (0, 0, z1 - z0), (x1 - x0, 0, 0), n, n, atlas.rect())


def add_gable(builder: Builder, atlas: Atlas, x0, z0, x1, z1, y, rise: float, n: int) -> None:
    """Gable roof with the ridge along x at z = (z0+z1)/2, plus the two triangular gable ends."""
    zm = 0.5 * (z0 + z1)
    start = len(builder.triangles)
    builder.grid((x0, y, z0), (x1 - x0, 0, 0), (0, rise, zm - z0), n, n, atlas.rect())
    builder.grid((x1, y, z1), (x0 - x1, 0, 0), (0, rise, zm - z1), n, n, atlas.rect())
    for x in (x0, x1):
        r = atlas.rect()
        builder.add(
            [(x, y, z0), (x, y, z1), (x, y + rise, zm)],
            [[0, 1, 2]],
            [(r[0], r[3]), (r[2], r[3]), (0.5 * (r[0] + r[2]), r[1])],
        )
    # Outward = away from the ridge-line axis (x, y, zm) below the roof.
    centre = np.array([0.5 * (x0 + x1), y - 1.0, zm])
    for i in range(start, len(builder.triangles)):
        pos = builder.positions[i]
        local = builder.triangles[i] - (builder.count - sum(len(q) for q in builder.positions[i:]))
        builder.triangles[i] = _orient(pos, local, lambda c: c - centre) + (
            builder.triangles[i] - local
        )


def add_dome(
    builder: Builder, atlas: Atlas, cx, cz, y, radius: float, rings: int, segments: int
) -> None:
    """Half UV sphere (open at the bottom, seam at longitude 0) on top of height y."""
    phi = np.linspace(0, 0.5 * np.pi, rings + 1)  # from the equator up
    theta = np.linspace(0, 2 * np.pi, segments + 1)  # seam column duplicated
    t, p = np.meshgrid(theta, phi)
    a = np.where(
        t == theta[-1], 0.0, t
    ).ravel()  # the seam column at exactly the first one's position
    ring = np.where(p == phi[-1], 0.0, np.cos(p)).ravel()  # one exact pole
    pos = np.column_stack(
        [
            cx + radius * ring * np.cos(a),
            y + radius * np.sin(p.ravel()),
            cz + radius * ring * np.sin(a),
        ]
    )
    r = atlas.rect()
    uvs = np.column_stack(
        [
            r[0] + (r[2] - r[0]) * t.ravel() / (2 * np.pi),
            r[3] - (r[3] - r[1]) * p.ravel() / (0.5 * np.pi),
        ]
    )
    tri = _grid_triangles(rings, segments)
    tri = _orient(pos, tri, lambda c: c - np.array([cx, y, cz]))
    builder.add(pos, tri, uvs)


def add_cylinder(
    builder: Builder, atlas: Atlas, cx, cz, y0, y1, radius, segments, rings=1, top=None
) -> None:
    """Open cylinder (or cone when ``top`` radius is given) around (cx, cz) from y0 to y1 metres."""
    top = radius if top is None else top
    theta = np.linspace(0, 2 * np.pi, segments + 1)
    h = np.linspace(0, 1, rings + 1)
    t, s = np.meshgrid(theta, h)
    rad = radius + (top - radius) * s
    a = np.where(
        t == theta[-1], 0.0, t
    ).ravel()  # the seam column at exactly the first one's position
    pos = np.column_stack(
        [
            cx + rad.ravel() * np.cos(a),
            np.where(s.ravel() == 1.0, y1, y0 + (y1 - y0) * s.ravel()),
            cz + rad.ravel() * np.sin(a),
        ]
    )
    r = atlas.rect()
    uvs = np.column_stack(
        [r[0] + (r[2] - r[0]) * t.ravel() / (2 * np.pi), r[3] - (r[3] - r[1]) * s.ravel()]
    )
    tri = _grid_triangles(rings, segments)
    tri = tri[np.ptp(pos[tri], axis=1).max(axis=1) > 1e-9]
    axis_point = lambda c: c - np.column_stack([np.full(len(c), cx), c[:, 1], np.full(len(c), cz)])
    builder.add(pos, _orient(pos, tri, axis_point), uvs)


def _orient(pos, tri, outward):
    a, b, c = (pos[tri[:, i]] for i in range(3))
    n = np.cross(b - a, c - a)
    d = outward(pos[tri].mean(axis=1))
    flip = np.einsum("ij,ij->i", n, d) < 0
    return np.where(flip[:, None], tri[:, ::-1], tri)


def box_building(half_x, half_z, height, wall_cuts, roof_cuts):
    """A floorless box centred on the origin (local East/Up/North metres), walls cut
    ``wall_cuts`` = (columns, rows), flat roof cut ``roof_cuts`` per side: one textured part."""
    builder, atlas = Builder(), Atlas()
    add_walls(builder, atlas, -half_x, -half_z, half_x, half_z, 0.0, height, *wall_cuts)
    add_flat_roof(builder, atlas, -half_x, -half_z, half_x, half_z, height, roof_cuts)
    return [builder.part()]


def crafted_building(seed: int) -> list[Part]:
    """A VWorld-like floorless building: walls (subdivided), a flat / gable / dome / spire top and
    rooftop clutter in a second part with its own texture; a few hundred triangles."""
    rng = np.random.default_rng(seed)
    atlas = Atlas()
    main = Builder()
    w, d = rng.uniform(8, 30), rng.uniform(8, 25)
    h = rng.uniform(6, 40)
    x0, z0, x1, z1 = -w / 2, -d / 2, w / 2, d / 2
    nu, nv = int(rng.integers(1, 5)), int(rng.integers(1, 6))
    add_walls(main, atlas, x0, z0, x1, z1, 0.0, h, nu, nv)
    kind = ("flat", "gable", "dome", "spire")[seed % 4]
    parts = []
    if kind == "gable":
        add_gable(main, atlas, x0, z0, x1, z1, h, rng.uniform(2, 6), int(rng.integers(2, 5)))
    else:
        add_flat_roof(main, atlas, x0, z0, x1, z1, h, int(rng.integers(2, 6)))
        if kind == "dome":
            radius = 0.35 * min(w, d)
            add_cylinder(main, atlas, 0.0, 0.0, h, h + 2.0, radius, 16)
            add_dome(main, atlas, 0.0, 0.0, h + 2.0, radius, 6, 16)
        elif kind == "spire":
            add_cylinder(
                main, atlas, 0.0, 0.0, h, h + 0.6 * h, 0.2 * min(w, d), 12, rings=3, top=0.01
            )
    parts.append(main.part(ATLAS, "main"))
    clutter = Builder()
    catlas = Atlas(4)
    for _ in range(int(rng.integers(1, 4))):
        cx, cz = rng.uniform(x0 + 2, x1 - 2), rng.uniform(z0 + 2, z1 - 2)
        s = rng.uniform(0.5, 1.5)
        yb = h if kind != "gable" else h + 0.2
        top = yb + rng.uniform(1, 3)
        add_walls(clutter, catlas, cx - s, cz - s, cx + s, cz + s, yb, top, 1, 1)
        add_flat_roof(clutter, catlas, cx - s, cz - s, cx + s, cz + s, top, 1)
    parts.append(clutter.part(CLUTTER, "clutter"))
    return parts


def test_crafted_buildings_are_floorless_and_outward():
    import trimesh

    for seed in range(8):
        parts = crafted_building(seed)
        for part in parts:
            mesh = trimesh.Trimesh(part.positions, part.triangles, process=False)
            assert mesh.area > 0
            normals = mesh.face_normals
            # No face looks down: floorless, and walls / roofs face out or up.
            assert (normals[:, 1] > -1e-6).all(), seed
