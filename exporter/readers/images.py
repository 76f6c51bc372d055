"""Texture image files into :class:`exporter.model.Texture`, for every reader.

Only the header is decoded (size and format); the encoded bytes are kept as they are, so LOD0 can
be written without re-encoding. Everything a tile folder may hold instead of an image is told
apart: a missing or unreadable file, an XML error page served in its place (VWorld's service does
that), something that is not an image, and an image that visibly stops early.
"""

from __future__ import annotations

import io
from pathlib import Path

from PIL import Image, UnidentifiedImageError

from ..errors import error_text
from ..formats.vworld_binary import xml_error
from ..model import Texture
from ..textures import pillow_pixel_limit


class TextureFileError(Exception):
    """Why an image file cannot be used; ``str()`` is the problem phrase, e.g. ``is truncated``."""


def is_truncated(data: bytes, fmt: str | None) -> bool:
    """True when an encoded image visibly stops early (JPEG without EOI after its scan, PNG without IEND)."""
    if fmt == "JPEG":
        # 0xFFD9 cannot occur inside entropy-coded data (0xFF is byte-stuffed there).
        return not (0 <= data.find(b"\xff\xda") < data.rfind(b"\xff\xd9"))
    if fmt == "PNG":
        return b"IEND" not in data[-64:]
    return False


def read_texture_file(path: Path, name: str) -> Texture:
    """The image at ``path`` as a Texture named ``name``; raises TextureFileError saying why not."""
    try:
        data = path.read_bytes()
    except OSError as error:
        raise TextureFileError(f"cannot be read ({error.strerror or error})") from None
    code = xml_error(data) if data else "empty file"
    if code is not None:
        raise TextureFileError(f"is an XML error page ({code}), not an image")
    try:
        # Header only, so no size limit here: the texture stage applies textures.max_pixels
        # (Pillow's smaller default would refuse atlases the config accepts).
        with pillow_pixel_limit(None), Image.open(io.BytesIO(data)) as image:
            fmt, (width, height) = image.format, image.size
    except UnidentifiedImageError:
        raise TextureFileError(
            f"is not a readable image (no image format recognised in {len(data)} bytes)"
        ) from None
    except Exception as error:  # Pillow raises many types for bad headers
        raise TextureFileError(f"is not a readable image ({error_text(error)})") from None
    if is_truncated(data, fmt):
        raise TextureFileError(f"is truncated ({len(data)} bytes)")
    mime = Image.MIME.get(fmt or "", "") or "application/octet-stream"
    return Texture(data=data, mime=mime, width=width, height=height, name=name, source=str(path))
