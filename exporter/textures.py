"""Texture LoDs: one encoded atlas in, one encoded atlas per level of detail out.

Data form: a :class:`~exporter.model.Texture` holds the *encoded* bytes of one atlas (JPEG, PNG,
or another format Pillow reads) and its size in pixels. Each level ``k`` gets the atlas scaled per
side by ``scales[k]`` (``lods[].texture``; 0.5 = a quarter of the pixels, the paper's rule). UVs are
normalised (0..1, glTF convention), so they stay valid at every size and are never touched here.

Sizes per level (:func:`level_size`), all in pixels:

- never larger than the source, and LOD0 at scale 1.0 is the source size;
- power-of-two sources (both sides) stay power-of-two: the scale is rounded to a power of two
  (1024x512 -> 512x256 -> 256x128), so mip chains stay whole;
- other sources get sides rounded to a multiple of 4: it keeps the aspect ratio and the requested
  pixel budget (rounding to a power of two can halve or double the pixels and skew the aspect),
  and 4x4 blocks are what BCn / ETC2 / ASTC 4x4 compression in Unity need; every GPU Unity
  targets (GLES3+) mips non-power-of-two textures;
- the shorter side is not reduced below ``min_size`` (nor above the source's own shorter side);
  the other side follows the aspect ratio.

Formats: LOD0 at the source size keeps the source bytes unchanged for JPEG and PNG; other formats
are converted once (PNG when the image has real transparency, else JPEG). Reduced levels are
JPEG for JPEG sources, PNG with alpha for transparent PNGs, and PNG (or JPEG with
``opaque_png_to_jpeg``) for opaque PNGs.

Speed: a source is decoded once. A JPEG source is decoded directly at 1/2, 1/4 or 1/8 size where
the reduced levels allow it (libjpeg's scaled IDCT via Pillow's ``Image.draft``), and each smaller
level is made from the previous one. The scaled IDCT filters about like a box filter: fine on
photographs, aliasing on detail near the pixel size. ``fast_jpeg_downscale: auto`` measures, on the
level it has, how far a k x k box reduction is from a Lanczos one (PSNR, :func:`sampled_box_psnr`:
25 fixed 12x12-pixel blocks of a 512² level, bit-exact there): below 35 dB the IDCT shortcut is refused
(full decode, Lanczos LOD1), and each later level is a box reduction of the level above
(``Image.reduce``, as GPU mip chains are) where that level passes, Lanczos where it does not.
``always`` skips the checks (box wherever the size divides evenly); ``never`` decodes the full
image and makes every level by Lanczos from it. Numbers in ``benchmarks/bench_textures.py`` and
``docs/textures.md``. Results are kept in a process-wide LRU cache bounded in bytes, so an atlas
shared by many buildings is processed once per process.

Bounded memory: the declared size is read from the header and checked against ``max_pixels``
before any pixel is decoded.

Sources: the paper ("A Method for Constructing and Managing Level of Detail for Non-Closed
Boundary Models of Buildings", texture atlases a quarter of the pixels per level);
Pillow handbook (``Image.draft``, ``Image.resize`` with ``LANCZOS``, ``Image.reduce``,
decompression-bomb protection ``Image.MAX_IMAGE_PIXELS``) and its ``libImaging/Resample.c`` (a
reduction reads only the source pixels within the filter's support, which makes the sampled
check's blocks exact); libjpeg-turbo's scaled IDCT (``scale_num/scale_denom``); Unity's texture
importer (mipmaps by a box filter by default).
"""

from __future__ import annotations

import dataclasses
import io
import math
import threading
import warnings
from collections import OrderedDict
from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import numpy as np
from PIL import Image, ImageChops, ImageStat, UnidentifiedImageError

from .config import TextureOptions
from .errors import ReadError
from .model import Texture

# Formats Pillow may open for us: the usual atlas formats only (no EPS/PDF plugins that shell out).
ALLOWED_FORMATS = ("JPEG", "PNG", "BMP", "TGA", "GIF", "WEBP", "TIFF", "PPM", "DDS")
MIME = {"JPEG": "image/jpeg", "PNG": "image/png"}
EXTENSION = {"JPEG": ".jpg", "PNG": ".png"}

