"""Write ``OUT/tileset.json`` (3D Tiles 1.1, glTF content) and each building tile's own
``OUT/<tile>/tileset.json`` (an external tileset, :func:`tile_tileset_json`) from a finished
:mod:`.tree`.

Bounding volumes are boxes in each node's tile frame, axis-aligned there, around the corners of
its content's box and of its children's boxes (so they contain both); a node's ``transform`` is
its frame relative to its parent's (3D Tiles composes them from the root down). A node without
content gets ``geometricError`` = the larger of its box's diagonal and its children's errors
(refined as soon as it is in view); every error is at least its children's. The tileset's own
``geometricError`` (the error of drawing nothing: clients draw nothing while it is small on
screen) is at least the root's box diagonal. A tile's own tileset has no transform at its root:
3D Tiles composes an external tileset's transforms onto the referencing tile's frame, the
tile's (:func:`.tree.tileset_reference`); its content URIs are relative to its folder. The bytes depend
only on the tree (sorted, no times), written atomically after everything it references.
"""

from __future__ import annotations

import json
from pathlib import Path
from urllib.parse import quote

import numpy as np

from .. import __version__
from ..atomic import write_bytes_atomic
from ..model import TileId
from . import frames
from .metadata import add_metadata, schema
from .tree import BuildingChain, Node, building_nodes, tile_world

TILESET_NAME = "tileset.json"


def finish(node: Node, parent_world: np.ndarray, parent_inverse: np.ndarray) -> np.ndarray:
    """Fill ``node.box`` (in its frame) and ``node.error`` bottom-up; returns the (8, 3) ECEF
    corners of its box. ``parent_inverse``: ECEF -> ``parent_world``'s frame (computed once per
    frame). Building chains must be done first (:func:`finish_chains`)."""
    if node.box_ecef is not None:
        return node.box_ecef
    if node.world is None:
        frame, to_frame = parent_world, parent_inverse
    else:
        frame, to_frame = node.world, frames.inverse_rigid(node.world)
    points = [] if node.corners is None else [node.corners]
    points += [finish(child, frame, to_frame) for child in node.children]
    box = frames.box_around(frames.apply(to_frame, np.vstack(points)))
    node.box = box
    most = max((child.error for child in node.children), default=0.0)
    if node.content is None:
        node.error = max(most, box_diagonal(box))
    else:
        node.error = max(node.error, most)
    return frames.apply(frame, frames.box_corners(box))


def finish_chains(tops: list[Node]) -> None:
    """:func:`finish` for every building chain (``tops``: their top nodes), chains of the same
    length as one batch (the same arithmetic, one numpy call per level instead of one per node);
    each top keeps its box's ECEF corners in ``box_ecef``."""
    by_length: dict[int, list[list[Node]]] = {}
    for top in tops:
        chain = [top]
        while chain[-1].children:
            chain.append(chain[-1].children[0])
        by_length.setdefault(len(chain), []).append(chain)
    for length, chains in sorted(by_length.items()):
        worlds = np.array([chain[0].world for chain in chains])
        inverses = np.array([frames.inverse_rigid(world) for world in worlds])
        below: np.ndarray | None = None  # (N, 8, 3) ECEF corners of the level below's boxes
        for depth in reversed(range(length)):
            nodes = [chain[depth] for chain in chains]
            points = np.array([node.corners for node in nodes])
            if below is not None:
                points = np.concatenate([points, below], axis=1)
            local = frames.apply_each(inverses, points)
            low, high = local.min(axis=1), local.max(axis=1)
            centres, halves = (low + high) / 2.0, (high - low) / 2.0
            axes = np.zeros((len(nodes), 3, 3))
            axes[:, [0, 1, 2], [0, 1, 2]] = halves
            for node, centre, half in zip(nodes, centres.tolist(), halves.tolist()):
                node.box = [*centre, half[0], 0.0, 0.0, 0.0, half[1], 0.0, 0.0, 0.0, half[2]]
                most = node.children[0].error if node.children else 0.0
                node.error = max(node.error, most)
            below = frames.apply_each(worlds, centres[:, None, :] + np.matmul(frames.SIGNS, axes))
        assert below is not None
        for chain, corners in zip(chains, below):
            chain[0].box_ecef = corners


def building_tops(node: Node) -> list[Node]:
    """The top nodes of the building chains under ``node``."""
    if node.building is not None:
        return [node]
    return [top for child in node.children for top in building_tops(child)]


def box_diagonal(box: list[float]) -> float:
    """Metres: the diagonal of a 3D Tiles box whose half-axes are orthogonal."""
    return 2.0 * float(np.linalg.norm(np.linalg.norm(np.asarray(box[3:]).reshape(3, 3), axis=1)))


