"""Independent checks of an ``OUT/tileset.json`` (3D Tiles 1.1) for the tests and the benchmark.

External tilesets (3D Tiles 1.1: a content URI naming a tileset JSON; the export gives each
building tile its own, ``OUT/<tile>/tileset.json``) are followed by :func:`load`, which returns
one resolved tileset (as the tileset a client assembles in memory) plus what the rules of external
tilesets need (:func:`external_problems`).

Frames: ``world`` matrices map a tile's frame to ECEF (EPSG:4978) metres, composed from the root
down from the column-major ``transform``s; glTF content is turned y-up -> z-up first, as the
specification says ((x, y, z) -> (x, -z, y)). Written from the specification, not from the
exporter's code.
"""

from __future__ import annotations

import copy
import json
import posixpath
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import quote, unquote, urlparse

import numpy as np

from exporter.tileset.glb import read_primitives

Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, -1.0, 0], [0, 1.0, 0, 0], [0, 0, 0, 1.0]])


@dataclass
class Visit:
    tile: dict
    world: np.ndarray  # 4 x 4: tile frame -> ECEF
    depth: int
    parent: Visit | None
    children: list[Visit] = field(default_factory=list)

    @property
    def uri(self) -> str | None:
        content = self.tile.get("content")
        return None if content is None else content["uri"]


def load(out: Path, name: str = "tileset.json") -> dict:
    """``OUT/name`` with every external tileset it references resolved, recursively: a tile
    whose content URI ends in ``.json`` loses that content and gets the external tileset's root
    as its only child (its content URIs made relative to OUT, its groups appended to the
    resolved ``groups`` with their indices shifted, its ``extras`` lists appended to the
    resolved ones), and keeps under ``"external"`` what the rules need: ``uri``, the file as
    read (``tileset``) and whether the referencing tile had children (``had_children``)."""
    tileset = json.loads((out / name).read_text(encoding="utf-8"))
    resolved = copy.deepcopy(tileset)
    resolved.setdefault("groups", [])

    def rebase(tile: dict, base: str, shift: int) -> None:
        content = tile.get("content")
        if content is not None:
            if base:
                content["uri"] = quote(posixpath.join(base, unquote(content["uri"])))
            if "group" in content:
                content["group"] += shift
        for child in tile.get("children", []):
            rebase(child, base, shift)

    def resolve(tile: dict) -> None:
        uri = tile.get("content", {}).get("uri", "")
        if unquote(uri).endswith(".json"):
            external = json.loads((out / unquote(uri)).read_text(encoding="utf-8"))
            tile["external"] = {
                "uri": unquote(uri),
                "tileset": external,
                "had_children": "children" in tile,
            }
            root = copy.deepcopy(external["root"])
            rebase(root, posixpath.dirname(unquote(uri)), len(resolved["groups"]))
            resolved["groups"] += external.get("groups", [])
            for key, lines in external.get("extras", {}).items():
                resolved.setdefault("extras", {}).setdefault(key, []).extend(lines)
            del tile["content"]
            tile["children"] = [root]
            resolve(root)
            return
        for child in tile.get("children", []):
            resolve(child)

    resolve(resolved["root"])
    if not resolved["groups"]:
        del resolved["groups"]
    return resolved


def external_problems(out: Path, tileset: dict) -> list[str]:
    """The rules of external tilesets in the resolved ``tileset`` (:func:`load`); [] when all
    hold: a tile referencing one has no children of its own (3D Tiles 1.1), the external file is
    a 3D Tiles 1.1 tileset with a top-level geometricError, every class of its schema is in the
    top-level tileset's with the same properties (the specification asks for the classes;
    CesiumJS reads an external tileset's groups with the top-level class, cesium#13407), and
    every content's group indexes its own tileset's groups."""
    problems = []
    top_classes = tileset.get("schema", {}).get("classes", {})
    for visit in walk(tileset):
        found = visit.tile.get("external")
        if found is None:
            continue
        uri, external = found["uri"], found["tileset"]
        if found["had_children"]:
            problems.append(f"the tile referencing {uri} has children")
        if external.get("asset", {}).get("version") != "1.1" or "geometricError" not in external:
            problems.append(f"{uri}: not a 3D Tiles 1.1 tileset with a geometricError")
        for name, item in external.get("schema", {}).get("classes", {}).items():
            if name not in top_classes:
                problems.append(f"{uri}: class {name} not in the top-level schema")
                continue
            top = top_classes[name].get("properties", {})
            for pid, definition in item.get("properties", {}).items():
                if top.get(pid) != definition:
                    problems.append(f"{uri}: {name}.{pid} defined otherwise at the top level")
        count = len(external.get("groups", []))
        for tile in tiles_of(external):
            group = tile.get("content", {}).get("group")
            if group is not None and not (isinstance(group, int) and 0 <= group < count):
                problems.append(f"{uri}: group {group} out of range ({count} groups)")
    return problems