# The fast JPEG path (IDCT-scaled decode) filters about like a box filter. ``auto`` uses it for
# an atlas only when the box-vs-Lanczos PSNR measured one octave further down on the decoded image
# itself is >= AUTO_MIN_PSNR_DB (scale similarity of images), and only at the factors where that
# estimate held in benchmarks/bench_textures.py (1/2: -4.7..+2.9 dB off the truth, 1/4: -1.3..+1.7,
# same side of 35 dB on all 31 atlases; 1/8 overshot by up to 5.9 dB); otherwise it decodes the
# full image. The same measure decides whether a later level may be a box reduction of the level
# above. It is taken on a sample of blocks (sampled_box_psnr; agreement with the whole image in
# docs/textures.md).
AUTO_MIN_PSNR_DB = 35.0
AUTO_DRAFT_FACTORS = (2, 4)
SAMPLE_BLOCKS = 5  # per side: 5 x 5 blocks
SAMPLE_BLOCK_OUT = 6  # output pixels per block side
LANCZOS_REACH = 3  # Lanczos-3 reads 3 k source pixels either side of a k-times reduction's pixel
ALWAYS_DRAFT_FACTORS = (2, 4, 8)
# JPEG/PNG outputs of a whole run rarely exceed this; an LRU on bytes keeps memory bounded.
CACHE_MAX_BYTES = 64 * 2**20
# Atlases remembered as seen once (a few hundred bytes each): only a second sighting is cached, so
# a tile of one atlas per building (VWorld) keeps no texture bytes at all.
SEEN_MAX_ENTRIES = 16384


# --------------------------------------------------------------------------- sizes


def is_power_of_two(n: int) -> bool:
    return n > 0 and n & (n - 1) == 0


def level_size(width: int, height: int, scale: float, min_size: int) -> tuple[int, int]:
    """Size in pixels ``(width, height)`` of a level scaled per side by ``scale`` (see module doc).

    ``width``/``height`` are the source's pixels, ``scale`` in (0, 1], ``min_size`` pixels.
    """
    if scale >= 1.0:
        return width, height
    shorter = min(width, height)
    if is_power_of_two(width) and is_power_of_two(height):
        # The scale rounded to the nearest power of two in log scale (0.7 -> 0.5, 0.75 -> 1).
        shift = max(0, round(-math.log2(scale)))
        while shift > 0 and shorter >> shift < min(min_size, shorter):
            shift -= 1
        return width >> shift, height >> shift
    # Not below the factor that keeps the shorter side at min_size (or at its own size).
    factor = max(scale, min(1.0, min_size / shorter))
    return _multiple_of_4(width, factor, min_size), _multiple_of_4(height, factor, min_size)


def _multiple_of_4(side: int, factor: float, min_size: int) -> int:
    if side <= 4:
        return side
    target = max(4, int(round(side * factor / 4.0)) * 4)
    if target < min(min_size, side):
        target += 4
    return min(target, side)


def level_sizes(
    width: int, height: int, scales: Sequence[float], min_size: int
) -> list[tuple[int, int]]:
    """:func:`level_size` for each scale, LOD0 first; pixels."""
    return [level_size(width, height, float(s), min_size) for s in scales]


# --------------------------------------------------------------------------- quality


def psnr(reference: np.ndarray, image: np.ndarray) -> float:
    """Peak signal-to-noise ratio in dB of ``image`` against ``reference``.

    Both (h, w) or (h, w, c) arrays of 8-bit values, same shape; ``inf`` when identical.
    """
    difference = reference.astype(np.float64) - image.astype(np.float64)
    mse = float(np.mean(difference * difference))
    return math.inf if mse == 0.0 else 10.0 * math.log10(255.0 * 255.0 / mse)


