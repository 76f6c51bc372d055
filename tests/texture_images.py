"""Images the texture tests make themselves, and where the real aerial atlases live.

Arrays are (height, width, 3) uint8 RGB; ``REAL_ATLASES`` are the aerial photographs of the
Rotterdam CityJSON in ``tests/data/real`` (``PROVENANCE.md``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

REAL_ATLASES = (
    Path(__file__).resolve().parents[1]
    / "tests"
    / "data"
    / "real"
    / "rotterdam_textured"
    / "appearances"
)
SCALES = [1.0, 0.5, 0.25]


def smooth_rgb(width: int, height: int, seed: int = 0) -> np.ndarray:
    """A photo-like image (smooth gradients, faint noise): (height, width, 3) uint8."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width] / max(width, height)
    image = np.stack(
        [120 + 80 * np.sin(6 * x + 2 * y), 100 + 60 * np.cos(5 * y), 90 + 50 * np.sin(3 * (x + y))],
        axis=-1,
    )
    return np.clip(image + rng.normal(0, 1, image.shape), 0, 255).astype(np.uint8)


def sharp_rgb(width: int, height: int, seed: int = 0) -> np.ndarray:
    """Pixel-sized black/white detail (makes ``auto`` fall back; a stress case for box-like
    filters): (height, width, 3) uint8."""
    grid = np.random.default_rng(seed).random((height, width)) > 0.5
    return np.repeat(np.where(grid, 255, 0).astype(np.uint8)[..., None], 3, axis=-1)
