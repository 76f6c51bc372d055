"""Atomic output: an interrupted write never leaves a truncated file under the final name."""

import os

import pytest

from exporter import atomic
from exporter.atomic import (
    remove_stale_temporaries,
    write_bytes_atomic,
    write_bytes_if_changed,
)


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


def test_leftover_temporaries_are_removed_only_inside_the_folder(tmp_path):
    """A link in OUT to a folder elsewhere is not followed: that folder's files are not OUT's."""
    out, elsewhere = tmp_path / "out", tmp_path / "elsewhere"
    (out / "tile" / "b").mkdir(parents=True)
    elsewhere.mkdir()
    mine = atomic.temporary_name(out / "tile" / "b" / "lod0.glb")
    theirs = atomic.temporary_name(elsewhere / "lod0.glb")
    mine.write_bytes(b"partial")
    theirs.write_bytes(b"someone else's")
    (out / "tile" / "b" / "kept.glb").write_bytes(b"complete")
    (out / "linked").symlink_to(elsewhere, target_is_directory=True)
    assert remove_stale_temporaries(out) == 1
    assert not mine.exists() and theirs.read_bytes() == b"someone else's"
    assert (out / "tile" / "b" / "kept.glb").is_file()


def test_a_leftover_temporary_of_this_pid_is_replaced_not_written_through(tmp_path):
    target = tmp_path / "lod0.glb"
    leftover = atomic.temporary_name(target)
    leftover.write_bytes(b"stale bytes from a killed writer that had this pid")
    assert write_bytes_atomic(target, b"new") == target
    assert target.read_bytes() == b"new"
    assert [p.name for p in tmp_path.iterdir()] == ["lod0.glb"]


def test_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path, monkeypatch):
    target = tmp_path / "lod0.glb"
    write_bytes_atomic(target, b"old")

    def disk_full(fd, data):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(atomic.os, "write", disk_full)
    with pytest.raises(OSError, match="No space"):
        write_bytes_atomic(target, b"new")
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["lod0.glb"]


def test_short_writes_are_continued(tmp_path, monkeypatch):
    real_write = atomic.os.write
    monkeypatch.setattr(atomic.os, "write", lambda fd, data: real_write(fd, bytes(data[:3])))
    data = bytes(range(256)) * 3
    write_bytes_atomic(tmp_path / "x.bin", bytearray(data))
    assert (tmp_path / "x.bin").read_bytes() == data


def test_folder_is_made_once_and_durable_writes_fsync_before_the_rename(tmp_path, monkeypatch):
    calls = []
    real_makedirs, real_fsync, real_replace = atomic.os.makedirs, atomic.os.fsync, atomic.os.replace
    monkeypatch.setattr(
        atomic.os, "makedirs", lambda *a, **k: calls.append("makedirs") or real_makedirs(*a, **k)
    )
    monkeypatch.setattr(atomic.os, "fsync", lambda fd: calls.append("fsync") or real_fsync(fd))
    monkeypatch.setattr(
        atomic.os, "replace", lambda a, b: calls.append("replace") or real_replace(a, b)
    )
    folder = tmp_path / "B1"  # missing: made by the first write only
    for level in range(3):
        write_bytes_atomic(folder / f"lod{level}.glb", b"glb")
    atomic.write_text_atomic(folder / "building.json", "{}", durable=True)
    assert calls == ["makedirs", "replace", "replace", "replace", "fsync", "replace"]
    assert sorted(p.name for p in folder.iterdir()) == [
        "building.json",
        "lod0.glb",
        "lod1.glb",
        "lod2.glb",
    ]


def test_the_path_comes_back_as_given(tmp_path):
    """A str path comes back a str (no Path made per file: the pipeline writes four a building)."""
    as_text = os.path.join(tmp_path, "a", "lod0.glb")
    assert type(write_bytes_atomic(as_text, b"glb")) is str
    assert write_bytes_atomic(tmp_path / "b.json", b"{}") == tmp_path / "b.json"
    with open(as_text, "rb") as written:
        assert written.read() == b"glb"


def test_an_unchanged_file_is_left_as_it_was_and_a_changed_one_replaced(tmp_path):
    target = tmp_path / "lod0.glb"
    assert write_bytes_if_changed(target, b"level bytes") is True  # missing: written
    os.utime(target, ns=(10**18, 10**18))
    inode = target.stat().st_ino
    assert write_bytes_if_changed(target, b"level bytes") is False
    assert target.stat().st_mtime_ns == 10**18 and target.stat().st_ino == inode
    # Same size, other bytes; then another size: both replace the file.
    assert write_bytes_if_changed(target, b"level BYTES") is True
    assert target.read_bytes() == b"level BYTES" and target.stat().st_mtime_ns != 10**18
    assert write_bytes_if_changed(target, b"longer level bytes") is True
    assert target.read_bytes() == b"longer level bytes"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["lod0.glb"]


def test_a_run_after_one_that_ended_does_not_walk_for_temporaries(tmp_path, monkeypatch):
    """The walk for temporaries (a city's OUT: thousands of folders) is done only when the last
    run did not end (killed, failed, or an OUT of a version without the marker)."""
    walked: list[str] = []
    real = atomic.remove_stale_temporaries
    monkeypatch.setattr(
        atomic,
        "remove_stale_temporaries",
        lambda folder: walked.append(str(folder)) or real(folder),
    )
    leftover = atomic.temporary_name(tmp_path / "t" / "lod0.glb")
    leftover.parent.mkdir()
    leftover.write_bytes(b"partial")
    assert atomic.start_writing(tmp_path) == 1 and walked  # no marker: walked, removed
    atomic.end_writing(tmp_path)
    walked.clear()
    assert atomic.start_writing(tmp_path) == 0 and not walked  # ended: no walk
    assert not (tmp_path / atomic.ENDED).exists()  # this run may be interrupted in turn
    leftover.write_bytes(b"partial again")  # ... and is: no end_writing
    assert atomic.start_writing(tmp_path) == 1 and walked and not leftover.exists()
