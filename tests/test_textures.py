"""Texture LoDs (issue 6): sizes per level, byte identity of LOD0, formats, alpha, bad input, cache,
and the fast JPEG path. Images are small and made here; one test reads a real aerial atlas from
``tests/data/real``."""

from __future__ import annotations

import io
import struct
import time
import zlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from PIL import Image, ImageFile
from texture_images import REAL_ATLASES, SCALES, sharp_rgb, smooth_rgb

from exporter import textures
from exporter.config import TextureOptions
from exporter.errors import ReadError
from exporter.model import Texture
from exporter.textures import build_texture_lods, level_size, level_sizes, psnr


@pytest.fixture(autouse=True)
def fresh_cache():
    textures.clear_texture_cache()
    yield
    textures.clear_texture_cache()


def encode(array: np.ndarray, fmt: str, **params) -> bytes:
    out = io.BytesIO()
    Image.fromarray(array).save(out, fmt, **params)
    return out.getvalue()


def texture_of(data: bytes, mime: str = "image/jpeg", name: str = "atlas.jpg") -> Texture:
    return Texture(data=data, mime=mime, width=0, height=0, name=name, source=f"tile/{name}")


def decoded(texture: Texture) -> Image.Image:
    image = Image.open(io.BytesIO(texture.data))
    image.load()
    return image


# --------------------------------------------------------------------------- sizes


@pytest.mark.parametrize(
    "source, expected",
    [
        ((1024, 1024), [(1024, 1024), (512, 512), (256, 256)]),
        ((1024, 512), [(1024, 512), (512, 256), (256, 128)]),
        ((512, 2048), [(512, 2048), (256, 1024), (128, 512)]),
        ((8, 8), [(8, 8), (8, 8), (8, 8)]),  # below min_size: never reduced, never upscaled
        ((20, 20), [(20, 20), (16, 16), (16, 16)]),  # floored at min_size, multiple of 4
        ((32, 32), [(32, 32), (16, 16), (16, 16)]),  # power of two floored at min_size
    ],
)
def test_level_sizes(source, expected):
    assert level_sizes(*source, SCALES, 16) == expected


def test_non_power_of_two_sides_are_multiples_of_4_and_keep_the_aspect():
    sizes = level_sizes(1000, 600, SCALES, 16)
    assert sizes[0] == (1000, 600)
    for (w, h), scale in zip(sizes[1:], SCALES[1:]):
        assert w % 4 == 0 and h % 4 == 0
        assert abs(w / h - 1000 / 600) < 0.05
        assert abs(w * h / (1000 * 600 * scale * scale) - 1) < 0.05  # the paper's pixel budget


def test_min_size_floor_keeps_the_aspect_of_a_non_square_atlas():
    assert level_size(1024, 256, 1 / 64, 16) == (64, 16)
    assert level_size(1000, 300, 0.01, 16) == (52, 16)


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 8192), st.integers(1, 8192), st.floats(0.001, 1.0), st.integers(1, 64))
def test_level_size_never_upscales_and_respects_the_floor(width, height, scale, min_size):
    w, h = level_size(width, height, scale, min_size)
    assert 1 <= w <= width and 1 <= h <= height
    if (w, h) != (width, height):
        assert min(w, h) >= min(min_size, width, height)
    if textures.is_power_of_two(width) and textures.is_power_of_two(height):
        assert textures.is_power_of_two(w) and textures.is_power_of_two(h)
        assert width * h == height * w


# --------------------------------------------------------------------------- formats