def tile_json(node: Node, parent_world: np.ndarray, parent_inverse: np.ndarray) -> dict:
    """The 3D Tiles ``tile`` object of ``node`` (recursively); ``parent_inverse``: ECEF ->
    ``parent_world``'s frame."""
    out: dict = {
        "boundingVolume": {"box": node.box},
        "geometricError": node.error,
        "refine": "REPLACE",
    }
    frame, inverse = parent_world, parent_inverse
    if node.world is not None:
        out["transform"] = frames.column_major(parent_inverse @ node.world)
        frame, inverse = node.world, frames.inverse_rigid(node.world)
    if node.content is not None:
        out["content"] = {"uri": quote(node.content)}
    if node.children:
        out["children"] = [tile_json(child, frame, inverse) for child in node.children]
    return out


def document(root: Node, frame: np.ndarray) -> dict:
    """``asset``, ``geometricError`` and ``root`` of a tileset whose root is ``root``, placed in
    ``frame`` (4 x 4, the frame its root's transform is relative to: ECEF for the export's
    tileset, the tile's for a tile's own, which 3D Tiles composes onto the referencing tile's)."""
    inverse = frames.inverse_rigid(frame)
    finish_chains(building_tops(root))
    finish(root, frame, inverse)
    assert root.box is not None
    return {
        "asset": {"version": "1.1", "tilesetVersion": f"vworld-lod {__version__}"},
        # The error of drawing nothing (clients draw nothing below it): the whole box's size.
        "geometricError": max(root.error, box_diagonal(root.box)),
        "root": tile_json(root, frame, inverse),
    }


def collapsed(node: Node) -> Node:
    """``node``'s tree with every tile node that has no content (no proxy) and only its own
    tileset's reference below it replaced by that reference, in the tile's frame: the tile node
    references its tileset directly."""
    node.children = [collapsed(child) for child in node.children]
    only = node.children[0] if len(node.children) == 1 else None
    if node.tile is not None and node.content is None and only is not None and only.holds:
        only.world, only.tile = node.world, node.tile  # still the tile (tiles.json's children)
        return only
    return node


def add_extras(tileset: dict, tops_of_chains: list[Node], left_out: list[str]) -> None:
    """``extras``: what was left out (``left_out``) and the written level files the chains of
    ``tops_of_chains`` do not reference, each with the reason (tree.redundant)."""
    if left_out:
        tileset["extras"] = {"left_out": sorted(left_out)}
    levels = sorted(note for top in tops_of_chains for note in top.building.dropped)  # type: ignore[union-attr]
    if levels:
        tileset.setdefault("extras", {})["levels_left_out"] = levels


def tileset_json(
    tops: list[Node], left_out: list[str], properties: dict[str, dict] | None = None
) -> dict:
    """The whole tileset: one top node is the root, several hang under a root without content.
    ``properties``: the ``building`` class of the export (the union of its tiles' own tilesets'
    classes, .metadata): its ``schema`` when the tree holds no chain itself (3D Tiles: every
    class of an external tileset's schema is in the top-level tileset's)."""
    root = collapsed(tops[0] if len(tops) == 1 else Node("root", None, children=tops))
    tileset = document(root, np.eye(4))
    add_metadata(tileset, root)  # the buildings' metadata (schema, contents'): .metadata
    if properties and "schema" not in tileset:
        tileset["schema"] = schema(properties)
    add_extras(tileset, building_tops(root), left_out)
    return tileset


def tile_tileset_json(
    tile: TileId,
    chains: list[BuildingChain],
    left_out: list[str],
    properties: dict[str, dict] | None = None,
) -> tuple[dict, Node, dict[str, dict]]:
    """A building tile's own tileset (``OUT/<tile>/tileset.json``): its ``chains`` (by id) under a
    root without content in the tile's frame, its buildings' ``schema`` and content ``metadata``
    (``properties``: the class to type them with, default their own), ``extras``: ``left_out``
    and the levels left out. Returns (tileset, its root node, .metadata.property_kinds of its
    buildings)."""
    tops = building_nodes(chains)
    prefix = f"{tile.name}/"
    for top in tops:  # URIs relative to the tile's folder, where this tileset lives
        node: Node | None = top
        while node is not None:
            assert node.content is not None and node.content.startswith(prefix)
            node.content = node.content[len(prefix) :]
            node = node.children[0] if node.children else None
    root = Node(tile.name, None, children=tops)
    tileset = document(root, tile_world(tile))
    kinds = add_metadata(tileset, root, properties)
    add_extras(tileset, tops, left_out)
    return tileset, root, kinds


def tileset_bytes(tileset: dict) -> bytes:
    """The file's bytes of ``tileset`` (compact JSON, UTF-8, one line)."""
    text = json.dumps(tileset, ensure_ascii=False, allow_nan=False, separators=(",", ":"))
    return (text + "\n").encode("utf-8")


def write_tileset_json(out_dir: Path, tileset: dict) -> Path:
    return write_bytes_atomic(Path(out_dir) / TILESET_NAME, tileset_bytes(tileset), durable=True)
