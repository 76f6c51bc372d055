"""Texture detail for the report: the same small region of a level's atlas at its own resolution.

The renders are thumbnails and cannot show what the texture LoDs lose (each level has a quarter of
the pixels of the one above). A crop of the centre of each level's largest atlas, in normalised
image coordinates so every level shows the same content, makes it visible: LOD0's 1024 px atlas
gives a 128 px crop, LOD1's 512 px one 64 px, LOD2's 256 px one 32 px; the page shows them at one
size with pixelated scaling.

Data form: the ``.glb``'s embedded images (glTF ``images[]`` in the binary chunk), read with
pygltflib; output (h, w, 3) uint8 RGB at the atlas' own pixel size.
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image
from pygltflib import GLTF2

from ..errors import InputError

DETAIL_FRACTION = 1.0 / 8.0  # side of the cropped square as a share of the atlas side


def embedded_images(path: Path) -> list[bytes]:
    """Encoded bytes of every image stored in the ``.glb``'s binary chunk (others are skipped)."""
    try:
        gltf = GLTF2.load_binary(str(path))
        blob = gltf.binary_blob() or b""
    except Exception as error:  # pygltflib raises many types for a broken file
        raise InputError(
            f"{path}: cannot be read as glTF binary ({type(error).__name__}: {error})"
        ) from None
    out = []
    for image in gltf.images:
        if image.bufferView is None:
            continue
        view = gltf.bufferViews[image.bufferView]
        start = view.byteOffset or 0
        out.append(blob[start : start + view.byteLength])
    return out


def atlas_detail(path: str | Path, fraction: float = DETAIL_FRACTION) -> np.ndarray | None:
    """The centre ``fraction`` x ``fraction`` of the largest atlas (by pixels) of a level's ``.glb``
    as (h, w, 3) uint8 at the atlas' resolution; None when the level has no readable image."""
    largest, largest_pixels = None, 0
    for data in embedded_images(Path(path)):
        try:
            image = Image.open(io.BytesIO(data))  # lazy: only the header is read here
        except Exception:  # an unreadable image is the texture stage's problem, reported there
            continue
        if image.width * image.height > largest_pixels:
            largest, largest_pixels = image, image.width * image.height
    if largest is None:
        return None
    width, height = largest.size
    side_x, side_y = max(1, round(width * fraction)), max(1, round(height * fraction))
    left, top = (width - side_x) // 2, (height - side_y) // 2
    try:
        return np.asarray(
            largest.convert("RGB").crop((left, top, left + side_x, top + side_y)), dtype=np.uint8
        )
    except Exception:  # truncated image data
        return None
