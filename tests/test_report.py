"""The HTML LoD report (exporter/report): page numbers, images, worst-first order, renders.

Fixture: a small fake export written with the project's own glTF writer (local East/Up/North ->
glTF West/Up/North) and a manifest following docs/ARCHITECTURE.md, so the test does not depend on
the simplifier; one test runs the real pipeline on the real Rotterdam data when it is present.
"""

from __future__ import annotations

import io
import json
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageDraw

from exporter.errors import InputError
from exporter.gltf_writer import glb_bytes
from exporter.model import Part, Texture
from exporter.report import image_name, write_reports
from exporter.report.plots import nice_ticks, strip_plot_svg
from exporter.report.render import BACKGROUND, Mesh, fit_view, load_glb, render
from exporter.report.summary import level_table, quality_score, worst_first

TILE = "15_279418_116113"
WALL, WINDOW, ROOF = (176, 96, 60), (40, 90, 200), (200, 30, 30)
BACKGROUND_RGB = np.round(BACKGROUND * 255).astype(int)


# --------------------------------------------------------------------------- fake export


def atlas_jpeg(size: int) -> bytes:
    """Left half: brick-coloured wall with blue windows; right half: red roof."""
    image = Image.new("RGB", (size, size), WALL)
    draw = ImageDraw.Draw(image)
    step = size // 8
    for i in range(4):
        for j in range(8):
            draw.rectangle(
                [
                    i * step + step // 4,
                    j * step + step // 4,
                    i * step + 3 * step // 4,
                    j * step + 3 * step // 4,
                ],
                fill=WINDOW,
            )
    draw.rectangle([size // 2, 0, size, size], fill=ROOF)
    out = io.BytesIO()
    image.save(out, format="JPEG", quality=92)
    return out.getvalue()


def box_part(
    width: float,
    depth: float,
    height: float,
    cuts: int,
    texture_size: int,
    east_offset: float = 0.0,
) -> Part:
    """A floorless box (local East/Up/North metres, centred on the origin's vertical axis, base at
    Up = 0), walls split into cuts x cuts quads, flat roof; outward winding; glTF-convention UVs
    (origin top-left): walls map to the atlas' left half, the roof to its right half."""
    positions, triangles, uvs = [], [], []

    def grid(origin, du, dv, uv0, uvu, uvv, n):
        base = len(positions)
        for i in range(n + 1):
            for j in range(n + 1):
                positions.append(origin + du * i / n + dv * j / n)
                uvs.append(uv0 + uvu * i / n + uvv * j / n)
        for i in range(n):
            for j in range(n):
                a, b = base + i * (n + 1) + j, base + (i + 1) * (n + 1) + j
                triangles.extend([[a, a + 1, b + 1], [a, b + 1, b]])

    corners = [
        (-width / 2, -depth / 2),
        (width / 2, -depth / 2),
        (width / 2, depth / 2),
        (-width / 2, depth / 2),
    ]
    for k in range(4):
        (x0, z0), (x1, z1) = corners[k], corners[(k + 1) % 4]
        grid(
            np.array([x0 + east_offset, 0.0, z0]),
            np.array([x1 - x0, 0, z1 - z0]),
            np.array([0, height, 0]),
            np.array([0.0, 1.0]),
            np.array([0.5, 0]),
            np.array([0, -1.0]),
            cuts,
        )
    grid(
        np.array([-width / 2 + east_offset, height, -depth / 2]),
        np.array([width, 0, 0]),
        np.array([0, 0, depth]),
        np.array([0.5, 1.0]),
        np.array([0.5, 0]),
        np.array([0, -1.0]),
        1,
    )
    positions, triangles = np.array(positions), np.array(triangles)
    a, b, c = (positions[triangles[:, i]] for i in range(3))
    inward = (
        np.einsum(
            "ij,ij->i", np.cross(b - a, c - a), (a + b + c) / 3 - [east_offset, height / 2, 0]
        )
        < 0
    )
    triangles[inward] = triangles[inward][:, ::-1]
    texture = Texture(
        atlas_jpeg(texture_size), "image/jpeg", texture_size, texture_size, name="atlas.jpg"
    )
    return Part(positions, triangles, uvs=np.array(uvs), texture=texture)


def fake_building(
    tile_dir: Path, building_id: str, size: tuple, quality: list[dict], missing_level=None
) -> dict:
    """Write lod0..lod2 of a box building and return its manifest record."""
    lods = []
    for level, (cuts, texture) in enumerate([(6, 256), (3, 128), (1, 64)]):
        part = box_part(*size, cuts, texture)
        file_name = f"{building_id}/lod{level}.glb"
        data = glb_bytes([part], building_id)
        if level != missing_level:
            (tile_dir / building_id).mkdir(parents=True, exist_ok=True)
            (tile_dir / file_name).write_bytes(data)
        lods.append(
            {
                "level": level,
                "file": file_name,
                "triangles": part.triangle_count,
                "vertices": part.vertex_count,
                "texture_size": [texture, texture],
                "texture_bytes": len(part.texture.data),
                "file_bytes": len(data),
                "quality": quality[level],
            }
        )
    placement = {"position": [0.0, 0.0, 0.0], "rotation": [0.0, 0.0, 0.0, 1.0], "scale": 1.0}
    return {
        "id": building_id,
        "source": f"src/{building_id}.xdo",
        "input_hash": "0" * 64,
        "center": {"lon": 126.978, "lat": 37.5665, "elev": 20.0},
        "placement": placement,
        "relative_placement": placement,
        "lods": lods,
        "problems": [],
    }


def metrics(ratio: float, iou: float, coverage: float, hausdorff: float = 0.01) -> dict:
    return {
        "triangle_ratio": ratio,
        "hausdorff_rel": hausdorff,
        "silhouette_iou": iou,
        "wall_coverage": coverage,
        "boundary_length_change": 0.0,
        "new_holes": 0.0,
    }


# (id, size in metres, LOD1 quality, LOD2 quality); the expected worst-first order is C, A, D, B.
BUILDINGS = [
    ("A", (20.0, 12.0, 15.0), metrics(0.5, 0.97, 0.95), metrics(0.15, 0.90, 0.85)),
    ("B", (10.0, 10.0, 30.0), metrics(0.5, 0.99, 0.99), metrics(0.15, 0.98, 0.97)),
    ("C", (30.0, 8.0, 6.0), metrics(0.5, 0.80, 0.95), metrics(0.15, 0.60, 0.90)),
    ("D", (15.0, 15.0, 9.0), metrics(0.5, 0.95, 0.95), metrics(0.15, 0.93, 0.96, hausdorff=0.2)),
]
EXPECTED_ORDER = ["C", "A", "D", "B"]


def make_fake_export(
    out: Path, tile: str = TILE, missing: tuple = ("D", 2), only: str = "ABCD"
) -> Path:
    """A fake export folder ``out`` with one tile (the ``only`` buildings of BUILDINGS, 3 levels,
    one skipped building and one level file missing); returns the tile folder."""
    tile_dir = out / tile
    tile_dir.mkdir(parents=True)
    base = metrics(1.0, 1.0, 1.0, 0.0)
    buildings = [
        fake_building(
            tile_dir, bid, size, [base, q1, q2], missing[1] if bid == missing[0] else None
        )
        for bid, size, q1, q2 in BUILDINGS
        if bid in only
    ]
    level, idx, idy = (int(v) for v in tile.split("_"))
    placement = {"position": [0.0, 0.0, 0.0], "rotation": [0.0, 0.0, 0.0, 1.0], "scale": 1.0}
    manifest = {
        "format": "vworld-lod-manifest",
        "version": "1.0",
        "generator": {"name": "vworld-lod", "version": "0.1.0"},
        "config": {
            "lods": [],
            "simplify": {},
            "globe": {},
            "unity": {},
            "textures": {},
            "readers": {},
        },
        "tile": {
            "level": level,
            "idx": idx,
            "idy": idy,
            "name": tile,
            "bounds": {"west": 126.97, "south": 37.56, "east": 126.98, "north": 37.57},
            "center": {"lon": 126.975, "lat": 37.565, "elev": 0.0},
            "placement": placement,
        },
        "globe": {
            "earth_radius_m": 6378137.0,
            "unity_radius": 6378137.0,
            "handedness": "left",
            "up": "y",
            "placement": "tile_relative",
        },
        "lod_group": {
            "screen_relative_heights": [0.5, 0.17, 0.02],
            "fade_mode": "none",
            "animate_cross_fading": False,
            "fade_transition_width": 0.0,
            "terrain_levels": [15, 14, 13],
        },
        "buildings": buildings,
        "skipped": [
            {
                "source": "src/E.xdo",
                "reason": "E.xdo: truncated mesh block (needs 3200 bytes, has 17)",
                "id": "E",
            }
        ],
        "summary": {
            "buildings": len(buildings),
            "skipped": 1,
            "levels": [{"level": 0, "mean_triangles": 1.0, "ratio_to_lod0": 1.0}],
        },
    }
    (tile_dir / "lod_manifest.json").write_text(json.dumps(manifest, indent=1), encoding="utf-8")
    return tile_dir


# --------------------------------------------------------------------------- HTML helpers


class Page(HTMLParser):
    """Collects what the tests look at: images per building article, tables' rows, element ids."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.articles: list[dict] = []
        self.images: list[str] = []  # renders
        self.atlas: list[str] = []  # atlas details
        self.missing: list[str] = []
        self.tables: dict[str, list[list[str]]] = {}
        self.links: list[str] = []
        self._table = None
        self._cell = None
        self._in_missing = False
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "article":
            self.articles.append(
                {"id": attrs.get("data-building-id"), "images": [], "atlas": [], "missing": []}
            )
        elif tag == "img":
            kind = "atlas" if attrs.get("class") == "atlas" else "images"
            if kind == "images":
                self.images.append(attrs["src"])
            else:
                self.atlas.append(attrs["src"])
            if self.articles:
                self.articles[-1][kind].append(attrs["src"])
        elif tag == "div" and attrs.get("class") == "missing":
            self._in_missing = True
        elif tag == "table" and attrs.get("id"):
            self._table = attrs["id"]
            self.tables[self._table] = []
        elif tag == "tr" and self._table:
            self.tables[self._table].append([])
        elif tag in ("td", "th") and self._table:
            self._cell = ""
        elif tag == "a":
            self.links.append(attrs.get("href"))

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._table and self._cell is not None:
            self.tables[self._table][-1].append(self._cell.strip())
            self._cell = None
        elif tag == "table":
            self._table = None
        elif tag == "div":
            self._in_missing = False

    def handle_data(self, data):
        if self._cell is not None:
            self._cell += data
        if self._in_missing and self.articles:
            self.articles[-1]["missing"].append(data)


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    out = tmp_path_factory.mktemp("out")
    tile_dir = make_fake_export(out)
    pages = write_reports(out)
    page = Page((tile_dir / "report.html").read_text(encoding="utf-8"))
    return out, tile_dir, pages, page


def _manifest(tile_dir: Path) -> dict:
    return json.loads((tile_dir / "lod_manifest.json").read_text(encoding="utf-8"))


# --------------------------------------------------------------------------- the pages


def test_returns_tile_page_then_index(report):
    out, tile_dir, pages, _ = report
    assert pages == [tile_dir / "report.html", out / "index.html"]
    assert all(p.is_file() and p.stat().st_size > 1000 for p in pages)


def test_level_table_has_the_manifest_numbers(report):
    _, tile_dir, _, page = report
    manifest = _manifest(tile_dir)
    rows = page.tables["level-table"][1:]
    assert [r[0] for r in rows] == ["LOD0", "LOD1", "LOD2"]
    assert [r[1] for r in rows] == ["50 %", "17 %", "2 %"]
    totals = [sum(b["lods"][k]["triangles"] for b in manifest["buildings"]) for k in range(3)]
    assert [int(r[3].replace(",", "")) for r in rows] == totals
    shares = [float(r[5].rstrip(" %")) for r in rows]
    assert shares == pytest.approx([100 * t / totals[0] for t in totals], abs=0.05)
    assert shares[0] == 100.0 and shares[2] < shares[1] < 100.0
    # Texture pixels: each building's atlas, a quarter per level.
    pixels = [int(r[8].replace(",", "")) for r in rows]
    assert pixels == [4 * 256 * 256, 4 * 128 * 128, 4 * 64 * 64]
    assert "256×256 ×4" in rows[0][10]


def test_skipped_buildings_listed_with_reason(report):
    _, _, _, page = report
    assert page.tables["skipped-table"][1] == [
        "E",
        "src/E.xdo",
        "E.xdo: truncated mesh block (needs 3200 bytes, has 17)",
    ]


def test_quality_table_per_level(report):
    _, _, _, page = report
    rows = {(r[0], r[1]): r for r in page.tables["quality-table"][1:]}
    iou2 = [q2["silhouette_iou"] for _, _, _, q2 in BUILDINGS]
    assert float(rows[("silhouette_iou", "LOD2")][3]) == pytest.approx(min(iou2))
    assert float(rows[("silhouette_iou", "LOD2")][5]) == pytest.approx(max(iou2))
    assert rows[("silhouette_iou", "LOD2")][2] == str(len(BUILDINGS))


def test_plots_are_inline_svg_with_a_dot_per_building_and_level(report):
    _, tile_dir, _, _ = report
    text = (tile_dir / "report.html").read_text(encoding="utf-8")
    svgs = re.findall(r"<svg.*?</svg>", text, flags=re.S)
    titles = [re.search(r'aria-label="([^"]+)"', s).group(1) for s in svgs]
    assert "silhouette IoU" in titles and "wall coverage" in titles
    iou = svgs[titles.index("silhouette IoU")]
    assert iou.count("<circle") == 2 * len(BUILDINGS)
    assert "C: 0.6" in iou  # tooltips name the building
    assert (
        "http://" not in text.replace('xmlns="http://www.w3.org/2000/svg"', "")
        and "https://" not in text
    )


def test_one_image_per_building_per_level_worst_first(report):
    _, tile_dir, _, page = report
    assert [a["id"] for a in page.articles] == EXPECTED_ORDER
    for article in page.articles:
        expected = 2 if article["id"] == "D" else 3
        assert len(article["images"]) == expected, article
        for src in article["images"]:
            assert not src.startswith(("/", "file:", "http")), src
            assert (tile_dir / src).is_file()
    d = next(a for a in page.articles if a["id"] == "D")
    assert any("D/lod2.glb: file missing" in text for text in d["missing"]), d["missing"]


def test_renders_show_the_textured_building(report):
    _, tile_dir, _, page = report
    for src in page.images:
        image = np.asarray(Image.open(tile_dir / src).convert("RGB")).astype(int)
        assert image.shape == (256, 256, 3)
        background = np.abs(image - BACKGROUND_RGB).sum(axis=2) < 12
        assert 0.1 < 1.0 - background.mean() < 0.95, src  # the building fills a fair part, not all
        r, g, b = image[..., 0], image[..., 1], image[..., 2]
        assert ((r > 2.5 * g) & (r > 2.5 * b) & (r > 90)).mean() > 0.01, src  # red roof
        if "lod2" not in src:  # 64 px atlas: windows still there but blurred by JPEG
            assert ((b > r + 50) & (b > g + 30)).mean() > 0.003, src  # blue windows


def test_atlas_detail_shows_the_same_region_at_each_level_resolution(report):
    _, tile_dir, _, page = report
    a = next(x for x in page.articles if x["id"] == "A")
    assert a["atlas"] == [f"report/A_lod{k}_atlas.png" for k in range(3)]
    crops = [
        np.asarray(Image.open(tile_dir / src).convert("RGB")).astype(int) for src in a["atlas"]
    ]
    assert [c.shape[:2] for c in crops] == [(32, 32), (16, 16), (8, 8)]  # 1/8 of 256, 128, 64 px
    # Same content: LOD0's crop reduced to LOD2's size is close to LOD2's crop.
    reduced = crops[0].reshape(8, 4, 8, 4, 3).mean(axis=(1, 3))
    assert np.abs(reduced - crops[2]).mean() < 40
    assert len(page.atlas) == len(page.images)


def test_same_view_for_every_level(report):
    _, tile_dir, _, page = report
    a = next(x for x in page.articles if x["id"] == "A")
    masks = [
        np.abs(
            np.asarray(Image.open(tile_dir / s).convert("RGB")).astype(int) - BACKGROUND_RGB
        ).sum(axis=2)
        > 40
        for s in a["images"]
    ]
    for mask in masks[1:]:  # same box geometry at every level -> nearly the same silhouette
        assert (mask & masks[0]).sum() / (mask | masks[0]).sum() > 0.97


def test_index_links_every_tile(tmp_path):
    make_fake_export(tmp_path, TILE)
    make_fake_export(tmp_path, "15_279419_116113")
    (tmp_path / "not_a_tile").mkdir()
    pages = write_reports(tmp_path, tiles=["15_279419_116113"])
    assert pages == [tmp_path / "15_279419_116113" / "report.html", tmp_path / "index.html"]
    index = Page((tmp_path / "index.html").read_text(encoding="utf-8"))
    rows = index.tables["tile-table"][1:]
    assert [r[0] for r in rows] == [TILE, "15_279419_116113"]
    assert rows[0][-1] == "not rendered" and rows[1][-1] == "report"
    assert rows[1][-2] == "C (0.600)"
    assert "15_279419_116113/report.html" in index.links
    worst = index.tables["worst-table"][1:]
    assert [(r[1], r[2], r[3]) for r in worst[:2]] == [
        (TILE, "C", "0.600"),
        ("15_279419_116113", "C", "0.600"),
    ]
    assert [r[2] for r in worst] == ["C", "C", "A", "A", "D", "D", "B", "B"]
    assert "15_279419_116113/report.html#building-C" in index.links  # only the rendered tile links
    assert not any(link.startswith(f"{TILE}/") for link in index.links)
    assert not (tmp_path / TILE / "report.html").exists()


def test_stale_images_removed(tmp_path):
    tile_dir = make_fake_export(tmp_path, missing=("A", 9), only="A")
    stale = tile_dir / "report" / "Z_lod0.png"
    stale.parent.mkdir()
    stale.write_bytes(b"old")
    write_reports(tmp_path)
    assert not stale.exists() and (tile_dir / "report" / "A_lod0.png").is_file()


def test_bad_inputs_raise_input_error_naming_the_file(tmp_path):
    with pytest.raises(InputError, match="not a folder"):
        write_reports(tmp_path / "nope")
    with pytest.raises(InputError, match="no <level>_<idx>_<idy>/lod_manifest.json"):
        write_reports(tmp_path)
    tile_dir = tmp_path / TILE
    tile_dir.mkdir()
    (tile_dir / "lod_manifest.json").write_text("{not json", encoding="utf-8")
    with pytest.raises(
        InputError, match=re.escape(str(tile_dir / "lod_manifest.json")) + ": not valid JSON"
    ):
        write_reports(tmp_path)
    with pytest.raises(InputError, match="15_1_1"):
        write_reports(tmp_path, tiles=["15_1_1"])


def test_unreadable_manifest_of_another_tile_is_flagged_on_the_index(tmp_path):
    make_fake_export(tmp_path, only="A")
    bad = tmp_path / "15_279419_116113"
    bad.mkdir()
    (bad / "lod_manifest.json").write_text('{"format": "vworld-lod-manifest"}', encoding="utf-8")
    write_reports(tmp_path, tiles=[TILE])
    rows = Page((tmp_path / "index.html").read_text(encoding="utf-8")).tables["tile-table"][1:]
    assert rows[1][0] == "15_279419_116113" and "no 'buildings' list" in rows[1][1]
    with pytest.raises(
        InputError, match="15_279419_116113/lod_manifest.json: not a vworld-lod manifest"
    ):
        write_reports(tmp_path)


def test_broken_glb_gets_a_placeholder_not_a_crash(tmp_path):
    tile_dir = make_fake_export(tmp_path, missing=("A", 9), only="B")
    write_reports(tmp_path)
    assert (tile_dir / "report" / "B_lod1.png").is_file()
    (tile_dir / "B" / "lod1.glb").write_bytes(b"glTF but not really")
    write_reports(tmp_path)
    page = Page((tile_dir / "report.html").read_text(encoding="utf-8"))
    b = next(a for a in page.articles if a["id"] == "B")
    assert len(b["images"]) == 2 and any(
        "B/lod1.glb" in t and "cannot be read" in t for t in b["missing"]
    )
    assert not (tile_dir / "report" / "B_lod1.png").exists()  # no stale picture of the broken level


def test_problems_shown_and_empty_tile_still_reported(tmp_path):
    tile_dir = make_fake_export(tmp_path, missing=("A", 9), only="B")
    manifest = _manifest(tile_dir)
    manifest["buildings"][0]["problems"] = ["texture B.jpg missing: exported untextured"]
    (tile_dir / "lod_manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
    empty = make_fake_export(tmp_path, "15_279419_116113", only="")
    manifest = _manifest(empty)
    manifest["skipped"] += [
        {"source": f"src/{b}.xdo", "reason": "unreadable", "id": b} for b in "ABCD"
    ]
    (empty / "lod_manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
    write_reports(tmp_path)
    assert "<li>texture B.jpg missing: exported untextured</li>" in (
        tile_dir / "report.html"
    ).read_text(encoding="utf-8")
    page = Page((empty / "report.html").read_text(encoding="utf-8"))
    assert page.articles == [] and len(page.tables["skipped-table"]) == 1 + 5
    assert [r[2] for r in page.tables["level-table"][1:]] == ["0", "0", "0"]
    assert not (empty / "report").exists() or not any((empty / "report").iterdir())


# --------------------------------------------------------------------------- renderer


def test_load_glb_returns_local_frame(tmp_path):
    part = box_part(10.0, 4.0, 3.0, 1, 64, east_offset=20.0)  # centred 20 m East
    path = tmp_path / "b.glb"
    path.write_bytes(glb_bytes([part], "b"))
    (mesh,) = load_glb(path)
    assert mesh.positions[:, 0].mean() == pytest.approx(20.0, abs=1e-4)  # East again, not West
    # Outward winding survives the round trip: normals of the top face point up.
    a, b, c = (mesh.positions[mesh.triangles[:, i]] for i in range(3))
    normals = np.cross(b - a, c - a)
    top = np.isclose(a[:, 1], 3.0) & np.isclose(b[:, 1], 3.0) & np.isclose(c[:, 1], 3.0)
    assert top.any() and (normals[top, 1] > 0).all()
    assert mesh.image is not None and mesh.image.shape == (64, 64, 3)


def test_untextured_part_renders_in_its_material_colour(tmp_path):
    part = box_part(10.0, 10.0, 10.0, 1, 64)
    plain = Part(part.positions, part.triangles, color=(0.1, 0.7, 0.1, 1.0))
    path = tmp_path / "plain.glb"
    path.write_bytes(glb_bytes([plain], "plain"))
    (mesh,) = load_glb(path)
    assert mesh.image is None and mesh.color == pytest.approx([0.1, 0.7, 0.1], abs=0.01)
    image = render([mesh], fit_view([mesh], size=96)).astype(int)
    assert (
        (image[..., 1] > image[..., 0] + 50) & (image[..., 1] > image[..., 2] + 50)
    ).mean() > 0.1


def test_inside_faces_are_dimmed_not_dropped():
    from exporter.report.render import BACK_FACE_DIM, face_shading

    # The same triangle wound both ways: seen from the eye, one shows its outside, one its inside.
    positions = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    triangles = np.array([[0, 1, 2], [0, 2, 1]])
    for eye in (np.array([0.3, 0.3, 5.0]), np.array([0.3, 0.3, -5.0])):
        light = face_shading(positions, triangles, eye)
        outside, inside = light if np.cross(positions[1], positions[2]) @ eye > 0 else light[::-1]
        assert inside == pytest.approx(outside * BACK_FACE_DIM) and inside > 0


def test_triangle_behind_the_camera_is_skipped():
    part = box_part(10.0, 10.0, 10.0, 1, 64)
    box = Mesh(part.positions, part.triangles, color=np.array([0.5, 0.5, 0.5], dtype=np.float32))
    view = fit_view([box], size=96)
    # A broken level: one extra triangle with a corner far behind the camera.
    spike = np.vstack([part.positions, view.eye - view.forward * 50.0])
    broken = Mesh(spike, np.vstack([part.triangles, [[0, 1, len(spike) - 1]]]), color=box.color)
    assert np.array_equal(render([broken], view), render([box], view))


def test_bilinear_sampling_wraps_like_repeat():
    from exporter.report.render import sample_bilinear

    image = np.array([[[0, 0, 0], [200, 100, 0]]], dtype=np.uint8)  # 2 x 1 pixels
    texels = np.array([[0.5, 0.5], [1.0, 0.5], [1.5, 0.5], [0.0, 0.5], [2.25, 0.5]])
    values = sample_bilinear(image, texels)[:, 0]
    assert values == pytest.approx([0.0, 100.0, 200.0, 100.0, 50.0])  # x = 0 and 2.25 wrap around


def test_fragments_match_a_per_pixel_inside_test():
    from exporter.report.render import fragments

    rng = np.random.default_rng(7)
    size = 40
    screen = np.column_stack(
        [rng.uniform(-10, 50, (60, 2)), rng.uniform(1, 5, 60)]
    )  # some off-image
    triangles = rng.integers(0, 60, (50, 3))
    triangles = triangles[
        (triangles[:, 0] != triangles[:, 1])
        & (triangles[:, 1] != triangles[:, 2])
        & (triangles[:, 0] != triangles[:, 2])
    ]
    rows, cols, faces, weights = (
        np.concatenate(parts) for parts in zip(*fragments(screen, triangles, size))
    )
    found = set(zip(rows.tolist(), cols.tolist(), faces.tolist()))
    # The weights interpolate the corners back to the pixel centre.
    centres = np.einsum("ki,kij->kj", weights, screen[triangles[faces], :2])
    assert np.abs(centres - np.column_stack([cols, rows]) - 0.5).max() < 1e-3
    expected = set()
    ys, xs = np.mgrid[0:size, 0:size] + 0.5
    for f, (i, j, k) in enumerate(triangles):
        (xa, ya), (xb, yb), (xc, yc) = screen[[i, j, k], :2]
        area = (xb - xa) * (yc - ya) - (xc - xa) * (yb - ya)
        w0 = ((xb - xs) * (yc - ys) - (xc - xs) * (yb - ys)) / area
        w1 = ((xc - xs) * (ya - ys) - (xa - xs) * (yc - ys)) / area
        inside = (w0 >= 0) & (w1 >= 0) & (1 - w0 - w1 >= 0)
        expected |= {(int(r), int(c), f) for r, c in zip(*np.nonzero(inside))}
    assert len(expected) > 500 and found == expected and len(rows) == len(found)


def test_uv_origin_is_the_top_left_of_the_image_as_in_gltf(tmp_path):
    image = Image.new("RGB", (64, 64), (20, 20, 220))
    image.paste((220, 20, 20), (0, 0, 32, 32))  # only the top-left quadrant is red
    data = io.BytesIO()
    image.save(data, format="PNG")
    part = box_part(10.0, 10.0, 10.0, 1, 64)
    part.uvs = np.full((part.vertex_count, 2), 0.25, dtype=np.float32)  # glTF: top-left quadrant
    part.texture = Texture(data.getvalue(), "image/png", 64, 64, name="quadrants.png")
    path = tmp_path / "q.glb"
    path.write_bytes(glb_bytes([part], "q"))
    meshes = load_glb(path)
    picture = render(meshes, fit_view(meshes, size=64)).astype(int)
    red = (picture[..., 0] > picture[..., 2] + 60).mean()
    blue = (picture[..., 2] > picture[..., 0] + 60).mean()
    assert red > 0.2 and blue < 0.01


def test_render_is_not_mirrored():
    # A low box with a tall tower at its East end, seen from the south: the tower is on the right.
    base = box_part(30.0, 6.0, 4.0, 1, 64)
    tower = box_part(4.0, 4.0, 20.0, 1, 64, east_offset=12.0)
    meshes = [
        Mesh(p.positions, p.triangles, color=np.array([0.5, 0.5, 0.5], dtype=np.float32))
        for p in (base, tower)
    ]
    view = fit_view(meshes, size=128, azimuth_deg=180.0, elevation_deg=10.0)
    image = render(meshes, view).astype(int)
    building = np.abs(image - BACKGROUND_RGB).sum(axis=2) > 40
    top_rows = building[: 128 // 3]  # only the tower reaches the upper third
    columns = np.nonzero(top_rows.any(axis=0))[0]
    assert len(columns) and columns.min() > 64


def test_render_untextured_uses_base_colour_and_lambert_shading():
    part = box_part(10.0, 10.0, 10.0, 1, 64)
    green = Mesh(part.positions, part.triangles, color=np.array([0.1, 0.8, 0.1], dtype=np.float32))
    image = render([green], fit_view([green], size=96)).astype(int)
    greenish = (image[..., 1] > image[..., 0] + 60) & (image[..., 1] > image[..., 2] + 60)
    assert greenish.mean() > 0.1
    # Faces at different angles to the sun get different brightness.
    assert len(np.unique(image[greenish][:, 1] // 10)) >= 3


def test_texture_lookup_is_perspective_correct():
    # A 40 m square roof seen obliquely; its atlas is blue for v < 0.5 (South half) and red above.
    # The colour edge must sit where the roof's 3D midline (North = 0) projects, not where a plain
    # screen-space (affine) interpolation of the UVs would put it.
    positions = np.array(
        [[-20.0, 5.0, -20.0], [20.0, 5.0, -20.0], [20.0, 5.0, 20.0], [-20.0, 5.0, 20.0]]
    )
    triangles = np.array([[0, 2, 1], [0, 3, 2]])
    uvs = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])  # v up from the bottom row
    image = np.zeros((64, 64, 3), dtype=np.uint8)
    image[:32] = (220, 20, 20)  # top rows = v > 0.5
    image[32:] = (20, 20, 220)
    roof = Mesh(positions, triangles, uvs=uvs, image=image)
    view = fit_view([roof], size=256, azimuth_deg=180.0, elevation_deg=25.0, fov_deg=60.0)
    picture = render([roof], view, supersample=1).astype(int)
    from exporter.report.render import project

    corners = project(positions, view, 256)
    midline = project(np.array([[0.0, 5.0, 0.0]]), view, 256)[0]
    column = int(midline[0])
    blue = np.nonzero(picture[:, column, 2] > picture[:, column, 0] + 50)[0]
    edge = blue.min()  # North is up in the image: red above, blue below
    affine = (corners[0, 1] + corners[3, 1]) / 2.0  # the screen midpoint of the West edge's rows
    assert abs(affine - midline[1]) > 4.0  # the test can tell the two apart
    assert abs(edge - midline[1]) <= 1.5


# --------------------------------------------------------------------------- pure helpers


def test_worst_first_puts_unmeasured_last():
    buildings = [
        {"id": "x", "lods": [{}]},
        {"id": "y", "lods": [{}, {"quality": {"wall_coverage": 0.5}}]},
        {"id": "z", "lods": [{}, {"quality": {"silhouette_iou": 0.9, "wall_coverage": 0.95}}]},
    ]
    assert [b["id"] for b in worst_first(buildings)] == ["y", "z", "x"]
    assert quality_score(buildings[0]) is None and quality_score(buildings[2]) == 0.9


def test_level_table_ratios():
    manifest = {
        "lod_group": {"screen_relative_heights": [0.5, 0.1]},
        "buildings": [
            {
                "lods": [
                    {"level": 0, "triangles": 100, "texture_size": [64, 64]},
                    {"level": 1, "triangles": 40, "texture_size": [32, 32]},
                ]
            },
            {
                "lods": [
                    {"level": 0, "triangles": 300, "texture_size": [0, 0]},
                    {"level": 1, "triangles": 200, "texture_size": [0, 0]},
                ]
            },
        ],
    }
    rows = level_table(manifest)
    assert rows[1]["triangle_share"] == pytest.approx(240 / 400)
    assert rows[1]["pixel_share"] == pytest.approx(0.25)
    assert rows[0]["mean_triangles"] == 200 and rows[1]["file_bytes"] is None


def test_plot_helpers():
    assert nice_ticks(0.0, 1.0) == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert nice_ticks(-0.03, 0.11) == [0.0, 0.05, 0.1]
    assert nice_ticks(0.0, 7.0) == [0.0, 2.0, 4.0, 6.0]
    svg = strip_plot_svg("t<x>", [("LOD1", [("a", 0.2), ("b", 0.4)]), ("LOD2", [])], (0.0, 1.0))
    assert svg.count("<circle") == 2 and "no data" in svg and "t&lt;x&gt;" in svg


def test_image_name_uses_the_output_folder():
    assert (
        image_name({"id": "a/b", "lods": [{"file": "a_b_1234/lod0.glb"}]}, 2) == "a_b_1234_lod2.png"
    )
    assert image_name({"id": "a/b c", "lods": [{}]}, 0) == "a_b_c_lod0.png"


# --------------------------------------------------------------------------- the real pipeline


def _building_pixels(path: Path) -> np.ndarray:
    image = np.asarray(Image.open(path).convert("RGB")).astype(int)
    ground = np.round(np.array([0.82, 0.84, 0.80]) * 255).astype(int)
    shadow = np.round(np.array([0.62, 0.64, 0.61]) * 255).astype(int)
    keep = (
        (np.abs(image - BACKGROUND_RGB).sum(axis=2) > 12)
        & (np.abs(image - ground).sum(axis=2) > 12)
        & (np.abs(image - shadow).sum(axis=2) > 12)
    )
    return image[keep]


def _check_pipeline_report(out: Path) -> tuple[dict, Page]:
    """Common checks of a report written for a real export; returns the manifest and the page."""
    (tile_dir,) = [p.parent for p in out.glob("*/lod_manifest.json")]
    manifest = _manifest(tile_dir)
    page = Page((tile_dir / "report.html").read_text(encoding="utf-8"))
    assert len(page.articles) == len(manifest["buildings"]) > 0
    by_id = {b["id"]: b for b in manifest["buildings"]}
    scores = [quality_score(by_id[a["id"]]) for a in page.articles]
    assert all(s is not None for s in scores) and scores == sorted(scores)  # worst first
    for article in page.articles:
        assert len(article["images"]) == len(by_id[article["id"]]["lods"]), article
    rows = page.tables["level-table"][1:]
    totals = [
        sum(b["lods"][k]["triangles"] for b in manifest["buildings"]) for k in range(len(rows))
    ]
    assert [int(r[3].replace(",", "")) for r in rows] == totals
    return manifest, page


def test_report_of_a_real_export(tmp_path):
    from exporter.config import Config
    from exporter.pipeline import export_tiles
    from exporter.samplegen import generate_tile

    generate_tile(tmp_path / "tile", 4, seed=1, atlas_size=256)
    export_tiles([tmp_path / "tile"], tmp_path / "out", Config(), jobs=1)
    write_reports(tmp_path / "out")
    manifest, page = _check_pipeline_report(tmp_path / "out")
    tile_dir = tmp_path / "out" / manifest["tile"]["name"]
    assert len(page.atlas) == len(page.images)  # every level textured: an atlas detail each
    for src in page.images:
        pixels = _building_pixels(tile_dir / src)
        assert len(pixels) > 0.05 * 256 * 256, src  # the building is in the picture
        assert pixels.std(axis=0).max() > 15, src  # textured and shaded, not one flat colour


def test_report_of_real_rotterdam_textures(tmp_path, shared_real):
    from exporter.config import Config
    from exporter.pipeline import export_tiles

    export_tiles([shared_real / "rotterdam_textured"], tmp_path / "out", Config(), jobs=1)
    write_reports(tmp_path / "out")
    manifest, page = _check_pipeline_report(tmp_path / "out")
    tile_dir = tmp_path / "out" / manifest["tile"]["name"]
    for building in manifest["buildings"]:
        for lod in building["lods"]:
            pixels = _building_pixels(tile_dir / "report" / image_name(building, lod["level"]))
            assert len(pixels) > 0.05 * 256 * 256, lod["file"]
            # Aerial-photo atlases give many more distinct colours than the same geometry untextured.
            meshes = load_glb(tile_dir / lod["file"])
            assert any(m.image is not None for m in meshes)
            flat = [Mesh(m.positions, m.triangles, color=m.color) for m in meshes]
            view = fit_view(load_glb(tile_dir / building["lods"][0]["file"]))
            flat_pixels = render(flat, view).reshape(-1, 3)
            distinct = len(np.unique(pixels // 4, axis=0))
            assert distinct > 3 * len(np.unique(flat_pixels // 4, axis=0)), lod["file"]


def test_cli_report_command(tmp_path, capsys):
    from exporter.cli import main

    make_fake_export(tmp_path, only="A")
    assert main(["report", str(tmp_path)]) == 0
    assert f"report: {tmp_path / 'index.html'}" in capsys.readouterr().out
    assert main(["report", str(tmp_path / "missing")]) == 2
    assert "not a folder" in capsys.readouterr().err


def test_building_table_shows_the_id_and_main_attributes(tmp_path):
    tile_dir = make_fake_export(tmp_path, only="B")
    manifest = _manifest(tile_dir)
    building = manifest["buildings"][0]
    building["attributes"] = {
        "Herkunft": "EE_LB_2007",
        "year_of_construction": 1985,
        "name": "<Rathaus>",
        **{f"extra{i}": i for i in range(9)},
    }
    (tile_dir / "lod_manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
    write_reports(tmp_path)
    text = (tile_dir / "report.html").read_text(encoding="utf-8")
    page = Page(text)
    (table,) = [rows for name, rows in page.tables.items() if name.startswith("attributes-")]
    assert table[:4] == [
        ["id", building["id"]],
        ["name", "<Rathaus>"],  # escaped in the page, read back as text
        ["year_of_construction", "1985"],
        ["Herkunft", "EE_LB_2007"],
    ]
    assert len(table) == 1 + 8 and "and 4 more attributes" in text


def test_each_level_shows_its_texel_and_error_when_the_manifest_states_them(tmp_path):
    out = tmp_path / "out"
    tile_dir = make_fake_export(out, only="A")
    manifest = _manifest(tile_dir)
    for lod in manifest["buildings"][0]["lods"]:
        lod["quality"]["texel_m"] = 0.046 * 2 ** lod["level"]
        lod["error_m"] = 8 * lod["quality"]["texel_m"] if lod["level"] else 0.0
    (tile_dir / "lod_manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
    write_reports(out)
    html = (tile_dir / "report.html").read_text(encoding="utf-8")
    assert '<span data-field="texel_m">texel 9.2 cm</span>' in html
    assert '<span data-field="error_m">error 0.736 m</span>' in html
    assert '<span data-field="error_m">error 0 m</span>' in html  # LOD0