@pytest.mark.parametrize("fmt, mime", [("JPEG", "image/jpeg"), ("PNG", "image/png")])
def test_lod0_keeps_the_source_bytes(fmt, mime):
    data = encode(smooth_rgb(256, 128), fmt)
    source = texture_of(data, mime, "wall." + fmt.lower())
    levels = build_texture_lods(source, SCALES, TextureOptions())
    assert levels[0].data is source.data
    assert (levels[0].mime, levels[0].width, levels[0].height, levels[0].name) == (
        mime,
        256,
        128,
        source.name,
    )
    assert [(t.width, t.height) for t in levels] == [(256, 128), (128, 64), (64, 32)]
    for level in levels[1:]:
        image = decoded(level)
        assert image.format == fmt and image.size == (level.width, level.height)
        assert level.name.endswith(("_lod1", "_lod2"), 0, level.name.rindex("."))
        assert level.source == source.source


def test_declared_mime_is_checked_against_the_content():
    data = encode(smooth_rgb(64, 64), "PNG")
    levels = build_texture_lods(
        texture_of(data, "image/jpeg", "mislabelled.jpg"), SCALES, TextureOptions()
    )
    assert levels[0].data is data and levels[0].mime == "image/png"


@pytest.mark.parametrize("fmt", ["BMP", "TGA", "WEBP", "GIF"])
def test_other_formats_are_converted_once(fmt, monkeypatch):
    data = encode(smooth_rgb(128, 128), fmt)
    encodes = []
    original = textures._encode
    monkeypatch.setattr(
        textures,
        "_encode",
        lambda image, f, q: encodes.append((image.size, f)) or original(image, f, q),
    )
    levels = build_texture_lods(
        texture_of(data, "image/x-" + fmt.lower(), "a." + fmt.lower()),
        [1.0, 1.0, 0.5],
        TextureOptions(),
    )
    assert [t.mime for t in levels] == ["image/jpeg"] * 3
    assert levels[0].data is levels[1].data  # equal sizes share one conversion
    assert encodes == [((128, 128), "JPEG"), ((64, 64), "JPEG")]
    assert decoded(levels[0]).size == (128, 128) and levels[0].name == "a_lod0.jpg"


def test_grayscale_jpeg_stays_grayscale():
    data = encode(smooth_rgb(64, 64)[..., 0], "JPEG")
    levels = build_texture_lods(texture_of(data), SCALES, TextureOptions(min_size=4))
    assert [decoded(t).mode for t in levels] == ["L", "L", "L"]


# --------------------------------------------------------------------------- alpha


def rgba(alpha: np.ndarray) -> np.ndarray:
    h, w = alpha.shape
    return np.concatenate([smooth_rgb(w, h), alpha[..., None]], axis=-1)


def test_transparent_png_keeps_alpha_at_every_level():
    alpha = np.full((128, 128), 255, np.uint8)
    alpha[:, :64] = 0  # the left half is a cut-out
    data = encode(rgba(alpha), "PNG")
    for options in (TextureOptions(), TextureOptions(opaque_png_to_jpeg=True)):
        textures.clear_texture_cache()
        levels = build_texture_lods(texture_of(data, "image/png", "a.png"), SCALES, options)
        assert levels[0].data is data
        for level in levels[1:]:
            image = decoded(level)
            assert level.mime == "image/png" and image.mode == "RGBA"
            a = np.asarray(image.getchannel("A"))
            assert a[:, : level.width // 4].max() == 0 and a[:, -level.width // 4 :].min() == 255


def test_palette_png_with_transparency_keeps_alpha():
    image = Image.fromarray(smooth_rgb(64, 64)).convert(
        "P", palette=Image.Palette.ADAPTIVE, colors=16
    )
    out = io.BytesIO()
    image.save(out, "PNG", transparency=0)
    levels = build_texture_lods(
        texture_of(out.getvalue(), "image/png", "p.png"), [1.0, 0.5], TextureOptions()
    )
    assert levels[1].mime == "image/png" and decoded(levels[1]).mode == "RGBA"


@pytest.mark.parametrize("to_jpeg", [False, True])
def test_opaque_png_becomes_jpeg_only_when_configured(to_jpeg):
    data = encode(rgba(np.full((128, 128), 255, np.uint8)), "PNG")  # alpha channel, all opaque
    levels = build_texture_lods(
        texture_of(data, "image/png", "a.png"), SCALES, TextureOptions(opaque_png_to_jpeg=to_jpeg)
    )
    assert levels[0].data is data and levels[0].mime == "image/png"
    expected = "image/jpeg" if to_jpeg else "image/png"
    assert [t.mime for t in levels[1:]] == [expected, expected]
    assert all(decoded(t).mode == "RGB" for t in levels[1:])  # the unused alpha channel is dropped


# --------------------------------------------------------------------------- bad input


def png_header_claiming(width: int, height: int) -> bytes:
    """A PNG signature and IHDR (valid CRC) declaring ``width`` x ``height`` pixels, then a stub."""
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    chunk = (
        struct.pack(">I", len(ihdr))
        + b"IHDR"
        + ihdr
        + struct.pack(">I", zlib.crc32(b"IHDR" + ihdr))
    )
    idat = zlib.compress(b"\0" * 64)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk
        + struct.pack(">I", len(idat))
        + b"IDAT"
        + idat
        + struct.pack(">I", zlib.crc32(b"IDAT" + idat))
    )


