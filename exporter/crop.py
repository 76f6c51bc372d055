"""Shared atlases cut to what a building uses: each building's levels hold its own pixels only.

Data form: a building's levels as lists of :class:`~exporter.model.Part` (uvs (n, 2) float32 in
the glTF convention, 0..1, origin top-left; a :class:`~exporter.model.Texture` holds encoded
bytes). Runs between the mesh LoDs and the texture LoDs, so every level keeps one uv layout over
one (cropped) source, as :mod:`exporter.textures` and the tileset's proxies expect.

Why: real city models often texture many buildings from one atlas (Rotterdam 3D's aerial atlases:
one building of the shared sample uses parts of 12 of 14 1024² atlases, 3.9 atlases' worth of
pixels). Exported per building, every building would embed every atlas it touches whole: N times
the file bytes and, in a client, N times the texture memory, mostly pixels no face of it shows.
VWorld atlases are one per building and fully used: they are left as they are (byte for byte).

Steps (:func:`crop_to_used`, the entry point):

1. ``used_box``: the pixel box of every uv of the texture over all levels, widened by
   :data:`MARGIN_PX` (bilinear filtering and the first mip levels read that far) and aligned to
   the JPEG's MCU (8 or 16 px: a crop on MCU boundaries re-encodes nearly losslessly) or 4 px
   (PNG; the block size of GPU compression). None when a uv leaves 0..1 (a repeating texture
   needs the whole image) or when the box keeps more than :data:`MAX_KEPT` of the pixels.
2. ``cropped_texture``: JPEG re-encoded with the source's quantisation tables and chroma
   subsampling (65 dB PSNR against the source pixels on a Rotterdam atlas, against 48 dB at
   quality 90), PNG cropped losslessly; the ICC profile kept. Other formats are left whole.
3. ``moved_uvs``: uvs mapped into the box (an affine map per texture: the mesh is untouched).

Sources: JPEG (ITU-T T.81) MCU structure, and Pillow's JPEG writer options ``qtables`` and
``subsampling`` (``JpegImagePlugin.get_sampling``); glTF 2.0 texture coordinates.
"""

from __future__ import annotations

import dataclasses
import io
import math

import numpy as np
from PIL import Image, JpegImagePlugin

from .config import TextureOptions
from .errors import ReadError
from .model import Part, Texture
from .textures import open_header

MARGIN_PX = 8  # source pixels kept around the used uvs (bilinear + mip levels 1-3 of LOD0)
MAX_KEPT = 0.75  # a crop keeping more of the image than this is not worth re-encoding LOD0
UV_SLACK = 1e-4  # uvs this far outside 0..1 (float rounding at the atlas edge) still count in


