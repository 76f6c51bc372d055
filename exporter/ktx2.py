"""KTX2 (Basis Universal) copies of texture atlases, for ``textures.ktx2`` (opt-in).

Input: a :class:`~exporter.model.Texture` (encoded JPEG/PNG bytes, pixels). Output: the bytes of a
KTX2 file holding it as Basis Universal ETC1S (``quality`` :data:`ETC1S_QUALITY` of 1..255), sRGB,
with its full mip chain, top-left origin as glTF images have (no flip), or None when its sides are
not multiples of 4 (``KHR_texture_basisu`` requires them; the JPEG/PNG then stays alone). The
writer (``exporter/gltf_writer.py``) embeds it through ``KHR_texture_basisu`` beside the JPEG/PNG.
Clients transcode ETC1S at load time to the GPU's format (BC1/BC3/BC7 desktop, ETC/ASTC mobile):
glTFast with ``com.unity.cloud.ktx``, CesiumJS, three.js.

Why ETC1S and this encoder (``benchmarks/bench_ktx2.py``, docs/textures.md "KTX2"): ETC1S files
are ~1.5x the JPEG's bytes at ~36 dB PSNR against the JPEG (UASTC: ~8x the bytes). The encoder is
``alktx2`` (PyPI; Basis Universal compiled in): wheels for CPython 3.11-3.13 on Linux x86-64 and
Windows x64 only (no macOS, no ARM, no 3.10, no sdist), ~4.6 s of CPU per 1024² atlas; so it is
an optional extra, ``pip install 'vworld-lod[ktx2]'``, and the config check refuses
``textures.ktx2: true`` without it before any work (exporter/config.py). Khronos's own binding,
``pyktx``, is an sdist that needs libktx installed and does not build without it.

Deterministic: the same atlas gives the same bytes (one encoder thread; checked in
tests/test_ktx2.py). Sources: KHR_texture_basisu (Khronos glTF extension registry); KTX 2.0
specification; Basis Universal (ETC1S, quality levels, mipmaps).
"""

from __future__ import annotations

import io

from PIL import Image

from .config import KTX2_INSTALL
from .errors import ProcessError
from .model import Texture

ETC1S_QUALITY = 128  # basisu's -q (1..255): its default; ~36 dB against the JPEG level


def ktx2_bytes(texture: Texture) -> bytes | None:
    """The KTX2 (ETC1S, sRGB, mipmaps) of ``texture``, or None when a side is not a multiple of 4."""
    with Image.open(io.BytesIO(texture.data)) as image:  # the header's size, not the declared one
        width, height = image.size
    if width % 4 or height % 4:
        return None
    try:
        import alktx2
    except ImportError:  # the config check makes this rare (an encoder removed mid-run)
        raise ProcessError(
            f"textures.ktx2: the KTX2 encoder is not installed: {KTX2_INSTALL}"
        ) from None
    try:
        return bytes(
            alktx2.encode_bytes_to_ktx2(
                bytes(texture.data),
                mime=texture.mime,
                codec="etc1s",
                quality=ETC1S_QUALITY,
                srgb=True,
                mipmaps=True,
                threads=1,
            )
        )
    except Exception as error:  # the encoder's own errors (a texture it cannot decode)
        raise ProcessError(f"texture {texture.name!r}: KTX2 encoding failed: {error}") from None
