"""Procedural texture atlases for sample buildings, encoded as JPEG with fixed settings.

Data form: an atlas is a square ``size x size`` RGB Pillow image (row 0 at the top, as glTF UVs
address it; boxes are pixel ``(x0, y0, x1, y1)``, end exclusive) split into the UV regions of
:mod:`exporter.samplegen.kinds`: a facade (windows per floor and bay) over the top 5/8, a roof
(tiles) bottom-left and details (metal, copper) bottom-right. A little fixed noise makes the JPEG
sizes realistic for photo textures.

Determinism: every choice comes from the caller's ``numpy.random.Generator``; the grain is
drawn once per size from a fixed seed; JPEG settings (quality, 4:2:0 subsampling, baseline, no
optimisation) are fixed, so the same seed gives the same bytes with the same Pillow build.
"""

from __future__ import annotations

import io
from functools import lru_cache

import numpy as np
from PIL import Image, ImageChops, ImageDraw

JPEG_QUALITY = 85
NOISE_SEED = 20240101  # fixed: the grain is part of the look, not of the sample seed
ROOF_COLOURS = (
    (90, 90, 95),
    (150, 75, 55),
    (70, 100, 80),
    (80, 85, 110),
    (130, 125, 115),
)  # slate, terracotta, green, blue, concrete


@lru_cache(maxsize=4)
def grain(size: int) -> Image.Image:
    """Grey grain (size, size) RGB with values 0..20 (10 = no change), the same for every call and atlas."""
    values = np.random.default_rng(NOISE_SEED).integers(0, 21, size=(size, size), dtype=np.uint8)
    return Image.fromarray(np.repeat(values[:, :, None], 3, axis=2), "RGB")


def _colour(rng: np.random.Generator, low, high) -> tuple:
    return tuple(int(v) for v in rng.integers(low, high, size=3))


def facade(
    draw: ImageDraw.ImageDraw, rng: np.random.Generator, box: tuple, floors: int, bays: int
) -> None:
    """Wall colour with a ``floors x bays`` window grid in the pixel ``box`` (x0, y0, x1, y1), each window its own glass tone."""
    x0, y0, x1, y1 = box
    grey = int(rng.integers(120, 220))
    draw.rectangle(
        (x0, y0, x1 - 1, y1 - 1), fill=_colour(rng, grey - 12, grey + 12)
    )  # plaster, concrete, stone
    glass = rng.integers([35, 55, 75], [75, 100, 135])  # blue-grey glass
    tones = np.clip(glass + rng.integers(-25, 26, size=(floors, bays, 1)), 0, 255).tolist()
    floor_h, bay_w = (y1 - y0) / floors, (x1 - x0) / bays
    for f in range(floors):
        top, bottom = y0 + (f + 0.25) * floor_h, y0 + (f + 0.8) * floor_h
        for b in range(bays):
            draw.rectangle(
                (x0 + (b + 0.2) * bay_w, top, x0 + (b + 0.8) * bay_w, bottom),
                fill=tuple(tones[f][b]),
            )


def roof(draw: ImageDraw.ImageDraw, rng: np.random.Generator, box: tuple) -> None:
    """Roof colour with darker tile courses every few pixels in the pixel ``box``."""
    x0, y0, x1, y1 = box
    colour = np.clip(
        np.array(ROOF_COLOURS[int(rng.integers(len(ROOF_COLOURS)))])
        + rng.integers(-12, 13, size=3),
        0,
        255,
    )
    draw.rectangle((x0, y0, x1 - 1, y1 - 1), fill=tuple(int(c) for c in colour))
    dark = tuple(int(c) for c in np.clip(colour - 30, 0, 255))
    for y in range(y0, y1, max(2, (y1 - y0) // 24)):
        draw.line((x0, y, x1 - 1, y), fill=dark)


def details(draw: ImageDraw.ImageDraw, rng: np.random.Generator, box: tuple) -> None:
    """Left half metal grey, right half copper green in the pixel ``box``."""
    x0, y0, x1, y1 = box
    middle = (x0 + x1) // 2
    grey = int(rng.integers(130, 200))
    draw.rectangle((x0, y0, middle - 1, y1 - 1), fill=(grey, grey, grey))
    draw.rectangle(
        (middle, y0, x1 - 1, y1 - 1),
        fill=tuple(int(c) for c in rng.integers([70, 120, 100], [110, 170, 140])),
    )


def draw_atlas(rng: np.random.Generator, size: int, floors: int, bays: int) -> Image.Image:
    """The full ``size x size`` RGB atlas: facade top 5/8, roof bottom-left, details bottom-right, grain over all."""
    split = size * 5 // 8
    image = Image.new("RGB", (size, size))
    draw = ImageDraw.Draw(image)
    facade(draw, rng, (0, 0, size, split), max(1, floors), max(1, bays))
    roof(draw, rng, (0, split, size // 2, size))
    details(draw, rng, (size // 2, split, size, size))
    return ImageChops.add(image, grain(size), scale=1.0, offset=-10)


def encode_jpeg(image: Image.Image) -> bytes:
    """Baseline JPEG bytes with the module's fixed settings."""
    out = io.BytesIO()
    image.save(out, "JPEG", quality=JPEG_QUALITY, subsampling=2, optimize=False, progressive=False)
    return out.getvalue()
