"""One texture atlas per building from several per-surface images (CityGML's usual layout).

Images are packed on shelves (tallest first) with a few pixels of edge-replicated padding so
bilinear filtering and the reduced texture levels do not bleed neighbours in; each textured
:class:`~exporter.model.Part` then has its UVs (glTF convention, top-left origin, 0..1 over its
own image) mapped into its image's rectangle and all of them become one part with the atlas. The
atlas is JPEG (quality 95) when every source is an opaque JPEG, else PNG, so the texture LoD chain
applies unchanged. Parts whose UVs leave 0..1 (repeating textures) cannot share an atlas and stay
as they are.
"""

from __future__ import annotations

import io
import math

import numpy as np
from PIL import Image

from ..model import Part, Texture

PADDING = 4  # pixels of replicated edge around each image
MAX_SIDE = 8192  # pixels: a larger atlas is not made (the parts stay separate)
UV_SLACK = 1e-3  # UVs this far outside 0..1 are clamped (rounding in the source)


def packable(part: Part) -> bool:
    """True when ``part`` has a texture and every UV lies in 0..1 (within UV_SLACK)."""
    if part.texture is None or part.uvs is None or not len(part.uvs):
        return False
    return bool(np.all(part.uvs >= -UV_SLACK) and np.all(part.uvs <= 1.0 + UV_SLACK))


def shelf_pack(sizes: list[tuple[int, int]], padding: int = PADDING) -> tuple[list, int, int]:
    """Positions (x, y) in pixels of each (width, height) image (padding included around each),
    and the atlas (width, height): shelves filled left to right, tallest images first."""
    padded = [(w + 2 * padding, h + 2 * padding) for w, h in sizes]
    area = sum(w * h for w, h in padded)
    width = max(max(w for w, _ in padded), math.ceil(math.sqrt(area)))
    order = sorted(range(len(sizes)), key=lambda i: (-padded[i][1], i))
    positions: list = [None] * len(sizes)
    x = y = shelf = 0
    for i in order:
        w, h = padded[i]
        if x + w > width:
            x, y, shelf = 0, y + shelf, 0
        positions[i] = (x + padding, y + padding)
        x, shelf = x + w, max(shelf, h)
    return positions, width, y + shelf


def _pixels(texture: Texture, mode: str) -> np.ndarray:
    with Image.open(io.BytesIO(texture.data)) as image:
        return np.asarray(image.convert(mode))


def pack_parts(parts: list[Part], name: str) -> tuple[list[Part], str | None]:
    """``parts`` with every packable textured part (:func:`packable`) merged into one part on a
    new atlas named ``name``, the others unchanged (first); and a problem text when packing was
    not possible (the parts are then returned as they were). Fewer than two packable textures:
    nothing to do."""
    packed = [p for p in parts if packable(p)]
    textures: list[Texture] = []
    for part in packed:
        if not any(part.texture is t for t in textures):
            textures.append(part.texture)  # type: ignore[arg-type]
    if len(textures) < 2:
        return parts, None
    positions, width, height = shelf_pack([(t.width, t.height) for t in textures])
    if max(width, height) > MAX_SIDE:
        return parts, f"textures need a {width}x{height} atlas (over {MAX_SIDE}): kept separate"
    alpha = any(t.mime != "image/jpeg" for t in textures)
    mode = "RGBA" if alpha else "RGB"
    canvas = np.zeros((height, width, len(mode)), dtype=np.uint8)
    try:
        for texture, (x, y) in zip(textures, positions):
            pixels = _pixels(texture, mode)
            if pixels.shape[:2] != (texture.height, texture.width):
                raise ValueError(f"{texture.name} decodes to another size than its header says")
            p = PADDING
            canvas[y - p : y + texture.height + p, x - p : x + texture.width + p] = np.pad(
                pixels, ((p, p), (p, p), (0, 0)), mode="edge"
            )
    except Exception as error:  # an image that stops decoding part-way: keep the parts as read
        return parts, f"textures not packed into an atlas ({type(error).__name__}: {error})"
    buffer = io.BytesIO()
    if alpha:
        Image.fromarray(canvas, mode).save(buffer, format="PNG", optimize=False)
    else:
        Image.fromarray(canvas, mode).save(buffer, format="JPEG", quality=95)
    atlas = Texture(
        data=buffer.getvalue(),
        mime="image/png" if alpha else "image/jpeg",
        width=width,
        height=height,
        name=name,
    )
    positions_of = {id(t): xy for t, xy in zip(textures, positions)}
    vertices, triangles, uvs, offset = [], [], [], 0
    for part in packed:
        assert part.texture is not None and part.uvs is not None
        x, y = positions_of[id(part.texture)]
        texture = part.texture
        uv = np.clip(part.uvs.astype(np.float64), 0.0, 1.0)
        uvs.append(
            np.column_stack(
                [(x + uv[:, 0] * texture.width) / width, (y + uv[:, 1] * texture.height) / height]
            )
        )
        vertices.append(part.positions)
        triangles.append(part.triangles + offset)
        offset += part.vertex_count
    merged = Part(
        positions=np.concatenate(vertices),
        triangles=np.concatenate(triangles),
        uvs=np.concatenate(uvs),
        texture=atlas,
        name=name,
    )
    return [p for p in parts if not packable(p)] + [merged], None
