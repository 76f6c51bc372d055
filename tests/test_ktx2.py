"""KTX2 output (``textures.ktx2``, exporter/ktx2.py and the writer's KHR_texture_basisu): off by
default with the output as before, refused before any work when the optional encoder is missing,
and, with the encoder (``pip install 'vworld-lod[ktx2]'``), valid glTF that keeps the JPEG/PNG
(LOD0's source bytes) as the fallback."""

from __future__ import annotations

import importlib.util
import io
import json
import struct

import pytest
from PIL import Image

from exporter import cli
from exporter import config as config_module
from exporter.config import Config, config_from_dict, default_config_yaml
from exporter.errors import ConfigError
from exporter.gltf_writer import glb_bytes
from exporter.model import Part, Texture

needs_encoder = pytest.mark.skipif(
    importlib.util.find_spec("alktx2") is None,
    reason="the KTX2 encoder alktx2 is not installed: pip install 'vworld-lod[ktx2]' (CPython 3.11-3.13, Linux x86-64 / Windows x64)",
)
TEXTURE_KEYS = [
    "jpeg_quality",
    "min_size",
    "fast_jpeg_downscale",
    "crop_to_used",  # 0.6.0 (on by default: a key of the manifest's config since)
    "opaque_png_to_jpeg",
    "max_pixels",
]


def gltf_json(data: bytes) -> dict:
    (length,) = struct.unpack_from("<I", data, 12)
    return json.loads(data[20 : 20 + length])


def image_bytes(data: bytes, document: dict, index: int) -> bytes:
    (json_length,) = struct.unpack_from("<I", data, 12)
    view = document["bufferViews"][document["images"][index]["bufferView"]]
    start = 20 + json_length + 8 + view.get("byteOffset", 0)
    return data[start : start + view["byteLength"]]


def wall(size: tuple[int, int] = (64, 32)) -> Part:
    """A wall facing East (local East/Up/North), wound outward, with a JPEG of ``size`` pixels."""
    buffer = io.BytesIO()
    Image.radial_gradient("L").resize(size).convert("RGB").save(buffer, "JPEG", quality=90)
    texture = Texture(buffer.getvalue(), "image/jpeg", size[0], size[1], "facade.jpg")
    return Part(
        positions=[[2, 0, -1], [2, 0, 1], [2, 3, 1], [2, 3, -1]],
        triangles=[[0, 2, 1], [0, 3, 2]],
        uvs=[[0, 1], [1, 1], [1, 0], [0, 0]],
        texture=texture,
    )


def test_ktx2_is_off_by_default_and_leaves_the_config_in_the_manifest_as_before():
    assert Config().textures.ktx2 is False
    # The manifest's config and the reuse hash (exporter.pipeline.config_fingerprint) are built
    # from to_dict: without the opt-in key they are what 0.6 wrote.
    assert list(Config().to_dict()["textures"]) == TEXTURE_KEYS
    on = (
        config_from_dict({"textures": {"ktx2": True}})
        if config_module.ktx2_encoder_installed()
        else None
    )
    if on is not None:
        assert on.to_dict()["textures"]["ktx2"] is True
    assert "ktx2: false" in default_config_yaml()


def test_default_glb_has_no_ktx2():
    data = glb_bytes([wall()], "B1_LOD0")
    document = gltf_json(data)
    assert "extensionsUsed" not in document and "extensions" not in document["textures"][0]
    assert [image["mimeType"] for image in document["images"]] == ["image/jpeg"]