def used_box(
    uvs: np.ndarray, size: tuple[int, int], align: int
) -> tuple[int, int, int, int] | None:
    """Pixel box (x0, y0, x1, y1), x1/y1 exclusive, of an image of ``size`` (width, height)
    that holds every uv of ``uvs`` (n, 2) with :data:`MARGIN_PX` around, its corners on multiples
    of ``align`` (clamped to the image); None when there is no uv, a uv leaves 0..1, or the box
    keeps more than :data:`MAX_KEPT` of the pixels."""
    if len(uvs) == 0 or not np.isfinite(uvs).all():
        return None
    low, high = uvs.min(axis=0).astype(np.float64), uvs.max(axis=0).astype(np.float64)
    if (low < -UV_SLACK).any() or (high > 1.0 + UV_SLACK).any():
        return None
    width, height = size
    x0 = max(0, (math.floor(low[0] * width) - MARGIN_PX) // align * align)
    y0 = max(0, (math.floor(low[1] * height) - MARGIN_PX) // align * align)
    x1 = min(width, -(-(math.ceil(high[0] * width) + MARGIN_PX) // align) * align)
    y1 = min(height, -(-(math.ceil(high[1] * height) + MARGIN_PX) // align) * align)
    if (x1 - x0) * (y1 - y0) > MAX_KEPT * width * height:
        return None
    return x0, y0, x1, y1


def jpeg_mcu(image: Image.Image) -> int:
    """Pixels per side of a JPEG's MCU: 16 with 4:2:0 / 4:2:2 chroma, 8 with 4:4:4 or grey."""
    sampling = JpegImagePlugin.get_sampling(image)
    return 16 if sampling in (1, 2) else 8


def cropped_texture(
    texture: Texture, box: tuple[int, int, int, int], image: Image.Image
) -> Texture:
    """``texture`` cut to ``box`` from its opened (header-only) ``image``: JPEG re-encoded with
    the source's tables and subsampling, PNG losslessly; raises ReadError for broken pixels."""
    where = texture.source or texture.name or "texture"
    try:
        image.load()
        part = image.crop(box)
    except Exception as error:  # the texture stage reports a broken image in its own words
        raise ReadError(where, f"image data is truncated or corrupt ({error})") from None
    out = io.BytesIO()
    profile = {"icc_profile": image.info["icc_profile"]} if image.info.get("icc_profile") else {}
    if image.format == "JPEG":
        part.save(
            out,
            "JPEG",
            qtables=getattr(image, "quantization", None),  # a JpegImageFile's tables
            subsampling=JpegImagePlugin.get_sampling(image),
            **profile,
        )
    else:
        part.save(out, "PNG", **profile)
    width, height = box[2] - box[0], box[3] - box[1]
    return dataclasses.replace(texture, data=out.getvalue(), width=width, height=height)


def moved_uvs(uvs: np.ndarray, size: tuple[int, int], box: tuple[int, int, int, int]) -> np.ndarray:
    """(n, 2) float32: ``uvs`` of an image of ``size`` (width, height) pixels, in ``box``'s crop."""
    width, height = size
    x0, y0, x1, y1 = box
    pixels = uvs.astype(np.float64) * [width, height]
    return ((pixels - [x0, y0]) / [x1 - x0, y1 - y0]).astype(np.float32)


def crop_box(texture: Texture, uvs: np.ndarray, options: TextureOptions):
    """(box, opened image) when ``texture`` is worth cropping to ``uvs`` (n, 2), else None."""
    if texture.mime not in ("image/jpeg", "image/png"):
        return None
    try:
        image = open_header(texture.data, texture.source or texture.name, options.max_pixels)
    except ReadError:
        return None  # the texture stage reports it
    if image.format == "JPEG" and image.mode in ("L", "RGB"):
        align = jpeg_mcu(image)
    elif image.format == "PNG":
        align = 4
    else:
        return None  # CMYK JPEGs are converted by the texture stage; other modes left whole
    box = used_box(uvs, image.size, align)
    return (box, image) if box is not None else None


def crop_to_used(parts_by_level: list[list[Part]], options: TextureOptions) -> list[list[Part]]:
    """Every level's parts with each partly used JPEG/PNG texture cut to what the building's uvs
    use over all levels and all parts showing it (see the module doc; parts whose textures have
    the same bytes show one image: a VWorld building's walls and roof share its atlas); parts of
    other textures are returned as they are."""
    uvs_of: dict[bytes, list[np.ndarray]] = {}
    textures: dict[bytes, Texture] = {}
    for parts in parts_by_level:
        for part in parts:
            if part.texture is not None and part.uvs is not None and part.triangle_count:
                used = np.unique(part.triangles.ravel())
                uvs_of.setdefault(part.texture.data, []).append(part.uvs[used])
                textures.setdefault(part.texture.data, part.texture)
    crops: dict[bytes, tuple[Texture, tuple[int, int, int, int], tuple[int, int]]] = {}
    for key, texture in textures.items():
        found = crop_box(texture, np.concatenate(uvs_of[key]), options)
        if found is None:
            continue
        box, image = found
        try:
            crops[key] = (cropped_texture(texture, box, image), box, image.size)
        except ReadError:
            continue  # left whole: the texture stage reports the broken image
    if not crops:
        return parts_by_level
    out = []
    for parts in parts_by_level:
        level = []
        for part in parts:
            crop = crops.get(part.texture.data) if part.texture is not None else None
            if crop is None or part.uvs is None:
                level.append(part)
                continue
            texture, box, size = crop
            level.append(
                dataclasses.replace(part, texture=texture, uvs=moved_uvs(part.uvs, size, box))
            )
        out.append(level)
    return out
