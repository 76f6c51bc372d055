"""Atomic output: an interrupted write never leaves a truncated file under the final name."""

import pytest

from exporter import atomic
from exporter.atomic import remove_stale_temporaries, write_bytes_atomic


def test_write_creates_folders_and_replaces_content(tmp_path):
    target = tmp_path / "a" / "b" / "lod0.glb"
    write_bytes_atomic(target, b"first")
    write_bytes_atomic(target, b"second")
    assert target.read_bytes() == b"second"
    assert [p.name for p in target.parent.iterdir()] == ["lod0.glb"]


def test_interrupted_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "lod_manifest.json"
    write_bytes_atomic(target, b'{"complete": true}')

    def interrupted(*args):
        raise KeyboardInterrupt  # as if Ctrl-C arrived between writing and renaming

    monkeypatch.setattr(atomic.os, "replace", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_bytes_atomic(target, b'{"half')
    assert target.read_bytes() == b'{"complete": true}'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lod_manifest.json"]


def test_a_killed_writer_leaves_only_a_hidden_temporary_that_the_next_run_removes(tmp_path):
    # A SIGKILL cannot run cleanup: simulate what it leaves (the temporary), then clean it.
    target = tmp_path / "t" / "lod1.glb"
    leftover = atomic.temporary_name(target)
    leftover.parent.mkdir(parents=True)
    leftover.write_bytes(b"partial")
    assert not target.exists()
    assert remove_stale_temporaries(tmp_path) == 1
    assert list((tmp_path / "t").iterdir()) == []