def jpeg_claiming(width: int, height: int) -> bytes:
    """A real small JPEG whose SOF0 frame header is edited to declare ``width`` x ``height``."""
    data = bytearray(encode(smooth_rgb(16, 16), "JPEG"))
    sof = data.index(b"\xff\xc0")
    data[sof + 5 : sof + 9] = struct.pack(">HH", height, width)
    return bytes(data)


@pytest.fixture
def no_decoding(monkeypatch):
    def refuse(self, *args, **kwargs):
        raise AssertionError("pixels decoded")

    monkeypatch.setattr(ImageFile.ImageFile, "load", refuse)


@pytest.mark.parametrize("make", [png_header_claiming, jpeg_claiming])
def test_huge_declared_size_is_refused_before_decoding(make, no_decoding):
    data = make(20000, 20000)
    saved = Image.MAX_IMAGE_PIXELS
    start = time.perf_counter()
    with pytest.raises(ReadError) as error:
        build_texture_lods(
            texture_of(data, name="huge.img"), SCALES, TextureOptions(max_pixels=16384 * 16384)
        )
    assert time.perf_counter() - start < 1.0
    assert "tile/huge.img" in str(error.value) and "20000x20000" in str(error.value)
    assert Image.MAX_IMAGE_PIXELS == saved  # Pillow's own guard is left as it was


def test_max_pixels_refuses_a_real_image_and_beyond_pillow_bomb_limit(no_decoding):
    with pytest.raises(ReadError, match="max_pixels"):
        build_texture_lods(
            texture_of(encode(smooth_rgb(64, 64), "PNG")),
            SCALES,
            TextureOptions(max_pixels=64 * 63),
        )
    # Far over both limits: Pillow's bomb error is reported in our words.
    with pytest.raises(ReadError, match="refused before decoding"):
        build_texture_lods(
            texture_of(png_header_claiming(60000, 60000)), SCALES, TextureOptions(max_pixels=1000)
        )


@pytest.mark.parametrize(
    "data, problem",
    [
        (b"", "missing or empty"),
        (np.random.default_rng(1).bytes(2000), "not a readable image"),
        (
            b'<?xml version="1.0" encoding="UTF-8"?><error><code>ERROR_SERVICE_FILE_NOTTHING</code></error>',
            "XML",
        ),
    ],
)
def test_unreadable_bytes_name_the_file_and_the_problem(data, problem):
    with pytest.raises(ReadError, match=problem) as error:
        build_texture_lods(texture_of(data, name="b7.jpg"), SCALES, TextureOptions())
    assert error.value.path == "tile/b7.jpg"


