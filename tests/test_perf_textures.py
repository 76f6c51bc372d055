"""Texture LoDs, issue 8 speed work: every mode's output bytes equal a plain reference formulation
written here (Pillow calls in the obvious order), the header is parsed once, and ``always``'s box
chain stays within its documented quality. Images are small and made here; one test reads a real
aerial atlas from ``tests/data/real``."""

from __future__ import annotations

import io
import math

import numpy as np
import pytest
from PIL import Image
from texture_images import REAL_ATLASES, SCALES, sharp_rgb, smooth_rgb

from exporter import textures
from exporter.config import TextureOptions
from exporter.model import Texture
from exporter.textures import build_texture_lods, integer_factor, psnr

LANCZOS = Image.Resampling.LANCZOS


@pytest.fixture(autouse=True)
def fresh_cache():
    textures.clear_texture_cache()
    yield
    textures.clear_texture_cache()


def jpeg(array: np.ndarray) -> bytes:
    out = io.BytesIO()
    Image.fromarray(array).save(out, "JPEG", quality=95)
    return out.getvalue()


def q90(image: Image.Image) -> bytes:
    out = io.BytesIO()
    image.save(out, "JPEG", quality=90)
    return out.getvalue()


def drafted(data: bytes, size: tuple[int, int]) -> Image.Image:
    image = Image.open(io.BytesIO(data))
    image.draft("RGB", size)
    image.load()
    return image


def full(data: bytes) -> Image.Image:
    image = Image.open(io.BytesIO(data))
    image.load()
    return image


def levels_of(data: bytes, mode: str, scales=SCALES) -> list[bytes]:
    texture = Texture(
        data=data, mime="image/jpeg", width=0, height=0, name="a.jpg", source="tile/a.jpg"
    )
    return [
        level.data
        for level in build_texture_lods(texture, scales, TextureOptions(fast_jpeg_downscale=mode))
    ]


# --------------------------------------------------------------------------- same bytes as the plain formulation


def test_auto_fast_path_is_draft_then_a_box_reduction_of_it():
    data = jpeg(smooth_rgb(512, 512))
    half = drafted(data, (256, 256))
    assert half.size == (256, 256)
    assert levels_of(data, "auto") == [data, q90(half), q90(half.reduce(2))]


def test_auto_fallback_is_lanczos_from_the_full_decode_then_from_each_level():
    data = jpeg(sharp_rgb(512, 512))
    half = full(data).resize((256, 256), LANCZOS)
    assert levels_of(data, "auto") == [data, q90(half), q90(half.resize((128, 128), LANCZOS))]


def test_never_is_lanczos_from_the_full_decode_for_every_level():
    data = jpeg(smooth_rgb(512, 512))
    source = full(data)
    assert levels_of(data, "never") == [
        data,
        q90(source.resize((256, 256), LANCZOS)),
        q90(source.resize((128, 128), LANCZOS)),
    ]


def test_always_is_draft_then_a_box_reduction_of_each_level():
    data = jpeg(smooth_rgb(512, 512))
    half = drafted(data, (256, 256))
    expected = [data, q90(half), q90(half.reduce(2)), q90(half.reduce(2).reduce(2))]
    assert levels_of(data, "always", [1.0, 0.5, 0.25, 0.125]) == expected


def test_always_uses_lanczos_where_the_size_does_not_divide():
    data = jpeg(
        smooth_rgb(600, 400)
    )  # not a power of two: sides are multiples of 4 (300x200 -> 152x100)
    sizes = textures.level_sizes(600, 400, SCALES, TextureOptions().min_size)
    assert sizes == [(600, 400), (300, 200), (152, 100)]
    half = drafted(data, sizes[1])
    assert half.size == (300, 200)
    assert levels_of(data, "always") == [data, q90(half), q90(half.resize((152, 100), LANCZOS))]


@pytest.mark.parametrize(
    "source, size, factor",
    [
        ((512, 512), (256, 256), 2),
        ((512, 256), (128, 64), 4),
        ((300, 200), (300, 200), 1),
        ((300, 200), (148, 100), 0),
        ((512, 512), (256, 128), 0),
        ((6, 4), (4, 2), 0),
    ],
)
def test_integer_factor(source, size, factor):
    assert integer_factor(source, size) == factor


def test_the_source_is_opened_once_on_the_fast_path(monkeypatch):
    opened = []
    original = textures.open_header
    monkeypatch.setattr(
        textures, "open_header", lambda *args: opened.append(args[1]) or original(*args)
    )
    levels_of(jpeg(smooth_rgb(256, 256)), "auto")
    assert opened == ["tile/a.jpg"]


