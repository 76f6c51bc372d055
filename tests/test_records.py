"""Record files (exporter/records.py): the ``files`` items' CRC-32 is zlib's, whatever computes it."""

from __future__ import annotations

import os
import zlib

from exporter.records import file_entry, files_intact


def test_file_entries_carry_zlibs_crc32():
    """Records written before the faster CRC must still match: the same CRC-32 as zlib.crc32."""
    for size in (0, 1, 7, 64, 1000, 65537, 300_001):
        data = os.urandom(size)
        assert file_entry("lod0.glb", data) == {
            "file": "lod0.glb",
            "bytes": size,
            "crc32": zlib.crc32(data),
        }


def test_files_intact_checks_size_and_crc(tmp_path):
    data = os.urandom(5000)
    (tmp_path / "lod0.glb").write_bytes(data)
    item = {"file": "lod0.glb", "bytes": len(data), "crc32": zlib.crc32(data)}
    assert files_intact(tmp_path, [item])
    (tmp_path / "lod0.glb").write_bytes(data[:-1] + bytes([data[-1] ^ 1]))  # same size, one bit
    assert not files_intact(tmp_path, [item])
