"""HTML text of the report pages: one per tile (``OUT/<tile>/report.html``) and the index
(``OUT/index.html``).

Data form: a tile page is built from the parsed manifest (dict, see ``docs/ARCHITECTURE.md``) and
a list of :class:`BuildingRenders` (per building, per level: the image path *relative to the page*
or the reason there is none). Pages are self-contained static HTML: inline CSS, inline SVG plots,
images referenced relatively, so they open from ``file://`` with no server and no network. One
small inline script marks ``<body>`` with the count of loaded and broken images
(``data-images-loaded`` / ``data-images-broken``), the ids of laid-out tables
(``data-tables-shown``) and the count of laid-out plots (``data-plots-shown``), and shows a banner
when an image is missing.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from html import escape
from urllib.parse import quote

from .plots import strip_plot_svg
from .summary import (
    METRICS,
    level_error,
    level_table,
    lod_metric,
    metric_series,
    metric_stats,
    quality_score,
    worst_first,
    worst_hausdorff,
)

# Display-only thresholds that colour a metric as a likely problem (not used by the exporter).
WARN_BELOW = {"silhouette_iou": 0.9, "wall_coverage": 0.9}
WARN_ABOVE = {"hausdorff_rel": 0.05, "new_holes": 0.0}
DETAIL_PX = 64  # CSS pixels of the atlas detail (its own size varies with the level)
FIXED_RANGES = {
    "triangle_ratio": (0.0, 1.0),
    "silhouette_iou": (0.0, 1.0),
    "wall_coverage": (0.0, 1.0),
}

STYLE = """
body{font:14px/1.4 system-ui,sans-serif;margin:1.5em;color:#222;background:#fff}
h1{font-size:1.5em;margin:.2em 0}h2{font-size:1.2em;margin-top:1.6em;border-bottom:1px solid #ddd}
table{border-collapse:collapse;margin:.5em 0}th,td{border:1px solid #ccc;padding:3px 6px;text-align:right}
th{background:#f0f0f3}td.text,th.text{text-align:left}
.meta{color:#555}.plots{display:flex;flex-wrap:wrap;gap:10px}.wide{overflow-x:auto}
.plot-title{font-size:12px;font-weight:600}.plot-tick{font-size:10px;fill:#555}
.plot-frame{fill:#fafafa;stroke:#ccc}.plot-grid{stroke:#e4e4e4}.plot-dot{fill:#3465a4;fill-opacity:.7}
.plot-median{stroke:#c00;stroke-width:2}
.building{border-top:1px solid #ddd;padding:.6em 0}.building h3{margin:.2em 0;font-size:1.05em}
.lods{display:flex;flex-wrap:wrap;gap:12px}.lod{margin:0;width:256px}
.lod img.render{display:block;width:256px;height:256px;background:#eee;border:1px solid #ddd}
.detail{display:flex;gap:6px;align-items:center;font-size:11px;color:#555;margin-top:4px}
.lod img.atlas{display:block;width:64px;height:64px;flex:none;image-rendering:pixelated;border:1px solid #ddd}
.lod figcaption{font-size:12px}.lod table{font-size:11px;margin:.2em 0;width:100%}
.lod td{padding:1px 4px}
.missing{width:256px;height:256px;display:flex;align-items:center;justify-content:center;
 background:#fee;border:1px solid #e99;color:#a00;text-align:center;font-size:12px;padding:4px;box-sizing:border-box}
.bad{color:#b00;font-weight:600}.problems{color:#a60}.score{font-weight:normal;color:#555}
#broken-banner{display:none;background:#fdd;border:1px solid #c66;padding:.5em;margin:.5em 0}
"""

LOAD_CHECK = """
<script>
window.addEventListener("load", function () {
  var images = Array.prototype.slice.call(document.images);
  var loaded = images.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.body.setAttribute("data-images-loaded", String(loaded));
  document.body.setAttribute("data-images-broken", String(images.length - loaded));
  var shown = function (selector) {
    return Array.prototype.filter.call(document.querySelectorAll(selector), function (e) {
      var box = e.getBoundingClientRect(); return box.width > 0 && box.height > 0; });
  };
  document.body.setAttribute("data-tables-shown", shown("table[id]").map(function (t) { return t.id; }).join(" "));
  document.body.setAttribute("data-plots-shown", String(shown("svg.plot").length));
  if (images.length > loaded) {
    var banner = document.getElementById("broken-banner");
    if (banner) { banner.style.display = "block"; banner.textContent = (images.length - loaded) + " image(s) failed to load"; }
  }
});
</script>
"""


@dataclass
class LevelRender:
    """One level's picture: ``image`` relative to the page (URL path) or ``error`` saying why not;
    ``seconds`` the wall time to load, render and save it (and its atlas detail)."""

    level: int
    lod: dict
    image: str | None = None
    error: str | None = None
    seconds: float = 0.0
    detail: str | None = None  # the atlas detail crop, relative to the page
    detail_size: tuple = (0, 0)  # its width, height in atlas pixels


@dataclass
class BuildingRenders:
    building: dict
    levels: list[LevelRender] = field(default_factory=list)


def _fmt_int(value) -> str:
    return f"{int(value):,}"


def _fmt_share(value: float | None) -> str:
    return "–" if value is None else f"{value * 100:.1f} %"


def _fmt_metric(value: float | None) -> str:
    if value is None:
        return "–"
    # Below 1e-6 is float32 noise of an unchanged level (micrometres on a building), shown as 0.
    return "0" if abs(value) < 1e-6 else f"{value:.3g}"


def _is_bad(key: str, value: float | None) -> bool:
    if value is None:
        return False
    return (key in WARN_BELOW and value < WARN_BELOW[key]) or (
        key in WARN_ABOVE and value > WARN_ABOVE[key]
    )


def _sizes(sizes: list) -> str:
    return (
        ", ".join(("untextured" if w * h == 0 else f"{w}×{h}") + f" ×{n}" for (w, h), n in sizes)
        or "–"
    )


def _document(title: str, body: list[str]) -> str:
    return "\n".join(
        [
            "<!DOCTYPE html>",
            '<html lang="en">',
            "<head>",
            '<meta charset="utf-8">',
            f"<title>{escape(title)}</title>",
            f"<style>{STYLE}</style>",
            "</head>",
            "<body>",
            '<div id="broken-banner"></div>',
            *body,
            LOAD_CHECK,
            "</body>",
            "</html>",
            "",
        ]
    )


# --------------------------------------------------------------------------- tile page sections


def level_table_html(manifest: dict) -> str:
    """The per-level summary table (the paper's Table III plus texture and file sizes)."""
    head = (
        "<tr><th>level</th><th>transition</th><th>buildings</th><th>triangles</th><th>mean triangles</th>"
        "<th>triangles / LOD0</th><th>mean triangle ratio</th><th>vertices</th><th>texture pixels</th>"
        '<th>pixels / LOD0</th><th class="text">atlas sizes × buildings</th><th>file bytes</th></tr>'
    )
    rows = []
    for row in level_table(manifest):
        transition = "–" if row["transition"] is None else f"{row['transition'] * 100:g} %"
        rows.append(
            f'<tr data-level="{row["level"]}"><td>LOD{row["level"]}</td><td>{transition}</td>'
            f'<td>{row["buildings"]}</td><td class="triangles">{_fmt_int(row["triangles"])}</td>'
            f'<td>{row["mean_triangles"]:.1f}</td><td class="triangle-share">{_fmt_share(row["triangle_share"])}</td>'
            f"<td>{_fmt_share(row['mean_triangle_ratio'])}</td><td>{_fmt_int(row['vertices'])}</td>"
            f"<td>{_fmt_int(row['texture_pixels'])}</td><td>{_fmt_share(row['pixel_share'])}</td>"
            f'<td class="text">{escape(_sizes(row["texture_sizes"]))}</td>'
            f"<td>{'–' if row['file_bytes'] is None else _fmt_int(row['file_bytes'])}</td></tr>"
        )
    return f'<div class="wide"><table id="level-table">{head}{"".join(rows)}</table></div>'


def skipped_html(manifest: dict) -> str:
    skipped = manifest.get("skipped", [])
    if not skipped:
        return '<p id="skipped-none">No building was skipped.</p>'
    rows = "".join(
        f'<tr><td class="text">{escape(str(item.get("id", "–")))}</td><td class="text">{escape(str(item.get("source", "")))}</td>'
        f'<td class="text">{escape(str(item.get("reason", "")))}</td></tr>'
        for item in skipped
    )
    return f'<table id="skipped-table"><tr><th class="text">id</th><th class="text">source</th><th class="text">reason</th></tr>{rows}</table>'


def plots_html(manifest: dict) -> str:
    """One strip plot per metric, a column per reduced level; metrics nobody measured are left out."""
    plots = []
    quality_table = []
    for key, label, _ in METRICS:
        series = metric_series(manifest, key)
        if not any(points for _, points in series):
            continue
        plots.append(
            strip_plot_svg(
                label,
                [(f"LOD{level}", points) for level, points in series],
                FIXED_RANGES.get(key),
                width=168,
                height=150,
            )
        )
        for level, points in series:
            stats = metric_stats([v for _, v in points])
            if stats:
                quality_table.append(
                    f'<tr><td class="text">{escape(key)}</td><td>LOD{level}</td><td>{len(points)}</td>'
                    f"<td>{_fmt_metric(stats['min'])}</td><td>{_fmt_metric(stats['median'])}</td><td>{_fmt_metric(stats['max'])}</td></tr>"
                )
    if not plots:
        return '<p id="plots-none">No quality metrics in the manifest.</p>'
    table = (
        '<table id="quality-table"><tr><th class="text">metric</th><th>level</th><th>buildings</th><th>min</th>'
        f"<th>median</th><th>max</th></tr>{''.join(quality_table)}</table>"
    )
    return f'<div class="plots">{"".join(plots)}</div><details><summary>min / median / max per level</summary>{table}</details>'


def _metrics_table(lod: dict) -> str:
    """The level's metrics, two label/value pairs per row (compact under a 256 px picture)."""
    cells = []
    for key, _, label in METRICS:
        value = lod_metric(lod, key)
        if value is None:
            continue
        css = ' class="bad"' if _is_bad(key, value) else ""
        cells.append(
            f'<td class="text">{escape(label)}</td><td{css} data-metric="{key}">{_fmt_metric(value)}</td>'
        )
    rows = "".join(f"<tr>{''.join(cells[i : i + 2])}</tr>" for i in range(0, len(cells), 2))
    return f'<table class="metrics">{rows}</table>' if cells else ""


NO_SMALLER_WHY = (
    "the simplifier found no smaller mesh within the level's error budget (a certified Hausdorff "
    "bound of max_screen_error_px at the level's largest size on screen; lods[].mesh is only a "
    "cap), so the level keeps the mesh of the level above, with its own atlas"
)


def no_smaller_html(manifest: dict) -> str:
    """Per level: how many buildings keep the level above's triangles (``no_smaller_than_above``
    in the manifest) and why; empty when none does."""
    buildings = manifest.get("buildings", [])
    counts: dict[int, int] = {}
    for building in buildings:
        for k, lod in enumerate(building.get("lods", [])):
            if k and lod.get("no_smaller_than_above"):
                counts[k] = counts.get(k, 0) + 1
    if not counts:
        return ""
    shares = "; ".join(
        f"LOD{k}: {n} of {len(buildings)} buildings keep LOD{k - 1}'s triangles"
        for k, n in sorted(counts.items())
    )
    return f'<p class="meta" id="no-smaller">{escape(shares)}: {escape(NO_SMALLER_WHY)}.</p>'


def _error_text(lod: dict) -> str:
    """`` · texel 4.6 cm · error 0.74 m``: the level's on-surface texel and its error (the larger
    of its certified geometric bound and its texture error, what the tileset uses), when stated."""
    texel, error = lod_metric(lod, "texel_m"), level_error(lod)
    text = (
        "" if texel is None else f' · <span data-field="texel_m">texel {texel * 100:.3g} cm</span>'
    )
    if error is not None:
        text += f' · <span data-field="error_m">error {_fmt_metric(error)} m</span>'
    return text


def _level_figure(building_id: str, render: LevelRender) -> str:
    lod = render.lod
    w, h = (list(lod.get("texture_size", [0, 0])) + [0, 0])[:2]
    texture = "untextured" if w * h == 0 else f"{w}×{h} px"
    if render.image is not None:
        picture = (
            f'<img class="render" src="{escape(render.image)}" width="256" height="256" '
            f'alt="{escape(building_id)} LOD{render.level}">'
        )
    else:
        picture = f'<div class="missing">{escape(render.error or "no image")}</div>'
    if render.detail is not None:
        w_crop, h_crop = render.detail_size
        picture += (
            f'<div class="detail"><img class="atlas" src="{escape(render.detail)}" width="{DETAIL_PX}" '
            f'height="{DETAIL_PX}" alt="{escape(building_id)} LOD{render.level} atlas detail">'
            f"<span>atlas centre, {w_crop}×{h_crop} px of the {w}×{h} atlas, enlarged</span></div>"
        )
    caption = (
        f"<b>LOD{render.level}</b> · {_fmt_int(lod.get('triangles', 0))} triangles · "
        f"{_fmt_int(lod.get('vertices', 0))} vertices · {texture}{_error_text(lod)}"
    )
    if render.level and lod.get("no_smaller_than_above"):
        budget = lod.get("error_budget_m")
        within = f" within its {budget * 100:.1f} cm error budget" if budget else ""
        caption += (
            f'<div class="note" data-no-smaller="1">same mesh as LOD{render.level - 1}: no '
            f"smaller one stays{within}</div>"
        )
    return (
        f'<figure class="lod" data-level="{render.level}">{picture}<figcaption>{caption}'
        f"{_metrics_table(lod) if render.level > 0 else ''}</figcaption></figure>"
    )


def building_anchor(building_id: str) -> str:
    """The building's element id on its tile page, usable as a URL fragment as it is."""
    return "building-" + quote(building_id, safe="")


# Attributes shown first in a building's table (docs/input.md "Attributes"), then the others in
# the manifest's order, up to MAIN_ATTRIBUTES rows.
MAIN_FIRST = (
    "name",
    "function",
    "usage",
    "year_of_construction",
    "measured_height",
    "storeys_above_ground",
    "roof_type",
    "gml_id",
    "key",
    "object_id",
)
MAIN_ATTRIBUTES = 8


def attributes_html(building: dict) -> str:
    """The building's id and main attributes as a small table (``id="attributes-<anchor>"``);
    a note says how many more the manifest holds."""
    attributes = building.get("attributes")
    attributes = attributes if isinstance(attributes, dict) else {}
    names = [n for n in MAIN_FIRST if n in attributes]
    names += [n for n in attributes if n not in names]
    rows = [("id", building.get("id", ""))] + [(n, attributes[n]) for n in names[:MAIN_ATTRIBUTES]]
    cells = "".join(
        f'<tr><th class="text">{escape(str(name))}</th><td class="text">{escape(str(value))}</td></tr>'
        for name, value in rows
    )
    more = len(names) - MAIN_ATTRIBUTES
    note = f'<div class="meta">and {more} more attributes in the manifest</div>' if more > 0 else ""
    anchor = escape(building_anchor(str(building.get("id", ""))))
    return f'<table class="attributes" id="attributes-{anchor}">{cells}</table>{note}'


def building_html(rank: int, renders: BuildingRenders) -> str:
    building = renders.building
    building_id = str(building.get("id", ""))
    score = quality_score(building)
    score_text = (
        "no quality metrics"
        if score is None
        else f"worst silhouette IoU / wall coverage {score:.3f}"
    )
    problems = building.get("problems", [])
    problem_list = (
        (
            '<ul class="problems">'
            + "".join(f"<li>{escape(str(p))}</li>" for p in problems)
            + "</ul>"
        )
        if problems
        else ""
    )
    figures = "".join(_level_figure(building_id, r) for r in renders.levels)
    return (
        f'<article class="building" id="{escape(building_anchor(building_id))}" data-building-id="{escape(building_id)}" '
        f'data-score="{"" if score is None else f"{score:.6f}"}"><h3>{rank}. {escape(building_id)} '
        f'<span class="score">— {score_text}</span></h3>'
        f'<div class="meta">source: {escape(str(building.get("source", "")))}</div>'
        f"{attributes_html(building)}{problem_list}"
        f'<div class="lods">{figures}</div></article>'
    )


def tile_page(
    manifest: dict, renders: list[BuildingRenders], render_seconds: float, reused: int = 0
) -> str:
    """The whole tile page. ``renders`` may come in any order: the page sorts them worst first;
    ``reused``: buildings whose images an earlier report drew (their files unchanged)."""
    tile = manifest.get("tile", {})
    name = str(tile.get("name", "tile"))
    center = tile.get("center", {})
    heights = manifest.get("lod_group", {}).get("screen_relative_heights", [])
    by_id = {id(r.building): r for r in renders}
    ordered = [by_id[id(b)] for b in worst_first([r.building for r in renders])]
    images = sum(1 for r in renders for level in r.levels if level.image is not None)
    generator = manifest.get("generator", {})
    body = [
        '<nav><a href="../index.html">← all tiles</a></nav>',
        f"<h1>Tile {escape(name)} — LoD report</h1>",
        f'<p class="meta">level {escape(str(tile.get("level", "?")))}, IDX {escape(str(tile.get("idx", "?")))}, '
        f"IDY {escape(str(tile.get('idy', '?')))}; centre lon {center.get('lon', float('nan')):.6f}°, "
        f'lat {center.get("lat", float("nan")):.6f}° · <span id="building-count">{len(manifest.get("buildings", []))}</span> buildings, '
        f'<span id="skipped-count">{len(manifest.get("skipped", []))}</span> skipped · LODGroup transitions '
        f"{', '.join(f'{h * 100:g} %' for h in heights) or '–'} · "
        f"{escape(str(generator.get('name', '')))} {escape(str(generator.get('version', '')))}</p>",
        '<h2 id="summary">Levels</h2>',
        level_table_html(manifest),
        no_smaller_html(manifest),
        '<h2 id="skipped">Skipped buildings</h2>',
        skipped_html(manifest),
        '<h2 id="distributions">Quality per level</h2>',
        plots_html(manifest),
        '<h2 id="buildings">Buildings, worst first</h2>',
        '<p class="meta">Same 3/4 view from the south-east for every level of a building, fitted to LOD0; '
        "sun from the south-south-west; inside faces darker. Under each render, the same central eighth "
        "of the level's atlas at the atlas' own resolution (texture LoD).</p>",
        *(building_html(rank, r) for rank, r in enumerate(ordered, 1)),
        f'<p class="meta" id="render-time">{images} images in {render_seconds:.2f} s'
        f"{f', {reused} buildings unchanged since the last report (images kept)' if reused else ''}"
        f"{f' ({render_seconds / images * 1000:.0f} ms each, load + render + PNG)' if images and not reused else ''}.</p>",
    ]
    return _document(f"{name} — vworld-lod report", body)


# --------------------------------------------------------------------------- index


@dataclass
class TileEntry:
    """A tile on the index: its folder name, manifest (None when unreadable, with ``error``) and
    whether its report page exists."""

    name: str
    manifest: dict | None
    has_page: bool
    error: str | None = None


WORST_LISTED = 10  # buildings in the index's "worst buildings" table


def worst_buildings_html(entries: list[TileEntry]) -> str:
    """The export's worst buildings over all tiles (those with metrics), linked to their pages."""
    candidates = [
        (building, entry)
        for entry in entries
        if entry.manifest
        for building in entry.manifest.get("buildings", [])
        if quality_score(building) is not None
    ]
    order = {id(b): i for i, b in enumerate(worst_first([b for b, _ in candidates]))}
    candidates.sort(key=lambda item: order[id(item[0])])
    rows = []
    for rank, (building, entry) in enumerate(candidates[:WORST_LISTED], 1):
        building_id = str(building.get("id", ""))
        name = escape(building_id)
        if entry.has_page:
            name = f'<a href="{quote(entry.name)}/report.html#{escape(building_anchor(building_id))}">{name}</a>'
        rows.append(
            f'<tr><td>{rank}</td><td class="text">{escape(entry.name)}</td><td class="text">{name}</td>'
            f"<td>{quality_score(building):.3f}</td><td>{_fmt_metric(worst_hausdorff(building))}</td></tr>"
        )
    if not rows:
        return '<p id="worst-none">No quality metrics in the manifests.</p>'
    return (
        '<table id="worst-table"><tr><th>#</th><th class="text">tile</th><th class="text">building</th>'
        f"<th>worst IoU / coverage</th><th>worst Hausdorff / diagonal</th></tr>{''.join(rows)}</table>"
    )


def index_page(entries: list[TileEntry]) -> str:
    levels = max((len(level_table(e.manifest)) for e in entries if e.manifest), default=0)
    head = (
        '<tr><th class="text">tile</th><th>buildings</th><th>skipped</th>'
        + "".join(f"<th>LOD{k} triangles / LOD0</th>" for k in range(1, levels))
        + '<th class="text">worst building</th><th class="text">report</th></tr>'
    )
    rows = []
    for entry in entries:
        if entry.manifest is None:
            rows.append(
                f'<tr><td class="text">{escape(entry.name)}</td><td class="text bad" colspan="{levels + 3}">'
                f"{escape(entry.error or 'manifest unreadable')}</td></tr>"
            )
            continue
        table = level_table(entry.manifest)
        shares = "".join(
            f"<td>{_fmt_share(table[k]['triangle_share']) if k < len(table) else '–'}</td>"
            for k in range(1, levels)
        )
        buildings = entry.manifest.get("buildings", [])
        worst = worst_first(buildings)[0] if buildings else None
        worst_score = quality_score(worst) if worst else None
        worst_text = (
            "–"
            if worst is None
            else f"{worst.get('id', '')}" + ("" if worst_score is None else f" ({worst_score:.3f})")
        )
        link = (
            f'<a href="{quote(entry.name)}/report.html">report</a>'
            if entry.has_page
            else "not rendered"
        )
        rows.append(
            f'<tr data-tile="{escape(entry.name)}"><td class="text">{escape(entry.name)}</td><td>{len(buildings)}</td>'
            f'<td>{len(entry.manifest.get("skipped", []))}</td>{shares}<td class="text">{escape(worst_text)}</td>'
            f'<td class="text">{link}</td></tr>'
        )
    body = [
        "<h1>vworld-lod export — LoD reports</h1>",
        f'<p class="meta">{len(entries)} tile(s). Worst building = lowest silhouette IoU / wall coverage over its reduced levels.</p>',
        f"<h2>Worst {WORST_LISTED} buildings</h2>",
        worst_buildings_html(entries),
        "<h2>Tiles</h2>",
        f'<table id="tile-table">{head}{"".join(rows)}</table>',
    ]
    return _document("vworld-lod LoD reports", body)