def tiles_of(tileset: dict) -> list[dict]:
    """Every tile of ``tileset`` as one file holds it (external tilesets not followed)."""
    found, stack = [], [tileset["root"]]
    while stack:
        tile = stack.pop()
        found.append(tile)
        stack.extend(tile.get("children", []))
    return found


def walk(tileset: dict) -> list[Visit]:
    """Every tile, parents before children, with its world matrix."""
    out: list[Visit] = []

    def visit(tile: dict, parent: Visit | None, depth: int) -> None:
        world = np.eye(4) if parent is None else parent.world
        if "transform" in tile:
            world = world @ np.array(tile["transform"], dtype=np.float64).reshape(4, 4).T
        node = Visit(tile, world, depth, parent)
        if parent is not None:
            parent.children.append(node)
        out.append(node)
        for child in tile.get("children", []):
            visit(child, node, depth + 1)

    visit(tileset["root"], None, 0)
    return out


def to_world(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    return points @ matrix[:3, :3].T + matrix[:3, 3]


def box_corners(box: list[float]) -> np.ndarray:
    centre, axes = np.asarray(box[:3]), np.asarray(box[3:]).reshape(3, 3)
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    return centre + signs @ axes


def inside_box(box: list[float], points: np.ndarray, slack: float = 1e-6) -> bool:
    """Whether ``points`` (n, 3, in the box's frame) lie in the oriented box (``slack`` metres)."""
    centre, axes = np.asarray(box[:3]), np.asarray(box[3:]).reshape(3, 3)
    offsets = points - centre
    coefficients = offsets @ np.linalg.pinv(axes)  # offsets = coefficients @ axes
    residual = np.linalg.norm(offsets - coefficients @ axes, axis=1)
    lengths = np.maximum(np.linalg.norm(axes, axis=1), 1e-12)
    excess = (np.abs(coefficients) - 1.0) * lengths
    return bool(residual.max() <= slack and excess.max() <= slack)


def content_mesh(out: Path, visit: Visit) -> tuple[np.ndarray, np.ndarray]:
    """The tile's content as one mesh in ECEF metres: positions (n, 3), triangles (m, 3)."""
    assert visit.uri is not None
    prims = read_primitives(out / unquote(visit.uri))
    offsets = np.cumsum([0] + [len(p.positions) for p in prims])
    matrix = visit.world @ Y_UP
    positions = np.concatenate([to_world(matrix, p.positions) for p in prims])
    faces = np.concatenate([p.triangles + offsets[i] for i, p in enumerate(prims)])
    return positions, faces


def structural_problems(out: Path, tileset: dict) -> list[str]:
    """The 3D Tiles 1.1 rules the tests check; [] when all hold."""
    problems = []
    if tileset.get("asset", {}).get("version") != "1.1":
        problems.append(f"asset.version {tileset.get('asset')}")
    if "geometricError" not in tileset:
        problems.append("no top-level geometricError")
    problems += external_problems(out, tileset)
    for visit in walk(tileset):
        tile = visit.tile
        box = tile["boundingVolume"]["box"]
        error = tile["geometricError"]
        # Errors never grow within one tileset; an external tileset's root (no content: refined
        # as soon as it is reached) may have a larger error than the tile referencing it.
        across = visit.parent is not None and "external" in visit.parent.tile
        if visit.parent is not None and not across and error > visit.parent.tile["geometricError"]:
            problems.append(
                f"geometricError grows {visit.parent.tile['geometricError']} -> {error}"
            )
        if tile.get("refine", "REPLACE") not in ("REPLACE", "ADD"):
            problems.append(f"refine {tile.get('refine')}")
        to_local = np.linalg.inv(visit.world)
        if visit.uri is not None:
            parsed = urlparse(visit.uri)
            if parsed.scheme or visit.uri.startswith("/") or ".." in visit.uri.split("/"):
                problems.append(f"not a relative URI inside OUT: {visit.uri}")
            elif not (out / unquote(visit.uri)).is_file():
                problems.append(f"content missing: {visit.uri}")
            else:
                positions, _ = content_mesh(out, visit)
                if not inside_box(box, to_world(to_local, positions), slack=1e-4):
                    problems.append(f"content of {visit.uri} outside its box")
        for child in visit.children:
            corners = to_world(child.world, box_corners(child.tile["boundingVolume"]["box"]))
            if not inside_box(box, to_world(to_local, corners), slack=1e-4):
                problems.append(f"a child box of {visit.uri or 'a tile'} outside its box")
    return problems