def image_psnr(reference: Image.Image, image: Image.Image) -> float:
    """:func:`psnr` of two Pillow images of the same size and mode, in dB (computed in C)."""
    squares = [rms * rms for rms in ImageStat.Stat(ImageChops.difference(reference, image)).rms]
    mse = sum(squares) / len(squares)
    return math.inf if mse == 0.0 else 10.0 * math.log10(255.0 * 255.0 / mse)


# --------------------------------------------------------------------------- decoding

_pillow_limit_lock = threading.Lock()


def _problem_of_bytes(data: bytes) -> str:
    head = data[:256].lstrip()
    if head[:1] == b"<":
        snippet = head[:80].decode("utf-8", "replace").replace("\n", " ")
        return f"not an image but XML/HTML (a service error page?): {snippet!r}"
    return f"not a readable image ({len(data)} bytes starting {data[:8].hex()})"


@contextmanager
def pillow_pixel_limit(max_pixels: int | None) -> Iterator[None]:
    """Pillow's own decompression-bomb guard set to ``max_pixels`` (None: off) while the block
    opens images: its default (refusing above about 179 MP) would otherwise refuse atlases that
    ``textures.max_pixels`` (268 MP) accepts, in its own words. The limit is process-wide, so the
    lock keeps concurrent opens from seeing each other's value."""
    with _pillow_limit_lock:
        saved = Image.MAX_IMAGE_PIXELS
        Image.MAX_IMAGE_PIXELS = max_pixels
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", Image.DecompressionBombWarning)
                yield
        finally:
            Image.MAX_IMAGE_PIXELS = saved


def open_header(data: bytes, where: str, max_pixels: int) -> Image.Image:
    """Open encoded ``data`` lazily (header only) and refuse it if its declared size exceeds
    ``max_pixels``; raises ReadError naming ``where``. No pixel is decoded here."""
    if not data:
        raise ReadError(where, "texture is missing or empty (0 bytes)")
    # Pillow's own guard off for this header-only open: the check below, on the header's size,
    # is the one users read about (it names the size and textures.max_pixels).
    with pillow_pixel_limit(None):
        try:
            image = Image.open(io.BytesIO(data), formats=ALLOWED_FORMATS)
        except (UnidentifiedImageError, OSError, ValueError, SyntaxError):
            raise ReadError(where, _problem_of_bytes(data)) from None
    width, height = image.size
    if width <= 0 or height <= 0:
        raise ReadError(where, f"image declares an empty size {width}x{height}")
    if width * height > max_pixels:
        raise ReadError(
            where,
            f"image declares {width}x{height} = {width * height} pixels, over textures.max_pixels = {max_pixels}; refused before decoding",
        )
    return image


def _decode(image: Image.Image, where: str) -> Image.Image:
    """Decode the pixels of a lazily opened image into RGB, RGBA or L; ReadError when broken."""
    try:
        image.load()
    except MemoryError:
        raise ReadError(
            where, f"image of {image.width}x{image.height} pixels does not fit in memory"
        ) from None
    except Exception as error:  # any decoder failure is this file's problem, never the run's
        raise ReadError(
            where, f"image data is truncated or corrupt ({type(error).__name__}: {error})"
        ) from None
    if image.mode in ("RGB", "RGBA", "L"):
        return image
    if image.mode == "I" or image.mode.startswith("I;16"):
        # 16-bit grey (PNG): keep the high byte; Pillow's own conversion would clip at 255.
        grey = np.asarray(image).astype(np.int64) >> 8
        return Image.fromarray(np.clip(grey, 0, 255).astype(np.uint8), "L")
    has_alpha = image.mode in ("LA", "PA", "La", "RGBa") or "transparency" in image.info
    try:
        return image.convert("RGBA" if has_alpha else "RGB")
    except ValueError as error:
        raise ReadError(where, f"unsupported pixel mode {image.mode} ({error})") from None


def has_transparency(image: Image.Image) -> bool:
    """True when a decoded RGB/RGBA/L image has at least one pixel with alpha below 255."""
    if image.mode != "RGBA":
        return False
    low, _ = image.getchannel("A").getextrema()  # one band: (low, high) ints
    return int(low) < 255  # type: ignore[arg-type]


