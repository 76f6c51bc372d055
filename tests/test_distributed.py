"""The export on a Dask cluster (``--scheduler``): a real scheduler and worker processes on
loopback; output compared byte for byte with the local pool's; a worker killed mid-run; the
one-line errors for a cluster that cannot run the work."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from dask_cluster import REPO, DaskCluster

from exporter import distributed as dist
from exporter.cli import main
from exporter.config import Config
from exporter.distributed import ClusterError, ClusterOptions
from exporter.model import TileId
from exporter.pipeline import RECORD_NAME, export_tiles

TILES = [TileId(15, 279418, 116113), TileId(15, 279419, 116113), TileId(15, 279418, 116114)]


def make_tiles(root: Path, count: int = 5) -> list[Path]:
    from exporter.samplegen import generate_tile

    return [
        generate_tile(
            root / tile.name, count=count, seed=11 + i, tile=tile, atlas_size=64, mean_triangles=80
        )
        for i, tile in enumerate(TILES)
    ]


def output_bytes(out: Path) -> dict[str, bytes]:
    """Every file of an export by relative path (building records included: they hold no
    run-specific values, issue 26)."""
    return {
        str(path.relative_to(out)): path.read_bytes()
        for path in sorted(out.rglob("*"))
        if path.is_file()
    }


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    with DaskCluster(tmp_path_factory.mktemp("dask"), workers=2) as running:
        yield running


@pytest.fixture(scope="module")
def tiles(tmp_path_factory) -> list[Path]:
    """Three tiles of five buildings; two of the first tile's are broken (listed as skipped,
    in the same order whichever worker finds them)."""
    made = make_tiles(tmp_path_factory.mktemp("input"))
    for name in ("B0001.xdo", "B0003.xdo"):
        path = made[0] / name
        path.write_bytes(path.read_bytes()[:40])
    return made


@pytest.fixture(scope="module")
def local_reference(tiles, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("reference") / "out"
    export_tiles(tiles, out, Config(), jobs=1)
    return out


def test_a_cluster_export_equals_the_local_one_byte_for_byte_and_reruns_skip_everything(
    cluster, tiles, local_reference, tmp_path, monkeypatch
):
    # Relative paths, as a user types them: workers resolve them from the client's folder.
    monkeypatch.chdir(tiles[0].parent)
    relative = [tile.name for tile in tiles]
    out = tmp_path / "out"
    options = ClusterOptions(cluster.address, batch_size=2)
    stats = export_tiles(relative, out, Config(), scheduler=options)
    assert (stats.buildings, stats.skipped, stats.reused) == (13, 2, 0)
    local = tmp_path / "local"
    export_tiles(relative, local, Config(), jobs=1)
    assert output_bytes(out) == output_bytes(local)
    # The tileset and its proxies too (built in this process from the files on disk).
    assert {"tileset.json", f"tileset_proxies/{TILES[0].name}.glb"} <= set(output_bytes(out))
    for tile in TILES:
        manifest = json.loads((out / tile.name / "lod_manifest.json").read_text())
        assert len(manifest["buildings"]) + len(manifest["skipped"]) == 5
        assert all(not Path(b["source"]).is_absolute() for b in manifest["buildings"])

    before = {path: path.stat().st_mtime_ns for path in out.rglob("*.glb")}
    again = export_tiles(relative, out, Config(), scheduler=options)
    assert again.reused == again.buildings == 13, "an unchanged re-run redoes nothing"
    assert {path: path.stat().st_mtime_ns for path in out.rglob("*.glb")} == before
    assert output_bytes(out) == output_bytes(local)


def test_the_command_line_runs_on_the_cluster_and_prints_the_dashboard(
    cluster, tiles, local_reference, tmp_path, capsys
):
    out = tmp_path / "out"
    code = main(["export", *map(str, tiles), "--out", str(out), "--scheduler", cluster.address])
    err = capsys.readouterr().err
    assert code == 0, err
    assert "dask dashboard: http://127.0.0.1:" in err
    assert "15/15 buildings" in err
    assert output_bytes(out) == output_bytes(local_reference)


def test_a_single_file_input_runs_on_the_cluster_as_locally(cluster, tiles, tmp_path, monkeypatch):
    monkeypatch.chdir(tiles[1])
    dat = Path(f"{TILES[1].name}.dat")  # a VWorld index file given alone, in the current folder
    local, out = tmp_path / "local", tmp_path / "out"
    export_tiles([dat], local, Config(), jobs=1)
    export_tiles([dat], out, Config(), scheduler=cluster.address)
    assert output_bytes(out) == output_bytes(local)
    assert len(list(out.glob("15_*/*/*.glb"))) == 15  # the buildings (the tile proxy aside)


@pytest.mark.slow
def test_a_worker_killed_mid_run_costs_only_its_tasks(tmp_path, tiles, local_reference):
    out = tmp_path / "out"
    with DaskCluster(tmp_path / "dask", workers=2) as cluster:
        command = [
            sys.executable,
            "-m",
            "exporter",
            "export",
            *map(str, tiles),
            "--out",
            str(out),
            "--scheduler",
            cluster.address,
            "--quiet",
        ]
        env = {**os.environ, "PYTHONPATH": str(REPO)}
        process = subprocess.Popen(command, env=env, stderr=subprocess.PIPE, text=True)
        try:
            deadline = time.monotonic() + 60
            while len(list(out.glob(f"*/*/{RECORD_NAME}"))) < 4 and time.monotonic() < deadline:
                time.sleep(0.02)
            assert process.poll() is None, "the run ended before the kill: nothing tested"
            cluster.kill_worker(0)  # mid-run: its batch in flight is lost
            _, err = process.communicate(timeout=120)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
        # The survivor takes the lost batch over: the run finishes.
        assert process.returncode == 0, err
        assert "Traceback" not in err
        done = output_bytes(out)
        # Whatever the killed worker was writing is at most a hidden temporary; a re-run (on the
        # worker left) removes it and equals the local export.
        export_tiles(tiles, out, Config(), scheduler=cluster.address)
    assert output_bytes(out) == output_bytes(local_reference)
    name = lambda k: k.split("/")[-1]
    # Hidden temporaries (.<name>.<pid>.tmp) left out; a tile's hidden summary is output.
    finished = {
        k: v for k, v in done.items() if not (name(k).startswith(".") and k.endswith(".tmp"))
    }
    assert finished == output_bytes(local_reference)


@pytest.mark.slow
def test_a_lost_scheduler_is_a_one_line_error_and_a_restarted_one_finishes_the_job(
    tmp_path, tiles, local_reference, cluster
):
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    with DaskCluster(tmp_path / "dask", workers=2) as doomed:
        command = [sys.executable, "-m", "exporter", "export", *map(str, tiles), "--out", str(out)]
        process = subprocess.Popen(
            [*command, "--scheduler", doomed.address], env=env, stderr=subprocess.PIPE, text=True
        )
        try:
            deadline = time.monotonic() + 60
            while len(list(out.glob(f"*/*/{RECORD_NAME}"))) < 3 and time.monotonic() < deadline:
                time.sleep(0.02)
            assert process.poll() is None, "the run ended before the scheduler was lost"
            os.killpg(doomed.processes[0].pid, signal.SIGKILL)  # the scheduler
            _, err = process.communicate(timeout=60)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
    assert process.returncode == 2, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("vworld-lod: lost the Dask scheduler") and "re-run to resume" in last
    assert "Traceback" not in err
    assert not any(out.glob("*/lod_manifest.json")), "no manifest before all its buildings"
    stats = export_tiles(tiles, out, Config(), scheduler=cluster.address)  # another scheduler
    assert stats.reused >= 3, "what was finished before the loss is kept"
    assert output_bytes(out) == output_bytes(local_reference)


@pytest.mark.slow
def test_a_cluster_left_without_workers_stops_after_a_bounded_wait(tmp_path):
    import threading

    tiles = make_tiles(tmp_path / "in", count=12)  # 36 buildings: still running at the kill
    out = tmp_path / "out"
    with DaskCluster(tmp_path / "dask", workers=1) as cluster:

        def kill_when_started() -> None:
            deadline = time.monotonic() + 60
            while not any(out.glob(f"*/*/{RECORD_NAME}")) and time.monotonic() < deadline:
                time.sleep(0.02)
            cluster.kill_worker(0)

        killer = threading.Thread(target=kill_when_started)
        killer.start()
        started = time.monotonic()
        try:
            with pytest.raises(ClusterError, match="every worker of .* left mid-run"):
                export_tiles(
                    tiles, out, Config(), scheduler=ClusterOptions(cluster.address, worker_wait_s=1)
                )
        finally:
            killer.join()
        assert time.monotonic() - started < 30, "a bounded wait, never a hang"
    assert not any(out.glob("*/lod_manifest.json"))


@pytest.mark.slow
def test_ctrl_c_on_a_local_cluster_exits_130_quietly_and_a_rerun_resumes(tmp_path, cluster):
    tiles = make_tiles(tmp_path / "in", count=12)  # 36 buildings: still running at the signal
    reference = tmp_path / "reference"
    export_tiles(tiles, reference, Config(), jobs=1)
    out = tmp_path / "out"
    command = [
        sys.executable,
        "-c",
        "import signal, sys; signal.signal(signal.SIGINT, signal.default_int_handler); "
        "from exporter.cli import main; sys.exit(main(sys.argv[1:]))",
        "export",
        *map(str, tiles),
        "--out",
        str(out),
        "--scheduler",
        "local",
        "--jobs",
        "2",
        "--quiet",
    ]
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    # A session of its own: the signal goes to the whole process group, as a terminal's Ctrl-C.
    process = subprocess.Popen(
        command, env=env, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        deadline = time.monotonic() + 60
        while len(list(out.glob(f"*/*/{RECORD_NAME}"))) < 2 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert process.poll() is None, "the run ended before the signal: nothing tested"
        os.killpg(process.pid, signal.SIGINT)
        _, err = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
    assert process.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err and "KeyboardInterrupt" not in err
    assert not any(out.glob("*/lod_manifest.json")), "no manifest for an unfinished tile"
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:  # the local cluster's processes went with the client
        try:
            os.killpg(process.pid, 0)
        except ProcessLookupError:
            break
        time.sleep(0.1)
    else:
        raise AssertionError("processes of the local cluster outlived the interrupted run")
    export_tiles(tiles, out, Config(), scheduler=cluster.address)
    assert output_bytes(out) == output_bytes(reference)


# --------------------------------------------------------------------------- bad input


def test_an_unreachable_scheduler_is_a_one_line_error_with_exit_2(tmp_path, capsys, monkeypatch):
    import socket

    with socket.socket() as free:  # a port nobody listens on
        free.bind(("127.0.0.1", 0))
        port = free.getsockname()[1]
    monkeypatch.setattr(dist, "CONNECT_TIMEOUT_S", 1.0)
    tile = make_tiles(tmp_path, count=1)[0]
    started = time.monotonic()
    code = main(
        [
            "export",
            str(tile),
            "--out",
            str(tmp_path / "out"),
            "--scheduler",
            f"tcp://127.0.0.1:{port}",
        ]
    )
    err = capsys.readouterr().err
    assert code == 2
    assert time.monotonic() - started < 20
    lines = err.strip().splitlines()
    assert len(lines) == 1 and f"cannot reach the Dask scheduler tcp://127.0.0.1:{port}" in lines[0]
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").rglob("*.glb"))


def test_a_scheduler_without_workers_is_an_error_after_a_bounded_wait(tmp_path):
    tile = make_tiles(tmp_path, count=1)[0]
    with DaskCluster(tmp_path / "dask", workers=0) as cluster:
        started = time.monotonic()
        with pytest.raises(ClusterError, match="has no workers \\(waited 1 s\\)"):
            export_tiles(
                [tile],
                tmp_path / "out",
                Config(),
                scheduler=ClusterOptions(cluster.address, worker_wait_s=1),
            )
        assert time.monotonic() - started < 15
    assert not any((tmp_path / "out").rglob("*.glb"))


def test_a_worker_running_other_code_is_refused_with_the_versions_named(tmp_path):
    import shutil

    other = tmp_path / "other"
    shutil.copytree(
        REPO / "exporter", other / "exporter", ignore=shutil.ignore_patterns("__pycache__")
    )
    with open(other / "exporter" / "pipeline.py", "a") as handle:
        handle.write("\n# an edit the client does not have\n")
    tile = make_tiles(tmp_path, count=1)[0]
    with DaskCluster(tmp_path / "dask", workers=0) as cluster:
        cluster.start_worker(env={**cluster.env, "PYTHONPATH": str(other)})
        cluster.wait_for_workers(1)
        with pytest.raises(ClusterError) as caught:
            export_tiles([tile], tmp_path / "out", Config(), scheduler=cluster.address)
    message = str(caught.value)
    assert "other versions" in message and "vworld-lod code" in message
    assert dist.code_hash() in message  # the client's, beside the worker's
    assert "\n" not in message
    assert not any((tmp_path / "out").rglob("*.glb"))


def test_version_mismatches_name_the_machine_the_package_and_both_versions():
    mine = {"python": "3.11.7", "numpy": "2.1.0", "vworld-lod": "0.2.0"}
    theirs = {
        "worker tcp://a:1": {"python": "3.11.7", "numpy": "1.26.4", "vworld-lod": "0.2.0"},
        "worker tcp://b:1": dict(mine),
        "scheduler": {"dask": "2026.8.0"},
    }
    assert dist.version_mismatches(mine, theirs) == [
        "worker tcp://a:1: numpy 1.26.4 (client 2.1.0)"
    ]


def test_the_storage_probe_names_what_a_worker_cannot_see_or_write(tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "a.dat").write_bytes(b"")
    out = tmp_path / "out"
    out.mkdir()
    cwd = os.getcwd()
    listing = dist.listing_digest(str(folder))
    assert dist.probe_storage({str(folder): listing}, str(out), "t", cwd) is None
    assert len(list(out.glob(".probe-t-*.tmp"))) == 1
    missing = str(tmp_path / "gone")
    assert dist.probe_storage({missing: listing}, str(out), "t", cwd) == (
        f"cannot read the input {missing}"
    )
    (folder / "b.dat").write_bytes(b"")  # the worker sees other files than the client
    assert f"sees another {folder} than the client" in dist.probe_storage(
        {str(folder): listing}, str(out), "t", cwd
    )
    nowhere = str(tmp_path / "no" / "such" / "out")
    assert dist.probe_storage(
        {str(folder): dist.listing_digest(str(folder))}, nowhere, "t", cwd
    ).startswith(f"cannot write into the output folder {nowhere}")


def test_a_batch_on_a_worker_that_lost_the_shared_folder_fails_naming_it(tmp_path, tiles):
    from exporter.readers import scan_folder

    entry = scan_folder(tiles[0], Config().readers).entries[0]
    gone = str(tmp_path / "unmounted" / "out")
    with pytest.raises(dist.StorageLost, match=f"cannot see {gone}"):
        dist.process_batch([(entry, Config(), gone, "digest", ())], os.getcwd())
    assert not (tmp_path / "unmounted").exists(), "nothing written where the mount was"


def test_without_dask_the_option_is_a_one_line_error(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)  # import fails as if not installed
    tile = make_tiles(tmp_path, count=1)[0]
    code = main(["export", str(tile), "--out", str(tmp_path / "out"), "--scheduler", "local"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.strip() == f"vworld-lod: {dist.DASK_MISSING}"


def test_batches_shrink_so_every_worker_gets_several():
    assert dist.batch_size_for(10_000, 8, 16) == 16
    assert dist.batch_size_for(15, 2, 16) == 2
    assert dist.batch_size_for(1, 4, 16) == 1
