"""Fast paths of the read and write stages equal their plain formulations bit for bit.

- GLB: :func:`exporter.gltf_writer._gltf_json` (``json.dumps`` walking the pygltflib dataclasses
  through a pruning ``default``) equals pygltflib's own ``gltf_to_json``; the container equals
  pygltflib's ``save_to_bytes``; documents the fast path does not cover take the generic one.
- VWorld reader: the frame computed once per building equals ``global_to_local`` /
  ``local_to_global``; the winding vote's cross product equals ``np.cross``; non-finite normals
  are still cleaned by ``nan_to_num``.
"""

import json

import numpy as np
import pygltflib
import pytest

import exporter.gltf_writer as gltf_writer
from exporter.config import ReaderOptions
from exporter.formats.vworld_binary import parse_xdo, serialise_xdo
from exporter.mesh.geometry import unit_vectors
from exporter.readers import vworld
from exporter.samplegen import generate_tile


@pytest.fixture(scope="module")
def tile(tmp_path_factory):
    """A small generated VWorld tile (two-part buildings included, 64 px atlases)."""
    return generate_tile(
        tmp_path_factory.mktemp("tile"), count=6, seed=2, atlas_size=64, two_part_share=0.5
    )


@pytest.fixture(scope="module")
def buildings(tile):
    scan = vworld.scan(tile, ReaderOptions())
    return scan, [vworld.load(entry, ReaderOptions()) for entry in scan.entries]


def pygltflib_json(gltf):
    return gltf.gltf_to_json(separators=(",", ":"), indent=None)


def pygltflib_glb(gltf, blob):
    gltf.set_binary_blob(bytes(blob))
    return b"".join(gltf.save_to_bytes())


def documents(parts_list, monkeypatch):
    """The (GLTF2, blob) pairs glb_bytes hands to ``_glb`` for each list of parts."""
    seen = []
    real = gltf_writer._glb
    monkeypatch.setattr(
        gltf_writer, "_glb", lambda gltf, blob: seen.append((gltf, blob)) or real(gltf, blob)
    )
    outputs = [gltf_writer.glb_bytes(parts, f"B{i}_LOD0") for i, parts in enumerate(parts_list)]
    monkeypatch.setattr(gltf_writer, "_glb", real)
    return outputs, seen


# --------------------------------------------------------------------------- GLB


def test_generated_buildings_glb_equal_pygltflib_save_to_bytes(buildings, monkeypatch):
    _, loaded = buildings
    outputs, seen = documents([b.parts for b in loaded], monkeypatch)
    assert len(seen) == len(loaded) >= 6 and any(len(b.parts) > 1 for b in loaded)
    for data, (gltf, blob) in zip(outputs, seen):
        # The fast path itself covers these documents (no fallback), and agrees with pygltflib.
        fast = json.dumps(
            gltf, allow_nan=False, separators=(",", ":"), default=gltf_writer._pruned_fields
        )
        assert fast == pygltflib_json(gltf)
        assert data == pygltflib_glb(gltf, blob)


def unusual_documents():
    """Documents with what glb_bytes never makes: each exercises a pruning rule of pygltflib."""

    def base():
        gltf = pygltflib.GLTF2(asset=pygltflib.Asset(version="2.0", generator="t"))
        gltf.nodes.append(
            pygltflib.Node(name="Bâtiment 건물", mesh=0, translation=[np.float64(1.5), 0.0, -2.0])
        )
        gltf.meshes.append(
            pygltflib.Mesh(
                primitives=[pygltflib.Primitive(attributes=pygltflib.Attributes(POSITION=0))]
            )
        )
        gltf.scenes.append(pygltflib.Scene(name="", nodes=[0]))
        gltf.scene = 0
        return gltf

    plain = base()
    extras = base()
    extras.nodes[0].extras = {"keep": 1, "drop": None, "nested": {"gone": []}}
    extensions = base()
    extensions.extensions = {"EXT_x": {"kept": None}}
    custom = base()
    custom.meshes[0].primitives[0].attributes._CUSTOM = 3  # Attributes may carry custom semantics
    extra_attribute = base()
    extra_attribute.nodes[0].not_a_field = "left out as asdict leaves it out"
    nested = base()
    nested.extras = {"rows": [[{"a": None}], []]}
    targets = base()
    targets.meshes[0].primitives[0].targets = [pygltflib.Attributes(POSITION=1)]
    emptied = base()
    emptied.meshes[0].primitives[0].attributes.__dict__.clear()  # converts to {}: pruned
    extension_object = base()
    extension_object.nodes[0].extensions = pygltflib.Asset(version="x")  # converted, left unpruned
    return {
        "plain": plain,
        "extras": extras,
        "extensions": extensions,
        "custom": custom,
        "extra_attribute": extra_attribute,
        "nested": nested,
        "targets": targets,
        "emptied": emptied,
        "extension_object": extension_object,
    }