def draft_factors(options: TextureOptions) -> tuple[int, ...]:
    """IDCT reduction factors a JPEG source may be decoded at under ``options``."""
    return {"auto": AUTO_DRAFT_FACTORS, "always": ALWAYS_DRAFT_FACTORS, "never": ()}[
        options.fast_jpeg_downscale
    ]


def _draft(image: Image.Image, target: tuple[int, int], factors: tuple[int, ...]) -> None:
    """Ask libjpeg to decode at the largest allowed 1/factor that still covers ``target`` pixels."""
    if not factors:
        return
    width, height = image.size
    largest = max(factors)
    request = (max(target[0], -(-width // largest)), max(target[1], -(-height // largest)))
    image.draft(image.mode, request)


# --------------------------------------------------------------------------- encoding


def _encode(image: Image.Image, fmt: str, quality: int) -> bytes:
    out = io.BytesIO()
    # Keep the source's colour profile so every level shows the same colours as LOD0.
    profile = {"icc_profile": image.info["icc_profile"]} if image.info.get("icc_profile") else {}
    if fmt == "JPEG":
        if image.mode == "RGBA":
            image = image.convert("RGB")
        image.save(out, "JPEG", quality=quality, **profile)
    else:
        image.save(out, "PNG", **profile)
    return out.getvalue()


def _level_name(name: str, level: int, fmt: str) -> str:
    stem = name.rsplit(".", 1)[0] if "." in name else (name or "texture")
    return f"{stem}_lod{level}{EXTENSION[fmt]}"


# --------------------------------------------------------------------------- the cache


class _Content:
    """Encoded bytes as a dict key: hashed on their length and ends (no pass over the whole file,
    a JPEG's tail is entropy-coded pixels), equal only when every byte is equal (one memcmp),
    so a hash collision costs a comparison and can never mix two atlases up."""

    __slots__ = ("data", "_hash")

    def __init__(self, data: bytes) -> None:
        self.data = data
        self._hash = hash((len(data), data[:4096], data[-4096:]))

    def __hash__(self) -> int:
        return self._hash

    def __eq__(self, other: object) -> bool:
        return isinstance(other, _Content) and (self.data is other.data or self.data == other.data)


class _LevelCache:
    """Process-wide LRU of finished levels (or of the problem found), bounded by total bytes.

    Keys are ``(_Content(source bytes), scales, options)``; the source bytes are counted in the
    budget. Admission on the second sighting: a key's first result is not stored, only noted (by
    hash, no bytes held) in a bounded LRU of ``seen_max`` keys, so atlases used once never occupy
    memory and a shared atlas is built at most twice.
    """

    def __init__(self, max_bytes: int, seen_max: int = SEEN_MAX_ENTRIES) -> None:
        self.max_bytes = max_bytes
        self.seen_max = seen_max
        self.seen: OrderedDict = OrderedDict()  # hash((content hash, scales, options)) -> None
        self.entries: OrderedDict = OrderedDict()  # key -> levels tuple or problem str
        self.bytes = 0
        self.hits = 0
        self.misses = 0
        self.lock = threading.Lock()

    @staticmethod
    def size_of(key, value) -> int:
        if isinstance(value, str):
            return len(key[0].data) + 256
        return len(key[0].data) + sum(len(level[0]) for level in value if not level[4])

    def get(self, key):
        with self.lock:
            value = self.entries.get(key)
            if value is None:
                self.misses += 1
                return None
            self.entries.move_to_end(key)
            self.hits += 1
            return value

    def put(self, key, value) -> None:
        size = self.size_of(key, value)
        if size > self.max_bytes:
            return
        with self.lock:
            if key in self.entries:
                return
            sighting = hash(key)
            if sighting not in self.seen:  # first sighting: remember it, keep nothing
                self.seen[sighting] = None
                if len(self.seen) > self.seen_max:
                    self.seen.popitem(last=False)
                return
            del self.seen[sighting]
            self.entries[key] = value
            self.bytes += size
            while self.bytes > self.max_bytes:
                old_key, old_value = self.entries.popitem(last=False)
                self.bytes -= self.size_of(old_key, old_value)

    def clear(self) -> None:
        with self.lock:
            self.entries.clear()
            self.seen.clear()
            self.bytes = self.hits = self.misses = 0


_cache = _LevelCache(CACHE_MAX_BYTES)


def clear_texture_cache() -> None:
    """Forget every cached result (tests, or a long-lived process between runs)."""
    _cache.clear()


def texture_cache_stats() -> dict:
    """``{"entries", "bytes", "max_bytes", "hits", "misses"}`` of the process-wide cache."""
    with _cache.lock:
        return {
            "entries": len(_cache.entries),
            "bytes": _cache.bytes,
            "max_bytes": _cache.max_bytes,
            "hits": _cache.hits,
            "misses": _cache.misses,
        }


# --------------------------------------------------------------------------- the pipeline


def box_psnr(image: Image.Image, k: int) -> float:
    """dB: PSNR of a k x k box reduction of ``image`` (``Image.reduce``) against its Lanczos
    reduction to the same size (``Image.resize``), over the whole image: what :func:`sampled_box_psnr`
    estimates. ``k`` >= 2; sides not divisible by ``k`` are compared at the box's size."""
    box = image.reduce(k)
    return image_psnr(image.resize(box.size, Image.Resampling.LANCZOS), box)


def sample_origins(side: int, count: int, block: int, margin: int, k: int) -> list[int]:
    """First source pixels of ``count`` blocks of ``block`` pixels along a side of ``side`` pixels:
    one per stratum of the side (inside ``margin``), placed in its stratum by a golden-ratio
    sequence so the blocks do not line up with an atlas's regular layout; multiples of ``k``."""
    low, high = margin, side - margin - block
    stratum = (high - low) / count
    return [
        low + int((i + (i * 0.6180339887 + 0.5) % 1.0) * stratum) // k * k for i in range(count)
    ]


def _mosaic(
    image: Image.Image, xs: list[int], ys: list[int], margin: int, cell: int
) -> Image.Image:
    """The ``cell``-pixel squares around block origins ``xs`` x ``ys`` (source pixels, ``margin``
    pixels before each origin) side by side, rows of ``ys``: one (len(xs) cell, len(ys) cell) image.

    Rows are cut first into one band, then the band's columns: 2 (n + n) crops and pastes instead
    of 2 n² (Pillow's public API; its per-call checks cost as much as the pixel work here).
    """
    width = image.width
    band = Image.new(image.mode, (width, len(ys) * cell), None)  # every pixel is pasted over
    for i, y in enumerate(ys):
        band.paste(image.crop((0, y - margin, width, y - margin + cell)), (0, i * cell))
    mosaic = Image.new(image.mode, (len(xs) * cell, len(ys) * cell), None)
    for j, x in enumerate(xs):
        mosaic.paste(band.crop((x - margin, 0, x - margin + cell, len(ys) * cell)), (j * cell, 0))
    return mosaic


def sampled_box_psnr(image: Image.Image, k: int) -> float:
    """dB: :func:`box_psnr` of ``image`` estimated on a fixed sample of blocks (whole image when small).

    ``SAMPLE_BLOCKS`` x ``SAMPLE_BLOCKS`` blocks of ``SAMPLE_BLOCK_OUT``² output pixels, each cut
    with a margin of ``LANCZOS_REACH * k`` source pixels (the filter's reach) and pasted side by
    side into one mosaic; the mosaic is reduced both ways and the block interiors compared. With
    the margins the interiors are bit for bit the pixels a reduction of the whole image gives
    there (Pillow filters within the reach only), so the estimate differs from the whole-image
    PSNR only by what the sample misses. Costs a Lanczos pass over ~14 k pixels instead of the
    image's (0.25 M for a 512² level). Levels under 4 x the mosaic's pixels, narrower than two
    cells or with sides not divisible by ``k`` are measured whole.
    """
    block, margin = SAMPLE_BLOCK_OUT * k, LANCZOS_REACH * k
    cell = block + 2 * margin
    n = SAMPLE_BLOCKS
    width, height = image.size
    if (
        width % k
        or height % k
        or min(width, height) < 2 * cell
        or 4 * (n * cell) ** 2 > width * height
    ):
        return box_psnr(image, k)
    mosaic = _mosaic(
        image,
        sample_origins(width, n, block, margin, k),
        sample_origins(height, n, block, margin, k),
        margin,
        cell,
    )
    side = n * cell // k
    difference = ImageChops.difference(
        mosaic.resize((side, side), Image.Resampling.LANCZOS), mosaic.reduce(k)
    )
    inner = slice(margin // k, margin // k + SAMPLE_BLOCK_OUT)
    errors = (
        np.frombuffer(difference.tobytes(), np.uint8)
        .reshape(n, cell // k, n, cell // k, -1)[:, inner, :, inner]
        .astype(np.int64)
        .ravel()
    )
    # Integer squares: the sum is exact (< 2**53), so the mean is the float64 mean's own value.
    mse = int(np.dot(errors, errors)) / errors.size
    return math.inf if mse == 0.0 else 10.0 * math.log10(255.0 * 255.0 / mse)


class _BoxCheck:
    """``auto``'s per-level check, each (image, k) measured once: may the level ``k`` times
    smaller be a box reduction of ``image``?"""

    def __init__(self) -> None:
        self.found: dict = {}
        self.images: list = []  # keeps the measured images alive, so their ids stay theirs

    def passes(self, image: Image.Image, k: int) -> bool:
        key = (id(image), k)
        if key not in self.found:
            self.images.append(image)
            self.found[key] = sampled_box_psnr(image, k) >= AUTO_MIN_PSNR_DB
        return self.found[key]


def _decode_jpeg(
    header: Image.Image,
    where: str,
    options: TextureOptions,
    target: tuple[int, int] | None,
    check: _BoxCheck,
) -> tuple[Image.Image | None, bool]:
    """Decode the JPEG opened lazily as ``header`` once for levels no larger than ``target``
    pixels (None: validation only).

    Returns the image (None when ``auto``'s check asks for the full image instead) and whether each
    level is resized from the previous one. The full-size pixels are never needed for themselves:
    LOD0 keeps the source bytes.
    """
    if target is None:
        _draft(header, (1, 1), ALWAYS_DRAFT_FACTORS)
        return _decode(header, where), False
    full_width = header.width
    _draft(header, target, draft_factors(options))
    decoded = _decode(header, where)
    chain = options.fast_jpeg_downscale != "never"
    # Too much detail near the pixel size: the IDCT shortcut would alias it.
    if (
        decoded.width < full_width
        and options.fast_jpeg_downscale == "auto"
        and not check.passes(decoded, 2)
    ):
        return None, chain
    return decoded, chain


def integer_factor(source: tuple[int, int], size: tuple[int, int]) -> int:
    """The whole number ``k`` with ``source == k * size`` on both sides (pixels), else 0."""
    k = source[0] // size[0]
    return k if k >= 1 and source == (size[0] * k, size[1] * k) else 0


def _output_format(source_format: str, transparent: bool, options: TextureOptions) -> str:
    """Format (JPEG or PNG) of every level that is not the source's own bytes."""
    if source_format == "JPEG":
        return "JPEG"
    if source_format == "PNG":
        return "JPEG" if options.opaque_png_to_jpeg and not transparent else "PNG"
    return "PNG" if transparent else "JPEG"


def _build_levels(
    data: bytes, scales: Sequence[float], options: TextureOptions, where: str
) -> list[tuple]:
    """Encoded levels ``[(bytes, format, width, height, is_source_bytes), ...]`` for one source."""
    header = open_header(data, where, options.max_pixels)
    source_format, (width, height) = header.format, header.size
    sizes = level_sizes(width, height, scales, options.min_size)
    reduced = [size for size in sizes if size != (width, height)]
    # CMYK JPEGs are not portable glTF images (Unity cannot load them): convert even LOD0.
    keeps_bytes = source_format in MIME and header.mode != "CMYK"
    check = _BoxCheck()
    if source_format == "JPEG" and keeps_bytes:
        largest = max(reduced, key=lambda size: size[0] * size[1]) if reduced else None
        # The header opened above is decoded in place (at reduced size): no second parse.
        decoded, chain = _decode_jpeg(header, where, options, largest, check)
        # Holding the header could pin its reduced pixels: dropped before a full decode (peak
        # memory on big atlases) and while the levels are made.
        del header
        if decoded is None:
            decoded = _decode(open_header(data, where, options.max_pixels), where)
    else:
        decoded, chain = _decode(header, where), False
    transparent = has_transparency(decoded)
    if not transparent and decoded.mode == "RGBA":
        decoded = decoded.convert("RGB")
    fmt = _output_format(source_format or "", transparent, options)

    source_level = (data, source_format, width, height, True) if keeps_bytes else None

    # A level made from the level above (never from the full-size source) is a box reduction
    # (Image.reduce, ~15x cheaper than Lanczos) under ``always``, and under ``auto`` where the
    # check predicts it within AUTO_MIN_PSNR_DB of Lanczos; Lanczos otherwise.
    mode = options.fast_jpeg_downscale if chain else "never"
    levels: list[tuple] = []
    previous = decoded
    for size in sizes:
        if levels and size == tuple(levels[-1][2:4]):
            levels.append(levels[-1])
            continue
        if size == (width, height):
            if source_level is None:
                source_level = (
                    _encode(decoded, fmt, options.jpeg_quality),
                    fmt,
                    width,
                    height,
                    False,
                )
            levels.append(source_level)
            continue
        base = previous if chain else decoded
        k = integer_factor(base.size, size)
        if base.size == size:
            resized = base
        elif k > 1 and (
            mode == "always"
            or mode == "auto"
            and base.size != (width, height)
            and check.passes(base, k)
        ):
            resized = base.reduce(k)
        else:
            resized = base.resize(size, Image.Resampling.LANCZOS)
        levels.append((_encode(resized, fmt, options.jpeg_quality), fmt, size[0], size[1], False))
        previous = resized
    return levels


def build_texture_lods(
    texture: Texture, scales: list[float], options: TextureOptions
) -> list[Texture]:
    """One :class:`Texture` per level for ``scales`` (per-side factors, LOD0 first).

    Raises :class:`~exporter.errors.ReadError` naming ``texture.source`` (or ``texture.name``) when
    the image is missing, truncated, undecodable, or declares more than ``options.max_pixels``.
    Identical bytes with identical scales and options are processed once per process.
    """
    where = texture.source or texture.name or "<embedded texture>"
    if not scales:
        return []
    if not all(0.0 < s <= 1.0 for s in scales):
        raise ValueError(f"texture scales must be in (0, 1], got {scales!r}")
    data = bytes(texture.data)
    # The options' field values (scalars): astuple's deep copy costs five times as much.
    fields = tuple(getattr(options, f.name) for f in dataclasses.fields(options))
    key = (_Content(data), tuple(float(s) for s in scales), fields)
    cached = _cache.get(key)
    if cached is None:
        try:
            cached = tuple(_build_levels(data, scales, options, where))
        except ReadError as error:
            cached = error.problem
        _cache.put(key, cached)
    if isinstance(cached, str):
        raise ReadError(where, cached)
    # The source level hands back the caller's own bytes object (a cache hit may come from
    # another building with equal bytes).
    return [
        Texture(
            data=texture.data,
            mime=MIME[fmt],
            width=w,
            height=h,
            name=texture.name,
            source=texture.source,
        )
        if is_source
        else Texture(
            data=level_data,
            mime=MIME[fmt],
            width=w,
            height=h,
            name=_level_name(texture.name, k, fmt),
            source=texture.source,
        )
        for k, (level_data, fmt, w, h, is_source) in enumerate(cached)
    ]
