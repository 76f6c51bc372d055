"""``OUT/tileset.json``: the export as one 3D Tiles 1.1 tileset (glTF content, the existing files).

Entry point: :func:`write_tileset` (``export_tiles`` calls it after the manifests). Each
building tile has its own tileset, ``OUT/<tile>/tileset.json`` (its buildings as LoD chains with
their certified errors, :mod:`.tree`), written with its manifest, and a small summary beside it
(:mod:`.external`). From the summaries of every tile under ``OUT`` (this run's and earlier
runs', as ``tiles.json`` lists them) this builds the VWorld quadtree of tiles, each building
tile referencing its own tileset (3D Tiles external tilesets), adds the tiles' proxies
(:mod:`.proxy`, each built from its children's, level by level in parallel: :mod:`.schedule`)
and writes the JSON (:mod:`.write`): its size and time grow with the tiles, not the buildings.
Frames: :mod:`.frames`.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..config import TextureOptions, TilesetOptions
from .external import tile_summaries, tile_summary
from .metadata import fits, merge_property_kinds, properties_digest, properties_of
from .tree import Node, TileSummary, tile_tree, tileset_reference
from .write import TILESET_NAME, tileset_json, write_tileset_json

if TYPE_CHECKING:
    from .schedule import Workers

__all__ = ["TILESET_NAME", "TilesetResult", "write_tileset"]


@dataclass
class TilesetResult:
    path: Path | None  # None: nothing to show (and no tileset.json left behind)
    buildings: int = 0
    proxies: int = 0
    proxies_built: int = 0
    left_out: list[str] = field(default_factory=list)
    # What tiles.json lists of the proxies for the Unity streamer (exporter.tile_index.proxy_entries)
    proxies_index: list[dict] = field(default_factory=list)
    proxies_on_workers: int = 0  # built on pool or cluster workers (not in this process)

    def summary(self) -> str:
        """One line for the command line."""
        if self.path is None:
            return "tileset: no building to show, no tileset.json written"
        text = (
            f"tileset: {self.buildings} building{'s' * (self.buildings != 1)}, "
            f"{self.proxies} tile prox{'y' if self.proxies == 1 else 'ies'} "
            f"({self.proxies_built} built) -> {self.path}"
        )
        if self.left_out:
            text += f"; left out: {self.left_out[0]}" + (
                f" (and {len(self.left_out) - 1} more, see its extras)"
                if len(self.left_out) > 1
                else ""
            )
        return text


def proxy_records(tops: list[Node]) -> list[dict]:
    """Per proxy of the finished tree (children before parents): its tile, ``file`` (relative to
    OUT), ``radius_m`` (metres: the farthest corner of its content box from its frame's origin,
    the tile centre at elevation 0), ``geometric_error`` (metres, as tileset.json has it), ``texel_m``
    (metres per texel of its atlas on its surface: what its texture shows, finer than that error
    when the geometry decides it), ``atlas_px`` (pixels per side of its atlas), the names of its
    child proxies (``children``) and of the building tile it holds (``tiles``)."""
    records: list[dict] = []

    def visit(node: Node) -> None:
        for child in node.children:
            visit(child)
        if node.tile is None or node.proxy_hash is None or node.world is None:
            return
        assert node.corners is not None and node.content is not None
        radius = float(np.linalg.norm(node.corners - node.world[:3, 3], axis=1).max())
        children = [c.tile.name for c in node.children if c.tile is not None]
        holds = any(
            c.building is not None or (c.holds is not None and c.holds.tile == node.tile)
            for c in node.children
        )
        records.append(
            {
                "tile": node.tile,
                "file": node.content,
                "radius_m": radius,
                "geometric_error": node.error,
                "texel_m": node.texel,
                "atlas_px": node.atlas_px,
                "children": children,
                "tiles": [node.tile.name] if holds else [],
            }
        )

    for top in tops:
        visit(top)
    return records


def write_tileset(
    out_dir: str | Path,
    options: TilesetOptions,
    jpeg_quality: int = TextureOptions.jpeg_quality,
    fresh: dict[str, tuple[int, dict]] | None = None,
    force: bool = False,
    workers: Workers | None = None,
    early: dict[str, dict] | None = None,
) -> TilesetResult:
    """Write ``OUT/tileset.json`` for every building of ``out_dir``; see the module doc.
    ``fresh``: the index facts of the run's tiles (:func:`exporter.tile_index.fresh_facts`);
    ``force``: rebuild every proxy (``export --force``); ``workers``: where the proxies are built
    (:class:`.schedule.Workers`; default this process); ``early``: proxies this run built already
    (:class:`.schedule.LeafProxies`' records, by task key), taken as they are."""
    out_dir = Path(out_dir)
    left_out: list[str] = []
    found = tile_summaries(out_dir, fresh, options, jpeg_quality, left_out)
    left_out += [
        f"{s.tile.name}: no building to show; tile left out" for s in found if not s.buildings
    ]
    shown = typed_alike(out_dir, [s for s in found if s.buildings], options, jpeg_quality, left_out)
    properties = properties_of(merge_property_kinds([s.kinds for s in shown.values()]))
    tops = tile_tree(shown, lambda tile: [tileset_reference(shown[tile])])
    if not options.proxies or not tops:
        from .proxy import PROXY_DIR, remove_stale

        remove_stale(out_dir / PROXY_DIR, set())
    problems = [line for s in found for line in s.left_out]  # buildings': in their tilesets
    if not tops:
        (out_dir / TILESET_NAME).unlink(missing_ok=True)  # it would name files no longer shown
        return TilesetResult(None, 0, left_out=left_out + problems)
    proxies = built = 0
    if options.proxies:
        from .schedule import add_proxies

        proxies, built = add_proxies(
            out_dir, tops, options, jpeg_quality, left_out, force, workers, early
        )
    path = write_tileset_json(out_dir, tileset_json(tops, left_out, properties))
    count = sum(s.buildings for s in shown.values())
    remote = workers.remote if workers is not None else 0
    records = proxy_records(tops)
    return TilesetResult(path, count, proxies, built, left_out + problems, records, remote)


def prebuild_proxies(
    out_dir: str | Path,
    options: TilesetOptions,
    jpeg_quality: int,
    fresh: dict[str, tuple[int, dict]] | None,
    workers: Workers,
    early: Callable[[], dict[str, dict]],
) -> dict[str, dict]:
    """Build now the proxies :func:`write_tileset` would build from ``out_dir`` as it is (tiles
    of earlier runs as they were), on ``workers``, writing nothing else and removing nothing;
    returns their records by task key (``write_tileset``'s ``early``, which ``early()`` gives
    once the tree is made: the leaf proxies it waits for are built meanwhile). A re-run builds a
    changed tile's ancestors so while it still confirms its unchanged tiles (exporter.completion):
    at the end they are taken by key, or built again if anything they are made from changed
    since."""
    out_dir = Path(out_dir)
    found = tile_summaries(out_dir, fresh, options, jpeg_quality, [])
    shown = {s.tile: s for s in found if s.buildings}
    tops = tile_tree(shown, lambda tile: [tileset_reference(shown[tile])])
    built: dict[str, dict] = {}
    records = early()
    if options.proxies and tops:
        from .schedule import add_proxies

        add_proxies(out_dir, tops, options, jpeg_quality, [], False, workers, records, built, False)
    return built


def typed_alike(
    out_dir: Path,
    shown: list[TileSummary],
    options: TilesetOptions,
    jpeg_quality: int,
    problems: list[str],
) -> dict:
    """``shown`` (summaries of tiles with buildings) by tile, after writing again the tilesets
    of those whose metadata class does not read the same against the export's (the union of
    all tiles', types widened over all values: a property INT32 in one tile and STRING in
    another is STRING; :func:`.metadata.fits`): they take the export's class (3D Tiles: an
    external tileset's classes are the top-level schema's, and CesiumJS reads their content
    metadata with it). A tile whose own class fits is written with its own (a tileset typed with the export's
    class earlier is written again with its own once the mixed types are gone)."""
    union = properties_of(merge_property_kinds([s.kinds for s in shown]))
    out = {}
    for summary in shown:
        own = properties_of(summary.kinds)
        target = own if fits(own, union) else union
        if properties_digest(target) != summary.typed:
            again = tile_summary(out_dir, summary.tile, options, jpeg_quality, problems, target)
            if again is None or not again.buildings:
                continue
            summary = again
        out[summary.tile] = summary
    return out
