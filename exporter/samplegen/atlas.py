"""Procedural texture atlases for sample buildings, encoded as JPEG with fixed settings.

Data form: an atlas is a square ``size x size`` RGB image (uint8 array ``(size, size, 3)``, row 0
at the top, as glTF UVs address it) split into the UV regions of
:mod:`exporter.samplegen.kinds`: a facade (windows per floor and bay) over the top 5/8, a roof
(tiles) bottom-left and details (metal, copper) bottom-right. A little fixed noise makes the JPEG
sizes realistic for photo textures.

Determinism: every choice comes from the caller's ``numpy.random.Generator``; the noise field is
drawn once per size from a fixed seed; JPEG settings (quality, 4:2:0 subsampling, baseline, no
optimisation) are fixed, so the same seed gives the same bytes with the same Pillow build.
"""
from __future__ import annotations

import io
from functools import lru_cache

import numpy as np
from PIL import Image

JPEG_QUALITY = 85
NOISE_SEED = 20240101  # fixed: the noise texture is part of the format, not of the sample seed


@lru_cache(maxsize=4)
def noise_field(size: int) -> np.ndarray:
    """Grain (size, size) int16 in [-10, 10], the same for every call."""
    return np.random.default_rng(NOISE_SEED).integers(-10, 11, size=(size, size)).astype(np.int16)


def facade(rng: np.random.Generator, height: int, width: int, floors: int, bays: int) -> np.ndarray:
    """Wall colour with a ``floors x bays`` window grid, each window a slightly different glass tone; (h, w, 3) int16."""
    wall = rng.integers(120, 225, size=3)
    glass = rng.integers(40, 110, size=3)
    rows = np.arange(height) * floors // height
    cols = np.arange(width) * bays // width
    in_floor = (np.arange(height) * floors % height) / height  # 0..1 within a floor, top first
    in_bay = (np.arange(width) * bays % width) / width
    window = ((in_floor > 0.25) & (in_floor < 0.8))[:, None] & ((in_bay > 0.2) & (in_bay < 0.8))[None, :]
    tone = rng.integers(-25, 26, size=(floors, bays))[rows[:, None], cols[None, :]]
    image = np.broadcast_to(wall, (height, width, 3)).astype(np.int16).copy()
    image[window] = glass + tone[window][:, None]
    return image


def roof(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    """Roof colour with darker tile courses every few pixels; (h, w, 3) int16."""
    colour = rng.integers(60, 170, size=3)
    course = max(2, height // 24)
    shade = np.where(np.arange(height) % course == 0, -30, 0)
    return (colour[None, None, :] + shade[:, None, None] + np.zeros((1, width, 1), np.int16)).astype(np.int16)


def details(rng: np.random.Generator, height: int, width: int) -> np.ndarray:
    """Left half metal grey, right half copper green; (h, w, 3) int16."""
    image = np.empty((height, width, 3), np.int16)
    image[:, : width // 2] = rng.integers(130, 200) + np.zeros(3, np.int16)
    image[:, width // 2 :] = rng.integers([70, 120, 100], [110, 170, 140])
    return image


def draw_atlas(rng: np.random.Generator, size: int, floors: int, bays: int) -> np.ndarray:
    """The full atlas (size, size, 3) uint8: facade top 5/8, roof bottom-left, details bottom-right."""
    split = size * 5 // 8
    image = np.empty((size, size, 3), np.int16)
    image[:split] = facade(rng, split, size, max(1, floors), max(1, bays))
    image[split:, : size // 2] = roof(rng, size - split, size // 2)
    image[split:, size // 2 :] = details(rng, size - split, size - size // 2)
    dy, dx = rng.integers(0, size, size=2)
    image += np.roll(noise_field(size), (int(dy), int(dx)), axis=(0, 1))[:, :, None]
    return np.clip(image, 0, 255).astype(np.uint8)


def encode_jpeg(image: np.ndarray) -> bytes:
    """Baseline JPEG bytes with the module's fixed settings."""
    out = io.BytesIO()
    Image.fromarray(image, "RGB").save(out, "JPEG", quality=JPEG_QUALITY, subsampling=2, optimize=False, progressive=False)
    return out.getvalue()