@pytest.mark.parametrize("name", sorted(unusual_documents()))
def test_unusual_documents_equal_pygltflib_json(name):
    gltf = unusual_documents()[name]
    assert gltf_writer._gltf_json(gltf) == pygltflib_json(gltf)


def test_fast_path_refuses_what_it_could_prune_differently():
    documents_ = unusual_documents()
    for name in ("plain", "custom", "extra_attribute", "targets", "emptied"):
        json.dumps(
            documents_[name], separators=(",", ":"), default=gltf_writer._pruned_fields
        )  # covered
    for name in ("extras", "extensions", "nested", "extension_object"):
        with pytest.raises(gltf_writer._Unusual):
            json.dumps(documents_[name], separators=(",", ":"), default=gltf_writer._pruned_fields)


def test_non_json_values_fail_as_in_pygltflib():
    gltf = unusual_documents()["plain"]
    gltf.nodes[0].scale = [
        np.float32(1.0)
    ] * 3  # not a float subclass: pygltflib's json_serial refuses it
    with pytest.raises(TypeError):
        pygltflib_json(gltf)
    with pytest.raises(TypeError):
        gltf_writer._gltf_json(gltf)
    gltf.nodes[0].scale = [float("nan")] * 3
    with pytest.raises(ValueError):
        gltf_writer._gltf_json(gltf)


def test_blob_pieces_are_the_aligned_binary_chunk():
    blob = gltf_writer._Blob()
    offsets = [blob.append(b"abc"), blob.append(b"de"), blob.append(b"fghij")]
    blob.align()
    assert offsets == [0, 4, 8] and len(blob) == 16
    assert bytes(blob) == b"abc\0de\0\0fghij\0\0\0"


# --------------------------------------------------------------------------- VWorld reader


def test_cross_rows_is_numpy_cross():
    rng = np.random.default_rng(8)
    u, v = rng.normal(size=(500, 3)) * 1e3, rng.normal(size=(500, 3))
    u[0, 0], v[1, 2] = np.inf, np.nan
    assert np.array_equal(vworld.cross_rows(u, v), np.cross(u, v), equal_nan=True)


def test_winding_votes_equal_the_np_cross_formulation(buildings):
    _, loaded = buildings
    rng = np.random.default_rng(9)
    for part in (p for b in loaded for p in b.parts):
        directions = rng.normal(size=part.positions.shape)
        a, b, c = (part.positions[part.triangles[:, k]] for k in range(3))
        dots = np.einsum("ij,ij->i", np.cross(b - a, c - a), directions[part.triangles].sum(axis=1))
        assert vworld.winding_votes(part.positions, part.triangles, directions) == (
            int((dots > 0).sum()),
            int((dots < 0).sum()),
        )


def test_loaded_frame_equals_global_to_local_and_back(buildings, tile):
    scan, loaded = buildings
    for entry, building in zip(scan.entries, loaded):
        xdo = parse_xdo((tile / entry.source).read_bytes(), entry.source)
        reference = building.reference
        center_local = vworld.global_to_local(xdo.bbox_center[None, :], reference)[0]
        rotation = vworld.enu_rotation(reference.lon, reference.lat)
        for mesh, part in zip(xdo.meshes, building.parts):
            assert np.array_equal(
                part.positions, mesh.positions.astype(np.float64) @ rotation.T + center_local
            )
        everything = np.concatenate([p.positions for p in building.parts])
        lon, lat = vworld.lonlat_of(vworld.local_to_global(everything, reference))
        assert building.lonlat_bounds == (
            float(lon.min()),
            float(lat.min()),
            float(lon.max()),
            float(lat.max()),
        )


@pytest.mark.filterwarnings("ignore:overflow encountered")
def test_non_finite_normals_are_cleaned_as_nan_to_num(buildings, tile, tmp_path):
    scan, loaded = buildings
    entry = scan.entries[0]
    xdo = parse_xdo((tile / entry.source).read_bytes(), entry.source)
    xdo.meshes[0].vertices[0, 3:6] = (np.nan, 0.0, 1.0)  # nan_to_num: (0, 0, 1), a unit normal
    xdo.meshes[0].vertices[1, 3:6] = (-np.inf, 0.0, 0.0)  # nan_to_num: a huge finite value
    for path in tile.iterdir():
        (tmp_path / path.name).write_bytes(path.read_bytes())
    (tmp_path / entry.source.rsplit("/", 1)[-1]).write_bytes(serialise_xdo(xdo))
    moved = vworld.scan(tmp_path, ReaderOptions()).entries[0]
    building = vworld.load(moved, ReaderOptions())
    rotation = vworld.enu_rotation(building.reference.lon, building.reference.lat)
    expected = unit_vectors(np.nan_to_num(xdo.meshes[0].normals.astype(np.float64)) @ rotation.T)
    assert np.array_equal(building.parts[0].normals, expected.astype(np.float32))
    assert np.isfinite(building.parts[0].normals).all() and np.any(building.parts[0].normals[0])
