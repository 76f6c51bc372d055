"""Shared atlases cut to what a building uses (exporter/crop.py)."""

from __future__ import annotations

import filecmp
import io
import json
from pathlib import Path

import numpy as np
from PIL import Image
from texture_images import REAL_ATLASES

from exporter import crop
from exporter.config import Config, TextureOptions
from exporter.model import Part, Texture
from exporter.pipeline import export_tiles
from exporter.tileset.glb import read_primitives

REPO = Path(__file__).resolve().parents[1]
ROTTERDAM = REPO / "tests" / "data" / "real" / "rotterdam_textured"
SAMPLE = REPO / "samples" / "15_279418_116113"


def quad(uvs: list[list[float]], texture: Texture) -> Part:
    """Two triangles over the unit square, its corners at ``uvs`` (4, 2)."""
    positions = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
    return Part(positions, [[0, 1, 2], [0, 2, 3]], uvs=np.array(uvs), texture=texture)


def jpeg_texture(size: int = 512) -> Texture:
    image = Image.open(sorted(REAL_ATLASES.glob("*.jpg"))[0]).convert("RGB").resize((size, size))
    out = io.BytesIO()
    image.save(out, "JPEG", quality=90)
    return Texture(out.getvalue(), "image/jpeg", size, size, "atlas.jpg")


def sample(image: Image.Image, uvs: np.ndarray) -> np.ndarray:
    """(n, 3) float: the pixels of ``image`` under uvs (n, 2) (nearest texel)."""
    pixels = np.asarray(image.convert("RGB"), dtype=np.float64)
    h, w = pixels.shape[:2]
    cols = np.clip((uvs[:, 0] * w).astype(int), 0, w - 1)
    rows = np.clip((uvs[:, 1] * h).astype(int), 0, h - 1)
    return pixels[rows, cols]


def test_used_box_is_aligned_with_a_margin_and_refuses_what_it_cannot_cut():
    uvs = np.array([[0.10, 0.20], [0.30, 0.45]], np.float32)
    x0, y0, x1, y1 = crop.used_box(uvs, (1000, 800), 16)
    assert all(v % 16 == 0 for v in (x0, y0)) and x1 % 16 == 0 and y1 % 16 == 0
    assert x0 <= 100 - crop.MARGIN_PX and x1 >= 300 + crop.MARGIN_PX
    assert y0 <= 160 - crop.MARGIN_PX and y1 >= 360 + crop.MARGIN_PX
    assert crop.used_box(np.array([[0.0, 0.0], [1.0, 1.0]]), (1000, 800), 16) is None  # whole
    assert crop.used_box(np.array([[0.1, 0.1], [0.2, 1.7]]), (1000, 800), 16) is None  # repeats
    assert crop.used_box(np.zeros((0, 2)), (1000, 800), 16) is None


def test_a_partly_used_jpeg_is_cut_and_every_uv_shows_the_same_pixel():
    texture = jpeg_texture(512)
    uvs = [[0.55, 0.60], [0.90, 0.60], [0.90, 0.95], [0.55, 0.95]]
    lod0, lod1 = quad(uvs, texture), quad(uvs[:3] + [[0.6, 0.9]], texture)
    levels = crop.crop_to_used([[lod0], [lod1]], TextureOptions())
    cut = levels[0][0].texture
    assert cut is levels[1][0].texture  # one source for every level: one uv layout
    assert cut.width * cut.height < 0.25 * 512 * 512
    source = Image.open(io.BytesIO(texture.data))
    after = Image.open(io.BytesIO(cut.data))
    assert after.size == (cut.width, cut.height)
    grid = np.stack(np.meshgrid(np.linspace(0.56, 0.89, 40), np.linspace(0.61, 0.94, 40)), -1)
    old = grid.reshape(-1, 2)
    box = crop.used_box(np.array(uvs, np.float32), (512, 512), 16)
    new = crop.moved_uvs(old.astype(np.float32), (512, 512), box)
    # the re-encode with the source's tables on MCU boundaries is close to lossless
    error = np.abs(sample(source, old) - sample(after, new))
    assert error.mean() < 1.5
    for level in levels:
        moved = level[0].uvs
        assert moved.min() >= 0.0 and moved.max() <= 1.0


def test_a_png_is_cut_losslessly():
    pixels = np.random.default_rng(3).integers(0, 255, (200, 300, 4), dtype=np.uint8)
    out = io.BytesIO()
    Image.fromarray(pixels, "RGBA").save(out, "PNG")
    texture = Texture(out.getvalue(), "image/png", 300, 200, "atlas.png")
    part = quad([[0.1, 0.1], [0.3, 0.1], [0.3, 0.4], [0.1, 0.4]], texture)
    [[cut]] = crop.crop_to_used([[part]], TextureOptions())
    x0, y0, x1, y1 = crop.used_box(part.uvs, (300, 200), 4)
    got = np.asarray(Image.open(io.BytesIO(cut.texture.data)))
    assert np.array_equal(got, pixels[y0:y1, x0:x1])


def test_a_fully_used_or_repeating_texture_keeps_its_bytes():
    texture = jpeg_texture(256)
    whole = quad([[0, 0], [1, 0], [1, 1], [0, 1]], texture)
    repeat = quad([[0, 0], [2, 0], [2, 0.2], [0, 0.2]], texture)
    for part in (whole, repeat):
        [[out]] = crop.crop_to_used([[part]], TextureOptions())
        assert out.texture is texture and out.uvs is part.uvs


def texture_pixels(paths) -> int:
    """Pixels of the distinct images embedded in the .glb files ``paths``."""
    total = 0
    for path in paths:
        images = {p.image for p in read_primitives(path) if p.image is not None}
        total += sum(int(np.prod(Image.open(io.BytesIO(i)).size)) for i in images)
    return total


def test_shared_atlases_are_cut_per_building_and_fully_used_ones_are_not(tmp_path):
    cutting, whole = Config(), Config()
    whole.textures.crop_to_used = False
    for config in (cutting, whole):
        config.tileset.enabled = False
    export_tiles([ROTTERDAM], tmp_path / "cut", cutting, jobs=1)
    export_tiles([ROTTERDAM], tmp_path / "whole", whole, jobs=1)
    # Rotterdam's two buildings share 14 1024² atlases: each embedded whole, then cut
    cut, kept = (sorted((tmp_path / name).glob("*/*/lod0.glb")) for name in ("cut", "whole"))
    assert texture_pixels(cut) < 0.45 * texture_pixels(kept)
    for manifest in (tmp_path / "cut").glob("*/manifest.json"):
        for building in json.loads(manifest.read_text())["buildings"]:
            texels = [lod["quality"]["texel_m"] for lod in building["lods"]]
            assert texels == sorted(texels)  # still a quarter of the pixels per level
    # The sample tile: a building whose atlases its faces fill keeps its bytes; one whose
    # atlases hold unused pixels (the generator leaves a third of some empty) loses them.
    export_tiles([SAMPLE], tmp_path / "vworld_cut", cutting, jobs=1)
    export_tiles([SAMPLE], tmp_path / "vworld_whole", whole, jobs=1)
    same = changed = 0
    for path in sorted((tmp_path / "vworld_cut").glob("*/*/*.glb")):
        before = tmp_path / "vworld_whole" / path.relative_to(tmp_path / "vworld_cut")
        if filecmp.cmp(path, before, shallow=False):
            same += 1
        else:
            changed += 1
            assert texture_pixels([path]) < texture_pixels([before])
    assert same and changed
