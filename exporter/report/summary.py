"""Numbers for the report, computed from one tile's ``lod_manifest.json`` (a parsed dict).

Everything here is pure: manifest dicts in, plain dicts/lists out. Levels are LoD indices (0 =
full detail); triangle and vertex counts are per glTF file; texture sizes are pixels of the level's
largest atlas (``[0, 0]`` when untextured); byte counts are file sizes.

Quality metrics (``lods[].quality``, measured against LOD0 by ``exporter/quality.py``):
``triangle_ratio`` (share of LOD0's triangles), ``hausdorff_rel`` (Hausdorff distance over the
LOD0 bounding-box diagonal; lower is better), ``silhouette_iou`` and ``wall_coverage`` (0..1,
higher is better), ``boundary_length_change`` (relative change of open-border length; 0 is best),
``new_holes`` (count; 0 is best); ``texel_m`` (metres of surface per atlas texel, a property of
the level's texture, not a comparison). A level's ``error_m`` (metres) is the larger of its
geometric bound and its texture error (exporter/texel.py).
"""

from __future__ import annotations

import math
import statistics

# Metrics shown in plots and captions, in display order: key, plot title, short caption label.
METRICS = (
    ("triangle_ratio", "triangles / LOD0", "triangles"),
    ("silhouette_iou", "silhouette IoU", "silhouette"),
    ("wall_coverage", "wall coverage", "walls"),
    ("hausdorff_rel", "Hausdorff / diagonal", "Hausdorff"),
    ("boundary_length_change", "border length change", "border Δ"),
    ("new_holes", "new holes", "new holes"),
)

# The two metrics the worst-first order is decided by (lower = worse).
SCORE_METRICS = ("silhouette_iou", "wall_coverage")


def _number(value) -> float | None:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        return None
    return float(value)


def lod_metric(lod: dict, key: str) -> float | None:
    """A level's quality metric, or None when absent or not a finite number."""
    return _number((lod.get("quality") or {}).get(key))


def level_error(lod: dict) -> float | None:
    """A level's ``error_m`` (metres: the larger of its certified geometric bound and its texture
    error; written since 0.5.0), or None when absent or not a finite number."""
    return _number(lod.get("error_m"))


def quality_score(building: dict) -> float | None:
    """The building's worst ``silhouette_iou`` / ``wall_coverage`` over its reduced levels (0..1,
    lower = worse), or None when no reduced level has either metric."""
    metrics = [
        lod_metric(lod, key) for lod in building.get("lods", [])[1:] for key in SCORE_METRICS
    ]
    values = [v for v in metrics if v is not None]
    return min(values) if values else None


def worst_hausdorff(building: dict) -> float:
    values = [lod_metric(lod, "hausdorff_rel") for lod in building.get("lods", [])[1:]]
    return max((v for v in values if v is not None), default=0.0)


def worst_first(buildings: list[dict]) -> list[dict]:
    """Buildings ordered so problems surface: lowest quality score first, ties broken by the larger
    Hausdorff error, then id; buildings without metrics come last, by id."""

    def key(building: dict):
        score = quality_score(building)
        return (
            score is None,
            score if score is not None else 0.0,
            -worst_hausdorff(building),
            str(building.get("id", "")),
        )

    return sorted(buildings, key=key)


def level_count(manifest: dict) -> int:
    """Number of LoD levels of the tile (the longest chain of any building, at least the config's)."""
    chains = [len(b.get("lods", [])) for b in manifest.get("buildings", [])]
    heights = manifest.get("lod_group", {}).get("screen_relative_heights", [])
    return max(chains + [len(heights), 0])


def _lod_at(building: dict, level: int) -> dict | None:
    for lod in building.get("lods", []):
        if lod.get("level") == level:
            return lod
    return None


def level_table(manifest: dict) -> list[dict]:
    """One row per level, like the paper's Table III: counts, totals and ratios to LOD0.

    Keys: ``level``, ``transition`` (screen-relative height or None), ``buildings``,
    ``triangles`` (total), ``mean_triangles``, ``triangle_share`` (total / LOD0 total),
    ``mean_triangle_ratio`` (mean of per-building ``triangle_ratio``, None without metrics),
    ``vertices`` (total), ``texture_pixels`` (total of each building's largest atlas),
    ``pixel_share`` (/ LOD0), ``texture_sizes`` (list of ((w, h), count), most common first),
    ``file_bytes`` (total, None when the manifest has no sizes).
    """
    buildings = manifest.get("buildings", [])
    heights = manifest.get("lod_group", {}).get("screen_relative_heights", [])
    rows = []
    for level in range(level_count(manifest)):
        lods = [lod for lod in (_lod_at(b, level) for b in buildings) if lod is not None]
        sizes: dict[tuple, int] = {}
        for lod in lods:
            size = tuple(int(v) for v in lod.get("texture_size", [0, 0])[:2])
            sizes[size] = sizes.get(size, 0) + 1
        ratios = [v for v in (lod_metric(lod, "triangle_ratio") for lod in lods) if v is not None]
        byte_counts = [lod.get("file_bytes") for lod in lods]
        rows.append(
            {
                "level": level,
                "transition": heights[level] if level < len(heights) else None,
                "buildings": len(lods),
                "triangles": sum(int(lod.get("triangles", 0)) for lod in lods),
                "mean_triangles": statistics.fmean(int(lod.get("triangles", 0)) for lod in lods)
                if lods
                else 0.0,
                "mean_triangle_ratio": statistics.fmean(ratios) if ratios else None,
                "vertices": sum(int(lod.get("vertices", 0)) for lod in lods),
                "texture_pixels": sum(w * h for (w, h), n in sizes.items() for _ in range(n)),
                "texture_sizes": sorted(
                    sizes.items(), key=lambda item: (-item[1], -item[0][0] * item[0][1])
                ),
                "file_bytes": sum(b for b in byte_counts if isinstance(b, int))
                if lods and all(isinstance(b, int) for b in byte_counts)
                else None,
            }
        )
    base_triangles = rows[0]["triangles"] if rows else 0
    base_pixels = rows[0]["texture_pixels"] if rows else 0
    for row in rows:
        row["triangle_share"] = row["triangles"] / base_triangles if base_triangles else None
        row["pixel_share"] = row["texture_pixels"] / base_pixels if base_pixels else None
    return rows


def metric_series(manifest: dict, key: str) -> list[tuple[int, list[tuple[str, float]]]]:
    """Per reduced level (1, 2, ...): the (building id, value) pairs of metric ``key``."""
    series = []
    for level in range(1, level_count(manifest)):
        points = []
        for building in manifest.get("buildings", []):
            lod = _lod_at(building, level)
            value = lod_metric(lod, key) if lod is not None else None
            if value is not None:
                points.append((str(building.get("id", "")), value))
        series.append((level, points))
    return series


def metric_stats(values: list[float]) -> dict | None:
    """min / median / max of a list of numbers (None when empty)."""
    if not values:
        return None
    return {"min": min(values), "median": statistics.median(values), "max": max(values)}