def test_missing_encoder_is_refused_before_any_work_with_the_install_command(
    monkeypatch, tmp_path, capsys
):
    monkeypatch.setattr(config_module, "ktx2_encoder_installed", lambda: False)
    with pytest.raises(ConfigError) as error:
        config_from_dict({"textures": {"ktx2": True}}, "my.yaml")
    assert error.value.key == "textures.ktx2"
    assert "pip install 'vworld-lod[ktx2]'" in str(error.value)
    config_from_dict({"textures": {"ktx2": False}}, "my.yaml")  # off: no encoder needed

    # The command line: exit 2, one line naming the file, the key and the install command, and
    # nothing written.
    from exporter.samplegen import generate_tile

    tile = generate_tile(tmp_path / "in" / "15_279418_116113", 1, atlas_size=16)
    path = tmp_path / "ktx2.yaml"
    path.write_text("textures:\n  ktx2: true\n", encoding="utf-8")
    out = tmp_path / "out"
    code = cli.main(["export", str(tile), "--out", str(out), "--config", str(path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert (
        str(path) in err[0]
        and "textures.ktx2" in err[0]
        and "pip install 'vworld-lod[ktx2]'" in err[0]
    )
    assert not out.exists()

    # A Config made in code is checked too, before the folders are scanned.
    from exporter.pipeline import export_tiles

    config = Config()
    config.textures.ktx2 = True
    with pytest.raises(ConfigError, match=r"pip install 'vworld-lod\[ktx2\]'"):
        export_tiles([tile], out, config, jobs=1)
    assert not out.exists()


@needs_encoder
def test_ktx2_glb_keeps_the_jpeg_as_fallback_and_is_valid_gltf(gltf_validator, tmp_path):
    import alktx2

    from exporter.ktx2 import ktx2_bytes

    parts = [wall(), wall((30, 18))]  # the second's sides are not multiples of 4: JPEG alone
    data = glb_bytes(parts, "B1_LOD0", ktx2_bytes)
    assert data == glb_bytes(parts, "B1_LOD0", ktx2_bytes), "two runs give the same bytes"
    document = gltf_json(data)
    assert document["extensionsUsed"] == ["KHR_texture_basisu"]
    assert "extensionsRequired" not in document
    with_ktx2, jpeg_only = document["textures"]
    assert image_bytes(data, document, with_ktx2["source"]) == parts[0].texture.data
    ktx2_index = with_ktx2["extensions"]["KHR_texture_basisu"]["source"]
    assert document["images"][ktx2_index]["mimeType"] == "image/ktx2"
    info = alktx2.inspect_ktx2(image_bytes(data, document, ktx2_index))
    assert (info["width"], info["height"], info["is_etc1s"], info["is_srgb"]) == (
        64,
        32,
        True,
        True,
    )
    assert info["levels"] == 7  # 64x32 .. 1x1
    assert "extensions" not in jpeg_only
    assert image_bytes(data, document, jpeg_only["source"]) == parts[1].texture.data
    path = tmp_path / "ktx2.glb"
    path.write_bytes(data)
    report = gltf_validator([path])[0]
    assert report["errors"] == 0, report["messages"]


@needs_encoder
def test_export_with_ktx2_keeps_lod0_source_bytes(gltf_validator, tmp_path):
    from exporter.pipeline import export_tiles
    from exporter.samplegen import generate_tile

    folder = generate_tile(tmp_path / "in" / "15_279418_116113", 2, seed=2, atlas_size=64)
    config = config_from_dict({"textures": {"ktx2": True}})
    out = tmp_path / "out"
    export_tiles([folder], out, config, jobs=1)
    (manifest,) = out.glob("*/lod_manifest.json")
    data = json.loads(manifest.read_text(encoding="utf-8"))
    assert data["config"]["textures"]["ktx2"] is True
    glbs = sorted(manifest.parent.glob("*/lod*.glb"))
    sources = {p.read_bytes() for p in folder.glob("*.jpg")}
    for path in glbs:
        blob = path.read_bytes()
        document = gltf_json(blob)
        assert document["extensionsUsed"] == ["KHR_texture_basisu"], path
        for texture in document["textures"]:
            assert "KHR_texture_basisu" in texture["extensions"], path
            if path.name == "lod0.glb":
                assert image_bytes(blob, document, texture["source"]) in sources, path
    reports = gltf_validator(glbs)
    assert all(r["errors"] == 0 for r in reports), [r["messages"] for r in reports if r["errors"]]


def test_encoder_gone_mid_run_fails_the_building_naming_the_install_command(monkeypatch):
    """A worker (e.g. on Dask) without the encoder: ProcessError, which the job reports as that
    building's failure; an image whose sides are not multiples of 4 never needs the encoder."""
    import sys

    from exporter.errors import ProcessError
    from exporter.ktx2 import ktx2_bytes

    monkeypatch.setitem(sys.modules, "alktx2", None)  # import alktx2 raises ImportError
    assert ktx2_bytes(wall((30, 18)).texture) is None
    with pytest.raises(ProcessError, match=r"pip install 'vworld-lod\[ktx2\]'"):
        ktx2_bytes(wall().texture)
