"""Fast paths of the read and write stages equal their plain formulations bit for bit.

- GLB: :func:`exporter.gltf_writer.glb_bytes` (plain dicts, ``json.dumps``) equals the document
  built from pygltflib's dataclasses and written by its ``save_to_bytes``
  (``tests/gltf_reference.py``), names empty or not ASCII included.
- VWorld reader: the frame computed once per building equals ``global_to_local`` /
  ``local_to_global``; the winding vote's cross product equals ``np.cross``; non-finite normals
  are still cleaned by ``nan_to_num``.
"""

import dataclasses

import numpy as np
import pytest
from gltf_reference import reference_glb_bytes, reference_gltf_arrays

import exporter.gltf_writer as gltf_writer
from exporter.config import ReaderOptions
from exporter.formats.vworld_binary import parse_xdo, serialise_xdo
from exporter.mesh.geometry import unit_vectors
from exporter.model import Part
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


# --------------------------------------------------------------------------- GLB


def test_generated_buildings_glb_equal_pygltflib_save_to_bytes(buildings):
    _, loaded = buildings
    assert len(loaded) >= 6 and any(len(b.parts) > 1 for b in loaded)
    for i, building in enumerate(loaded):
        name = f"B{i}_LOD0"
        assert gltf_writer.glb_bytes(building.parts, name) == reference_glb_bytes(
            building.parts, name
        )


@pytest.mark.parametrize("name", ["", 'Bâtiment 건물 "quoted"', "B1_LOD2"])
def test_names_empty_or_not_ascii_equal_pygltflib(buildings, name):
    _, loaded = buildings
    parts = [
        dataclasses.replace(part, name=name if i else "")
        for i, part in enumerate(loaded[0].parts + loaded[1].parts)
    ]
    assert gltf_writer.glb_bytes(parts, name) == reference_glb_bytes(parts, name)


def test_non_finite_positions_fail_as_in_pygltflib(buildings):
    _, loaded = buildings
    part = loaded[0].parts[0]
    positions = np.array(part.positions, dtype=np.float64)
    positions[0, 1] = np.nan
    broken = [dataclasses.replace(part, positions=positions)]
    with pytest.raises(ValueError):
        reference_glb_bytes(broken, "B")
    with pytest.raises(ValueError):
        gltf_writer.glb_bytes(broken, "B")


def test_blob_pieces_are_the_aligned_binary_chunk():
    blob = gltf_writer._Blob()
    offsets = [blob.append(b"abc"), blob.append(b"de"), blob.append(b"fghij")]
    blob.align()
    assert offsets == [0, 4, 8] and len(blob) == 16
    assert bytes(blob) == b"abc\0de\0\0fghij\0\0\0"


def assert_same_arrays(part):
    fast, reference = gltf_writer.gltf_arrays(part), reference_gltf_arrays(part)
    assert fast[3] == reference[3]
    for got, expected in zip(fast[:3], reference[:3]):
        assert got.dtype == expected.dtype and got.shape == expected.shape
        assert got.tobytes() == expected.tobytes()  # the same bits, signed zeros included


@pytest.mark.parametrize("normal_dtype", [np.float32, np.float64])
def test_gltf_arrays_kernel_is_the_numpy_formulation(normal_dtype):
    """The C kernel against numpy: normals of every scale, zero, tiny (<= 1e-12), inf and NaN rows
    (up), zeros of both signs, float32 and float64 normals, int32 triangles."""
    rng = np.random.default_rng(24)
    n = 4000
    positions = rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-3, 6, size=(n, 1))
    positions[:5] = [
        [0.0, -0.0, 1.0],
        [-0.0, 0.0, -0.0],
        [1e-30, 3e38, -7.5],
        [1.0, 2.0, 3.0],
        [0, 0, 0],
    ]
    normals = (rng.normal(size=(n, 3)) * 10.0 ** rng.integers(-14, 8, size=(n, 1))).astype(
        normal_dtype
    )
    normals[:8] = [
        [0, 0, 0],
        [-0.0, 0, 0],
        [1e-13, 0, 0],
        [np.inf, 0, 0],
        [np.nan, 1, 0],
        [0, -0.0, 2],
        [-3, 0, 0],
        [0, 0, -1e-7],
    ]
    triangles = rng.integers(0, n, size=(3000, 3)).astype(np.int32)
    assert_same_arrays(Part(positions=positions, triangles=triangles, normals=normals))
    # no normals of its own: area-weighted ones of its triangles
    assert_same_arrays(Part(positions=positions, triangles=triangles[:, ::-1]))


def test_gltf_arrays_kernel_wide_indices_and_strided_inputs():
    rng = np.random.default_rng(25)
    n = 70000  # past 65535 vertices: uint32 indices
    positions = np.asfortranarray(rng.normal(size=(n, 3)) * 100.0)
    normals = rng.normal(size=(n, 6)).astype(np.float32)[:, ::2]  # not contiguous
    triangles = rng.integers(0, n, size=(5000, 3))
    assert_same_arrays(Part(positions=positions, triangles=triangles, normals=normals))
    small = Part(positions=positions[:65535], triangles=triangles % 65535, normals=normals[:65535])
    assert gltf_writer.gltf_arrays(small)[2].dtype == np.uint16
    assert_same_arrays(small)


def test_position_bounds_are_numpys_max_and_min():
    """The C pass gives numpy's column extremes (JSON text compared: signed zeros included); a NaN
    wins as in numpy; no rows is numpy's ValueError."""
    rng = np.random.default_rng(26)
    cases = [rng.normal(size=(n, 3)).astype(np.float32) * 100 for n in (1, 2, 5, 1000)]
    signed = np.array([[0.0, -0.0, 1.0], [-0.0, 0.0, -1.0], [-2.0, -0.0, 0.0]], np.float32)
    cases += [signed, signed[::-1].copy(), -signed, np.full((4, 3), 7.5, np.float32)]
    with_nan = cases[3].copy()
    with_nan[500, 1] = np.nan
    cases.append(with_nan)
    for positions in cases:
        expected = (positions.max(axis=0).tolist(), positions.min(axis=0).tolist())
        assert repr(gltf_writer.position_bounds(positions)) == repr(expected)
    with pytest.raises(ValueError):
        gltf_writer.position_bounds(np.zeros((0, 3), np.float32))


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
