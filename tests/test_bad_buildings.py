"""Bad building input through the whole export (issue 13): degenerate, non-manifold,
self-overlapping and zero-area meshes, a single triangle and a single flat polygon. Each either
comes through with an honest, certified ``hausdorff_rel`` (checked against the independent dense
measurement of tests/hausdorff_check.py on the exported levels) or is reported in the manifest;
none stops the tile.

Models are OBJ files (y up, metres) indexed by a ``buildings.csv`` (the folder reader)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pygltflib

from exporter.cli import main
from tests.hausdorff_check import dense_hausdorff

LON, LAT = 126.978, 37.5665


def obj(path: Path, vertices, faces) -> None:
    lines = [f"v {x} {y} {z}" for x, y, z in vertices]
    lines += ["f " + " ".join(str(i + 1) for i in face) for face in faces]
    path.write_text("\n".join(lines) + "\n")


def box(x0=0.0, z0=0.0, w=6.0, d=4.0, h=9.0):
    """A floorless box (walls and roof, outward, y up): vertices and faces."""
    v = [
        [x0, 0, z0], [x0 + w, 0, z0], [x0 + w, 0, z0 + d], [x0, 0, z0 + d],
        [x0, h, z0], [x0 + w, h, z0], [x0 + w, h, z0 + d], [x0, h, z0 + d],
    ]  # fmt: skip
    f = [
        [0, 1, 5], [0, 5, 4], [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7],
        [4, 5, 6], [4, 6, 7],
    ]  # fmt: skip
    return v, f


def bad_tile(folder: Path) -> None:
    folder.mkdir()
    models = {}
    models["single"] = ([[0, 0, 0], [4, 0, 0], [0, 3, 0]], [[0, 1, 2]])
    ring = [[5 * np.cos(a), 0.0, 5 * np.sin(a)] for a in np.linspace(0, 2 * np.pi, 13)[:-1]]
    models["flat_polygon"] = (ring, [[0, i, i + 1] for i in range(1, 11)])
    v, f = box()
    # The roof drawn twice (coincident faces) and a second wall overlapping the first.
    overlap_faces = f + [[4, 5, 6], [4, 6, 7], [0, 1, 5]]
    models["self_overlapping"] = (v, overlap_faces)
    # A third face on a roof edge (non-manifold), a repeated index and a duplicate vertex.
    nm_v = v + [[3.0, 12.0, 2.0], [0, 0, 0]]
    models["non_manifold"] = (nm_v, f + [[4, 6, 8], [0, 0, 1], [9, 1, 5]])
    models["zero_area"] = ([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]], [[0, 1, 2], [1, 2, 3]])
    rows = []
    for i, (name, (vertices, faces)) in enumerate(models.items()):
        obj(folder / f"{name}.obj", vertices, faces)
        rows.append(f"{name}.obj,{LON + i * 1e-4},{LAT},0,y,{name}")
    (folder / "buildings.csv").write_text("file,lon,lat,elev,up_axis,id\n" + "\n".join(rows) + "\n")


def glb_mesh(path: Path):
    """(positions (k, 3), faces (m, 3)) of every primitive of a written level, joined."""
    gltf = pygltflib.GLTF2().load_binary(str(path))
    blob = gltf.binary_blob()
    positions, faces, offset = [], [], 0
    for mesh in gltf.meshes:
        for primitive in mesh.primitives:

            def read(index, dtype, width):
                accessor = gltf.accessors[index]
                view = gltf.bufferViews[accessor.bufferView]
                start = view.byteOffset + (accessor.byteOffset or 0)
                count = accessor.count * width
                return np.frombuffer(blob, dtype, count, start).reshape(-1, width)

            p = read(primitive.attributes.POSITION, np.float32, 3).astype(np.float64)
            kind = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32}
            i = read(primitive.indices, kind[gltf.accessors[primitive.indices].componentType], 1)
            positions.append(p)
            faces.append(i.reshape(-1, 3).astype(np.int64) + offset)
            offset += len(p)
    if not positions:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    return np.concatenate(positions), np.concatenate(faces)


def test_bad_buildings_come_through_bounded_or_reported(tmp_path):
    tile = tmp_path / "tile"
    bad_tile(tile)
    out = tmp_path / "out"
    assert main(["export", str(tile), "--out", str(out), "--jobs", "1", "--quiet"]) == 0
    manifests = list(out.glob("*/lod_manifest.json"))
    buildings, skipped = {}, {}
    for path in manifests:
        manifest = json.loads(path.read_text())
        buildings.update({b["id"]: (path.parent, b) for b in manifest["buildings"]})
        skipped.update({s["id"]: s for s in manifest.get("skipped", [])})
    # Nothing is lost silently: every building is exported or skipped with a reason.
    names = {"single", "flat_polygon", "self_overlapping", "non_manifold", "zero_area"}
    assert set(buildings) | set(skipped) == names
    assert "zero_area" in skipped and skipped["zero_area"]["reason"]
    assert {"single", "flat_polygon", "self_overlapping", "non_manifold"} <= set(buildings)
    for name, (folder, record) in buildings.items():
        source = glb_mesh(folder / record["lods"][0]["file"])
        diagonal = float(np.linalg.norm(np.ptp(source[0], axis=0)))
        for lod in record["lods"][1:]:
            rel = lod["quality"]["hausdorff_rel"]
            assert np.isfinite(rel) and rel >= 0, (name, lod)
            level = glb_mesh(folder / lod["file"])
            dense = dense_hausdorff(source, level, 8) / diagonal
            # float32 vertices in the files: a few 1e-7 of the diagonal of rounding.
            assert dense <= rel + 1e-6, (name, lod["file"], dense, rel)