@pytest.mark.parametrize("fmt", ["JPEG", "PNG"])
@pytest.mark.parametrize("scales", [SCALES, [1.0]])
def test_truncated_image_is_refused(fmt, scales):
    data = encode(smooth_rgb(256, 256), fmt)
    with pytest.raises(ReadError, match="truncated or corrupt") as error:
        build_texture_lods(
            texture_of(data[: len(data) // 2], name="cut.img"), scales, TextureOptions()
        )
    assert error.value.path == "tile/cut.img"


def test_error_names_the_name_when_the_texture_is_embedded():
    texture = Texture(data=b"junk", mime="image/jpeg", width=1, height=1, name="image_3")
    with pytest.raises(ReadError) as error:
        build_texture_lods(texture, SCALES, TextureOptions())
    assert error.value.path == "image_3"


# --------------------------------------------------------------------------- cache


@pytest.fixture
def decode_calls(monkeypatch):
    calls = []
    original = textures._decode
    monkeypatch.setattr(
        textures, "_decode", lambda image, where: calls.append(where) or original(image, where)
    )
    return calls


def test_identical_bytes_are_decoded_at_most_twice(decode_calls):
    """Admission on the second sighting: the first build is only noted, the second is stored,
    every later one is a hit (another building's copy of the same bytes included)."""
    data = encode(smooth_rgb(256, 256), "JPEG")
    first = build_texture_lods(texture_of(data, name="a.jpg"), SCALES, TextureOptions())
    assert len(decode_calls) == 1 and textures.texture_cache_stats()["entries"] == 0
    again = build_texture_lods(texture_of(data, name="a.jpg"), SCALES, TextureOptions())
    assert len(decode_calls) == 2 and textures.texture_cache_stats()["entries"] == 1
    assert [t.data for t in again] == [t.data for t in first]
    copy = bytes(bytearray(data))  # another building's copy of the same file
    second = build_texture_lods(
        Texture(copy, "image/jpeg", 0, 0, "b.jpg", "other/b.jpg"), SCALES, TextureOptions()
    )
    assert len(decode_calls) == 2
    assert (
        second[0].data is copy and second[0].name == "b.jpg" and second[0].source == "other/b.jpg"
    )
    assert [t.data for t in second[1:]] == [t.data for t in first[1:]]
    assert second[1].data is again[1].data
    assert textures.texture_cache_stats()["hits"] == 1
    # Other scales or options are other work.
    build_texture_lods(texture_of(data), [1.0, 0.5], TextureOptions())
    build_texture_lods(texture_of(data), SCALES, TextureOptions(jpeg_quality=70))
    assert len(decode_calls) == 4


def test_atlases_used_once_keep_no_bytes():
    for seed in range(6):
        build_texture_lods(
            texture_of(encode(smooth_rgb(128, 128, seed), "JPEG")), SCALES, TextureOptions()
        )
    stats = textures.texture_cache_stats()
    assert stats["entries"] == 0 and stats["bytes"] == 0 and stats["misses"] == 6


def test_problems_are_cached_too(decode_calls):
    data = encode(smooth_rgb(128, 128), "JPEG")
    data = data[: len(data) // 2]
    for name in ("a.jpg", "b.jpg", "c.jpg", "d.jpg"):
        with pytest.raises(ReadError) as error:
            build_texture_lods(texture_of(data, name=name), SCALES, TextureOptions())
        assert error.value.path == f"tile/{name}"
    assert len(decode_calls) == 2


def test_cache_is_bounded_in_bytes(monkeypatch):
    monkeypatch.setattr(textures._cache, "max_bytes", 60_000)
    for seed in range(12):
        for _ in range(2):  # a second sighting is what gets stored
            build_texture_lods(
                texture_of(encode(smooth_rgb(128, 128, seed), "PNG")), SCALES, TextureOptions()
            )
        stats = textures.texture_cache_stats()
        assert stats["bytes"] <= 60_000
    assert 0 < stats["entries"] < 12


def test_seen_list_is_bounded(monkeypatch):
    monkeypatch.setattr(textures._cache, "seen_max", 3)
    for seed in range(5):
        build_texture_lods(
            texture_of(encode(smooth_rgb(32, 32, seed), "JPEG")), SCALES, TextureOptions()
        )
    assert len(textures._cache.seen) == 3
    # The oldest sighting was forgotten: seeing it again is a first sighting, not stored.
    build_texture_lods(texture_of(encode(smooth_rgb(32, 32, 0), "JPEG")), SCALES, TextureOptions())
    assert textures.texture_cache_stats()["entries"] == 0


# --------------------------------------------------------------------------- the fast JPEG path


def test_auto_decodes_a_photo_like_jpeg_at_reduced_size(decode_calls, monkeypatch):
    sizes = []
    original = textures._decode
    monkeypatch.setattr(
        textures, "_decode", lambda image, where: sizes.append(image.size) or original(image, where)
    )
    data = encode(smooth_rgb(512, 512), "JPEG", quality=95)
    build_texture_lods(texture_of(data), SCALES, TextureOptions(fast_jpeg_downscale="auto"))
    assert sizes == [(256, 256)]


def test_auto_falls_back_to_a_full_decode_on_pixel_sized_detail(monkeypatch):
    sizes = []
    original = textures._decode
    monkeypatch.setattr(
        textures, "_decode", lambda image, where: sizes.append(image.size) or original(image, where)
    )
    data = encode(sharp_rgb(512, 512), "JPEG", quality=95)
    levels = build_texture_lods(
        texture_of(data), SCALES, TextureOptions(fast_jpeg_downscale="auto")
    )
    assert sizes == [(256, 256), (512, 512)]
    textures.clear_texture_cache()
    sizes.clear()
    always = build_texture_lods(
        texture_of(data), SCALES, TextureOptions(fast_jpeg_downscale="always")
    )
    assert sizes == [(256, 256)]
    full = Image.open(io.BytesIO(data)).convert("RGB")
    reference = np.asarray(full.resize((256, 256), Image.Resampling.LANCZOS))
    # The fallback is what keeps quality here: closer to Lanczos than the IDCT shortcut.
    assert (
        psnr(reference, np.asarray(decoded(levels[1])))
        > psnr(reference, np.asarray(decoded(always[1]))) + 1.0
    )


def test_never_decodes_the_full_image(monkeypatch):
    sizes = []
    original = textures._decode
    monkeypatch.setattr(
        textures, "_decode", lambda image, where: sizes.append(image.size) or original(image, where)
    )
    build_texture_lods(
        texture_of(encode(smooth_rgb(256, 256), "JPEG")),
        SCALES,
        TextureOptions(fast_jpeg_downscale="never"),
    )
    assert sizes == [(256, 256)]


def test_fast_path_on_a_real_aerial_atlas_is_close_to_careful_lanczos():
    atlases = sorted(REAL_ATLASES.glob("*.jpg"))
    data = atlases[0].read_bytes()
    levels = build_texture_lods(texture_of(data, name=atlases[0].name), SCALES, TextureOptions())
    full = Image.open(io.BytesIO(data))
    assert [(t.width, t.height) for t in levels] == [
        full.size,
        (full.width // 2, full.height // 2),
        (full.width // 4, full.height // 4),
    ]
    assert levels[0].data is data
    # LOD1 is the IDCT-scaled decode; LOD2 its box reduction (auto's check passes on photographs),
    # about 2 dB below Lanczos from the full image (docs/textures.md).
    for level, floor_db in zip(levels[1:], (35.0, 33.0)):
        reference = np.asarray(full.resize((level.width, level.height), Image.Resampling.LANCZOS))
        assert psnr(reference, np.asarray(decoded(level))) >= floor_db


def test_psnr():
    a = np.zeros((4, 4), np.uint8)
    b = a.copy()
    b[0, 0] = 16  # mse = 16
    assert psnr(a, a) == float("inf")
    assert psnr(a, b) == pytest.approx(10 * np.log10(255**2 / 16))
    assert textures.image_psnr(Image.fromarray(a), Image.fromarray(b)) == pytest.approx(psnr(a, b))


def test_reduced_levels_keep_the_colour_profile():
    from PIL import ImageCms

    icc = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
    data = encode(smooth_rgb(64, 64), "JPEG", icc_profile=icc)
    levels = build_texture_lods(texture_of(data), SCALES, TextureOptions())
    assert all(decoded(t).info.get("icc_profile") == icc for t in levels)


def test_scales_outside_0_1_are_a_programming_error():
    with pytest.raises(ValueError):
        build_texture_lods(
            texture_of(encode(smooth_rgb(16, 16), "JPEG")), [1.0, 0.0], TextureOptions()
        )


def test_cache_tells_apart_files_with_equal_length_and_ends():
    # Uncompressed BMPs differing only in middle rows: same length, same first and last 4 KiB.
    a = smooth_rgb(128, 128)
    b = a.copy()
    b[60:68] = 255 - b[60:68]
    data_a, data_b = encode(a, "BMP"), encode(b, "BMP")
    assert (
        len(data_a) == len(data_b)
        and data_a[:4096] == data_b[:4096]
        and data_a[-4096:] == data_b[-4096:]
    )
    for _ in range(
        3
    ):  # stored on a second sighting; a and b share one hash, so sightings interleave
        first = build_texture_lods(
            texture_of(data_a, "image/bmp", "a.bmp"), SCALES, TextureOptions()
        )
        second = build_texture_lods(
            texture_of(data_b, "image/bmp", "b.bmp"), SCALES, TextureOptions()
        )
    assert textures.texture_cache_stats()["entries"] == 2
    assert first[0].data != second[0].data and first[1].data != second[1].data
    assert decoded(first[1]).tobytes() != decoded(second[1]).tobytes()


def test_16_bit_grey_png_is_reduced_to_8_bits_not_clipped():
    ramp = (np.arange(64 * 64).reshape(64, 64) * 16).astype(np.uint16)  # 0 .. 65520
    levels = build_texture_lods(
        texture_of(encode(ramp, "PNG"), "image/png", "g.png"), [1.0, 0.5], TextureOptions()
    )
    image = decoded(levels[1])
    assert image.mode == "L" and image.size == (32, 32)
    values = np.asarray(image)
    assert values.min() < 10 and values.max() > 245 and 100 < values.mean() < 155


def test_cmyk_jpeg_is_converted_to_rgb_even_at_lod0():
    data = encode(smooth_rgb(64, 64), "JPEG")
    cmyk = io.BytesIO()
    Image.open(io.BytesIO(data)).convert("CMYK").save(cmyk, "JPEG")
    levels = build_texture_lods(texture_of(cmyk.getvalue()), [1.0, 0.5], TextureOptions())
    assert levels[0].data != cmyk.getvalue()
    assert [(decoded(t).mode, t.width) for t in levels] == [("RGB", 64), ("RGB", 32)]


@settings(max_examples=25, deadline=None)
@given(
    st.integers(1, 96),
    st.integers(1, 96),
    st.sampled_from(["JPEG", "PNG", "BMP"]),
    st.sampled_from(["auto", "always", "never"]),
    st.integers(0, 2**32 - 1),
)
def test_every_level_decodes_to_its_declared_size(width, height, fmt, mode, seed):
    data = encode(
        sharp_rgb(width, height, seed) if seed % 2 else smooth_rgb(width, height, seed), fmt
    )
    scales = [1.0, 0.5, 0.25, 0.125]
    options = TextureOptions(fast_jpeg_downscale=mode, min_size=4)
    levels = build_texture_lods(texture_of(data, name="r." + fmt.lower()), scales, options)
    assert [(t.width, t.height) for t in levels] == level_sizes(width, height, scales, 4)
    for level in levels:
        image = decoded(level)
        assert image.size == (level.width, level.height)
        assert level.mime == {"JPEG": "image/jpeg", "PNG": "image/png"}[image.format]
    if fmt != "BMP":
        assert levels[0].data is data