# --------------------------------------------------------------------------- always's quality


def test_always_box_chain_stays_close_to_lanczos_on_photo_like_pixels():
    data = jpeg(smooth_rgb(512, 512, seed=3))
    source = np.asarray(full(data))
    for level in levels_of(data, "always", [1.0, 0.5, 0.25, 0.125])[1:]:
        image = full(level)
        reference = np.asarray(Image.fromarray(source).resize(image.size, LANCZOS))
        assert psnr(reference, np.asarray(image)) >= 35.0


def test_box_lod2_trades_about_2_db_on_a_real_aerial_atlas():
    """On a real photograph auto's check passes, so auto writes what always writes; its box LOD2
    is about 2 dB below never's Lanczos (docs/textures.md), still >= 33 dB against Lanczos from
    the full image."""
    atlases = sorted(REAL_ATLASES.glob("*.jpg"))
    data = atlases[0].read_bytes()
    auto, always, never = (
        levels_of(data, "auto"),
        levels_of(data, "always"),
        levels_of(data, "never"),
    )
    assert auto == always
    source = full(data)
    reference = np.asarray(source.resize((source.width // 4, source.height // 4), LANCZOS))
    quality = {
        name: psnr(reference, np.asarray(full(levels[2])))
        for name, levels in (("auto", auto), ("never", never))
    }
    assert 33.0 <= quality["auto"] < quality["never"] - 1.0


# --------------------------------------------------------------------------- auto's sampled check


def whole_image_errors(image: Image.Image, k: int) -> np.ndarray:
    """Per-pixel box minus Lanczos over the whole image, (h/k, w/k, 3) float."""
    size = (image.width // k, image.height // k)
    return np.asarray(image.resize(size, LANCZOS)).astype(np.float64) - np.asarray(
        image.reduce(k)
    ).astype(np.float64)


@pytest.mark.parametrize("width, height, k", [(512, 512, 2), (512, 512, 4), (768, 256, 2)])
def test_sampled_check_is_the_whole_image_comparison_on_its_blocks(width, height, k):
    """The mosaic's block interiors are bit for bit the whole-image reductions there: the sampled
    PSNR equals the PSNR of the whole-image difference restricted to the same blocks."""
    image = Image.fromarray(
        np.concatenate([sharp_rgb(width, height // 2), smooth_rgb(width, height // 2)])
    )
    block, margin = textures.SAMPLE_BLOCK_OUT * k, textures.LANCZOS_REACH * k
    n = textures.SAMPLE_BLOCKS
    ys = textures.sample_origins(image.height, n, block, margin, k)
    xs = textures.sample_origins(image.width, n, block, margin, k)
    assert len(set(ys)) == n and min(ys) >= margin and max(ys) + block + margin <= image.height
    errors = whole_image_errors(image, k)
    picked = np.concatenate(
        [
            errors[
                y // k : y // k + textures.SAMPLE_BLOCK_OUT,
                x // k : x // k + textures.SAMPLE_BLOCK_OUT,
            ].ravel()
            for y in ys
            for x in xs
        ]
    )
    expected = 10 * np.log10(255.0**2 / np.mean(picked * picked))
    assert textures.sampled_box_psnr(image, k) == pytest.approx(expected, rel=1e-12)
    # ... and differs from the whole image's value (it is a sample of a half sharp, half smooth image).
    assert textures.sampled_box_psnr(image, k) != pytest.approx(
        textures.box_psnr(image, k), abs=0.01
    )


@pytest.mark.parametrize(
    "width, height, k", [(96, 64, 2), (2048, 32, 2), (40, 2048, 2), (510, 512, 4)]
)
def test_sampled_check_on_small_narrow_or_indivisible_images_is_the_whole_image(width, height, k):
    image = Image.fromarray(sharp_rgb(width, height))
    assert textures.sampled_box_psnr(image, k) == textures.box_psnr(image, k)


def test_sampled_check_separates_photo_like_from_pixel_sharp_levels():
    assert (
        textures.sampled_box_psnr(Image.fromarray(smooth_rgb(512, 512)), 2)
        >= textures.AUTO_MIN_PSNR_DB
    )
    assert (
        textures.sampled_box_psnr(Image.fromarray(sharp_rgb(512, 512)), 2)
        < textures.AUTO_MIN_PSNR_DB
    )


def test_auto_measures_the_draft_once_for_both_its_guard_and_lod2(monkeypatch):
    measured = []
    original = textures.sampled_box_psnr
    monkeypatch.setattr(
        textures,
        "sampled_box_psnr",
        lambda image, k: measured.append((image.size, k)) or original(image, k),
    )
    levels_of(jpeg(smooth_rgb(512, 512)), "auto")
    assert measured == [((256, 256), 2)]


def test_auto_checks_each_later_level_on_the_level_above(monkeypatch):
    """Scales 1, 1/2, 1/8: the draft's guard at 2x, then LOD2 = 4x box of LOD1 only if the 4x check
    passes; a failing 4x check gives Lanczos (forced here)."""
    data = jpeg(smooth_rgb(512, 512))
    half = drafted(data, (256, 256))
    scales = [1.0, 0.5, 0.125]
    assert levels_of(data, "auto", scales) == [data, q90(half), q90(half.reduce(4))]
    original = textures.sampled_box_psnr
    monkeypatch.setattr(
        textures, "sampled_box_psnr", lambda image, k: original(image, k) if k == 2 else 0.0
    )
    textures.clear_texture_cache()
    assert levels_of(data, "auto", scales) == [data, q90(half), q90(half.resize((64, 64), LANCZOS))]


def test_auto_fallback_keeps_lanczos_where_the_box_check_fails_on_lod1():
    """A pixel-sharp atlas: full decode, Lanczos LOD1, and LOD1's own check fails too, so LOD2 is
    Lanczos of LOD1 (the same bytes as before the box rule)."""
    data = jpeg(sharp_rgb(512, 512, seed=5))
    half = full(data).resize((256, 256), LANCZOS)
    assert textures.sampled_box_psnr(half, 2) < textures.AUTO_MIN_PSNR_DB
    assert levels_of(data, "auto") == [data, q90(half), q90(half.resize((128, 128), LANCZOS))]


def public_api_sampled_psnr(image: Image.Image, k: int) -> float:
    """``sampled_box_psnr`` as first written: the mosaic cut and pasted with ``Image.crop`` and
    ``Image.paste`` (rows into a band, then columns), the mean of float64 squares."""
    block, margin = textures.SAMPLE_BLOCK_OUT * k, textures.LANCZOS_REACH * k
    cell, n = block + 2 * margin, textures.SAMPLE_BLOCKS
    width, height = image.size
    rows = [
        image.crop((0, y - margin, width, y + block + margin))
        for y in textures.sample_origins(height, n, block, margin, k)
    ]
    band = Image.new(image.mode, (width, n * cell))
    for i, row in enumerate(rows):
        band.paste(row, (0, i * cell))
    mosaic = Image.new(image.mode, (n * cell, n * cell))
    for j, x in enumerate(textures.sample_origins(width, n, block, margin, k)):
        mosaic.paste(band.crop((x - margin, 0, x + block + margin, n * cell)), (j * cell, 0))
    side = n * cell // k
    difference = np.asarray(mosaic.resize((side, side), LANCZOS)).astype(np.float64) - np.asarray(
        mosaic.reduce(k)
    ).astype(np.float64)
    inner = slice(margin // k, margin // k + textures.SAMPLE_BLOCK_OUT)
    errors = np.abs(difference).reshape(n, cell // k, n, cell // k, -1)[:, inner, :, inner]
    mse = float(np.mean(errors * errors))
    return 10.0 * math.log10(255.0 * 255.0 / mse) if mse else math.inf


def sample_images() -> list[Image.Image]:
    mixed = np.concatenate([sharp_rgb(640, 256, seed=3), smooth_rgb(640, 256, seed=4)])
    images = [Image.fromarray(a) for a in (sharp_rgb(512, 512), smooth_rgb(512, 512), mixed)]
    images.append(images[2].convert("L"))
    images.append(Image.fromarray(np.dstack([mixed, mixed[:, :, 0]]), "RGBA"))
    for path in sorted(REAL_ATLASES.glob("*.jp*g"))[:6] if REAL_ATLASES.is_dir() else []:
        data = path.read_bytes()
        width, height = Image.open(io.BytesIO(data)).size
        images.append(drafted(data, (width // 2, height // 2)))  # the level auto checks
    return images


@pytest.mark.parametrize("k", [2, 4])
def test_sampled_check_equals_its_public_api_formulation_bit_for_bit(k):
    """The core-API mosaic and integer sum give the very float the crop/paste mosaic and the
    float64 mean gave: ``auto``'s decisions cannot move."""
    images = [image for image in sample_images() if image.width >= 256]
    assert len(images) >= 5
    for image in images:
        assert textures.sampled_box_psnr(image, k) == public_api_sampled_psnr(image, k)
