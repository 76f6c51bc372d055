"""Manifest assembly: the tile's Table III summary and the schema."""

import jsonschema
import pytest

from exporter.config import Config
from exporter.manifest import build_manifest, summarize_levels, validate_manifest
from exporter.model import Skipped, TileId

PLACEMENT = {"position": [0.0, 0.0, 0.0], "rotation": [0.0, 0.0, 0.0, 1.0], "scale": 1.0}


def record(building_id, triangles, quality=None):
    lods = []
    for level, count in enumerate(triangles):
        lods.append(
            {
                "level": level,
                "file": f"{building_id}/lod{level}.glb",
                "triangles": count,
                "vertices": count * 2,
                "texture_size": [1024 >> level, 1024 >> level],
                "quality": dict(quality or {}, triangle_ratio=count / triangles[0]),
            }
        )
    return {
        "id": building_id,
        "source": "x.xdo",
        "center": {"lon": 127.0, "lat": 37.5, "elev": 10.0},
        "placement": PLACEMENT,
        "relative_placement": PLACEMENT,
        "lods": lods,
        "problems": [],
    }


def test_summary_is_the_papers_table_iii_for_the_tile():
    buildings = [
        record("a", [400, 270, 190], {"silhouette_iou": 0.99}),
        record("b", [200, 130, 100], {"silhouette_iou": 0.97}),
    ]
    levels = summarize_levels(buildings, 3)
    assert [lv["mean_triangles"] for lv in levels] == [300.0, 200.0, 145.0]
    assert levels[1]["ratio_to_lod0"] == pytest.approx(200 / 300) and levels[2][
        "ratio_to_lod0"
    ] == pytest.approx(145 / 300)
    assert levels[1]["quality_min"]["silhouette_iou"] == 0.97 and levels[1]["quality_mean"][
        "silhouette_iou"
    ] == pytest.approx(0.98)
    assert levels[2]["mean_texture_pixels"] == 256 * 256


def test_built_manifest_validates_and_schema_catches_breakage():
    manifest = build_manifest(
        TileId(15, 1, 2),
        (0.0, 0.0, 0.1, 0.1),
        {"lon": 0.05, "lat": 0.05, "elev": 0.0},
        PLACEMENT,
        Config(),
        [record("b", [10, 6, 4]), record("a", [12, 8, 5])],
        [Skipped("bad.xdo", "truncated", "c")],
    )
    validate_manifest(manifest)
    assert [b["id"] for b in manifest["buildings"]] == ["a", "b"]
    assert manifest["summary"]["skipped"] == 1 and manifest["skipped"][0] == {
        "source": "bad.xdo",
        "reason": "truncated",
        "id": "c",
    }
    assert manifest["lod_group"]["screen_relative_heights"] == [0.5, 0.17, 0.02]
    broken = dict(manifest, lod_group=dict(manifest["lod_group"], screen_relative_heights=[[0.5]]))
    with pytest.raises(jsonschema.ValidationError):
        validate_manifest(broken)
    broken = dict(manifest, buildings=[dict(manifest["buildings"][0], lods=[])])
    with pytest.raises(jsonschema.ValidationError):
        validate_manifest(broken)
