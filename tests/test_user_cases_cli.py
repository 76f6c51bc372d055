"""What a new user ran into on 0.4.3 (issue 36), the command line's and the pipeline's half: each
case ends with exit 0 and a correct result, or exit 2 and one line naming the path (or option)
and the problem. The readers' half is in ``tests/test_user_cases.py``."""

from __future__ import annotations

import inspect
import json
import os
import shutil
import socket
import stat
import struct
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from exporter.cli import main, usable_cores
from tests.test_user_cases import (
    REPO,
    city_file,
    export,
    one_line,
    results,
    run,
    tree_bytes,
    vworld_tile,
)
from tests.tileset_check import load

ENV = {**os.environ, "PYTHONPATH": str(REPO)}


def shifted(boxes: int):
    """A ``city_file`` edit moving every vertex ``boxes`` building spacings (30 m) east: boxes 1 to
    3 of ``tests.test_user_cases`` all lie in level-15 tile 15_170611_124655."""

    def edit(vertices: list[list[float]]) -> None:
        for vertex in vertices:
            vertex[0] += 30.0 * boxes

    return edit


def not_finite(vertices: list[list[float]]) -> None:
    """A ``city_file`` edit moving two buildings to boxes 1 and 2, the second with a corner that
    is not finite."""
    shifted(1)(vertices)
    vertices[8 + 3][1] = float("nan")


# --------------------------------------------------------------------------- the cases


def case_01_a_second_dataset_into_the_same_out_keeps_the_first(tmp: Path, capsys) -> None:
    first = city_file(tmp / "east" / "a.city.json", ["A1", "A2"], edit=shifted(1))
    second = city_file(tmp / "west" / "b.city.json", ["B1"], edit=shifted(3))
    out = tmp / "o"
    assert run(export(first, "--out", out), capsys)[0] == 0
    assert run(export(second, "--out", out), capsys)[0] == 0
    manifests = list(out.rglob("lod_manifest.json"))
    assert len(manifests) == 1, "both inputs land in one level-15 tile"
    buildings, _ = results(out)
    assert set(buildings) == {"A1", "A2", "B1"}, "the first run's buildings are kept"
    for building in buildings.values():
        assert (manifests[0].parent / building["folder"] / "lod0.glb").is_file()
    tileset = json.dumps(load(out))  # the tile's own tileset resolved
    assert all(f"{name}/lod0.glb" in tileset for name in ("A1", "A2", "B1"))
    # The first run's skipped buildings stay listed, once, however often the second one runs.
    bad = city_file(tmp / "east" / "bad.city.json", ["C1", "BAD"], edit=not_finite)
    assert run(export(bad, "--out", out), capsys)[0] == 0
    for _ in range(2):
        assert run(export(second, "--out", out), capsys)[0] == 0
        (manifest,) = [json.loads(p.read_text()) for p in out.rglob("lod_manifest.json")]
        assert [s["id"] for s in manifest["skipped"]] == ["BAD"]
        assert {b["id"] for b in manifest["buildings"]} == {"A1", "A2", "B1", "C1"}
    bad.unlink()
    assert run(export(tmp / "east", "--out", out), capsys)[0] == 0  # its folder: BAD is gone
    (manifest,) = [json.loads(p.read_text()) for p in out.rglob("lod_manifest.json")]
    assert manifest["skipped"] == [] and "C1" not in {b["id"] for b in manifest["buildings"]}
    # A re-run of the second input changes nothing; of the first, with a building gone from it,
    # removes that building only (this run's own input), keeping the second input's.
    before = tree_bytes(out)
    assert run(export(second, "--out", out), capsys)[0] == 0
    assert tree_bytes(out) == before
    city_file(first, ["A1"], edit=shifted(1))
    assert run(export(first, "--out", out), capsys)[0] == 0
    assert set(results(out)[0]) == {"A1", "B1"}
    assert not list(out.glob("*/A2"))
    # Both into a fresh OUT in one run: the same tile as the two runs.
    together = tmp / "together"
    assert run(export(first, second, "--out", together), capsys)[0] == 0
    assert tree_bytes(together) == tree_bytes(out)


def case_02_another_inputs_building_of_the_same_name_is_replaced_and_said(
    tmp: Path, capsys
) -> None:
    first = city_file(tmp / "east" / "a.city.json", ["A", "S"], edit=shifted(1))
    second = city_file(tmp / "west" / "b.city.json", ["S"], edit=shifted(3))
    out = tmp / "o"
    assert run(export(first, "--out", out), capsys)[0] == 0
    code, err = run(export(second, "--out", out), capsys)  # said even with --quiet
    assert code == 0, err
    line = one_line(err, "replaced")
    assert "S" in line and "a.city.json" in line and "b.city.json" in line
    buildings, _ = results(out)
    assert set(buildings) == {"A", "S"} and "b.city.json" in buildings["S"]["source"]


def case_03_a_symlinked_building_folder_in_out_is_not_written_through(tmp: Path, capsys) -> None:
    source = city_file(tmp / "a.city.json", ["A", "B"], edit=shifted(1))
    out = tmp / "o"
    assert run(export(source, "--out", out), capsys)[0] == 0
    folder = next(out.glob("*/A"))
    elsewhere = tmp / "elsewhere"
    folder.rename(elsewhere)
    (elsewhere / "lod7.glb").write_bytes(b"not the exporter's")
    folder.symlink_to(elsewhere, target_is_directory=True)
    kept = tree_bytes(elsewhere)
    for options in ([], ["--force"]):  # reused (unchanged input) or redone
        assert run(export(source, "--out", out, *options), capsys)[0] == 0
        assert tree_bytes(elsewhere) == kept, "the link's target is left as it was"
        assert not folder.is_symlink() and (folder / "lod0.glb").is_file()
        assert set(results(out)[0]) == {"A", "B"}
        shutil.rmtree(folder)
        folder.symlink_to(elsewhere, target_is_directory=True)


def case_04_a_deeply_nested_config(tmp: Path, capsys) -> None:
    config = tmp / "deep.yaml"
    config.write_text("simplify: " + "[" * 5000 + "]" * 5000 + "\n")
    code, err = run(
        ["inspect", str(city_file(tmp / "a.city.json", ["A"])), "--config", str(config)], capsys
    )
    assert code == 2
    one_line(err, "deep.yaml", "nested too deeply")


def alias_bomb(key: str) -> str:
    """A YAML config of about 350 bytes whose value at ``key`` is 9 aliased levels of 9-item
    lists (9^9 strings when expanded: "billion laughs")."""
    levels = ['&a ["lol","lol","lol","lol","lol","lol","lol","lol","lol"]']
    for name, below in zip("bcdefghi", "abcdefgh"):
        levels.append(f"&{name} [" + ",".join([f"*{below}"] * 9) + "]")
    return f"{key}: {{protect_largest: [{', '.join(levels)}]}}\n"


def case_05_a_yaml_alias_bomb_is_refused_fast(tmp: Path, capsys) -> None:
    config = tmp / "bomb.yaml"
    config.write_text(alias_bomb("simplify"))
    assert len(config.read_bytes()) < 400
    source = city_file(tmp / "a.city.json", ["A"])
    # In a child process with a time limit: the bomb took minutes of CPU before it was refused.
    command = [sys.executable, "-m", "exporter", "inspect", str(source), "--config", str(config)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=60, env=ENV, cwd=REPO)
    assert done.returncode == 2
    line = one_line(done.stderr, "bomb.yaml", "simplify.protect_largest")
    assert len(line) < 400, "the value is quoted bounded"


def case_06_init_config_force_onto_a_link_or_a_pipe(tmp: Path, capsys) -> None:
    # (A pipe and a link stand for /dev/null and /dev/stdout: a test must not risk a device.)
    pipe, target, link = tmp / "pipe", tmp / "mine.yaml", tmp / "link.yaml"
    os.mkfifo(pipe)
    target.write_text("mine\n")
    link.symlink_to(target)
    for path in (pipe, link):
        code, err = run(["init-config", str(path), "--force"], capsys)
        assert code == 2
        one_line(err, path.name, "not a regular file")
    assert stat.S_ISFIFO(os.lstat(pipe).st_mode), "the pipe is still a pipe"
    assert link.is_symlink() and target.read_text() == "mine\n"
    assert run(["init-config", str(target), "--force"], capsys)[0] == 0  # a regular file: replaced
    assert "lods:" in target.read_text()


def broken_dat(tmp: Path, header: tuple[int, int, int]) -> Path:
    """A generated VWorld tile whose .dat header says (level, IDX, IDY) = ``header``."""
    tile = vworld_tile(tmp / "tile")
    dat = next(tile.glob("*.dat"))
    dat.write_bytes(struct.pack("<3I", *header) + dat.read_bytes()[12:])
    return tile


@pytest.mark.parametrize(
    "header, problem",
    [((31, 0, 0), "tile level 31"), ((15, 10 * 2**15, 116113), "IDX must be in 0..327679")],
)
def test_a_dat_header_beyond_the_tile_grid_is_an_input_error(tmp_path, capsys, header, problem):
    tile = broken_dat(tmp_path, header)
    dat = next(tile.glob("*.dat"))
    for source in (tile, dat):  # the folder (its only .dat refused) and the .dat alone
        code, err = run(export(source, "--out", tmp_path / "o"), capsys)
        assert code == 2
        one_line(err, dat.name, problem)
        assert not list((tmp_path / "o").glob("*")), "no tile folder left"
    assert main(["inspect", str(tile)]) == 0
    out = capsys.readouterr().out
    assert "problems: 1" in out and problem in out


def case_07_a_cityjson_declaring_a_crs_of_mars(tmp: Path, capsys) -> None:
    source = city_file(tmp / "mars.city.json", ["A"])
    data = json.loads(source.read_text())
    data["metadata"]["referenceSystem"] = "https://www.opengis.net/def/crs/IAU/2015/49910"
    source.write_text(json.dumps(data))
    code, err = run(export(source, "--out", tmp / "o"), capsys)
    assert code == 2
    one_line(err, "mars.city.json", "Mars, not of the Earth")


def case_08_jobs_beyond_four_per_core_are_capped(tmp: Path, capsys, monkeypatch) -> None:
    from exporter import pipeline

    asked: list[int | None] = []

    def recorded(folders, out, config, jobs=None, **options):
        asked.append(jobs)
        return pipeline.RunStats()

    monkeypatch.setattr(pipeline, "export_tiles", recorded)
    source = city_file(tmp / "a.city.json", ["A"])
    code = main(["export", str(source), "--out", str(tmp / "o"), "--jobs", "10000"])
    err = capsys.readouterr().err
    assert code == 0 and asked == [4 * usable_cores()]
    one_line(err, "--jobs 10000", f"using {4 * usable_cores()}")
    assert main(["export", str(source), "--out", str(tmp / "o"), "--jobs", "2"]) == 0
    assert asked[-1] == 2


def case_09_help_lists_debug_and_says_what_an_input_is(tmp: Path, capsys) -> None:
    for command in ("export", "inspect"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "--debug" in text and "traceback" in text
        assert "INPUT a tile folder" in text and ".city.json" in text and ".dat" in text


def case_10_summary_grammar_and_order_when_captured(tmp: Path, capsys) -> None:
    source = city_file(tmp / "a.city.json", ["A"], edit=shifted(1))
    command = [sys.executable, "-m", "exporter", "export", str(source), "--out", str(tmp / "o")]
    # stdout and stderr into one pipe, as `cmd > log 2>&1` does: progress first, summary last.
    done = subprocess.run(
        [*command, "--jobs", "1"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
        timeout=120, env=ENV, cwd=REPO,
    )  # fmt: skip
    lines = done.stdout.splitlines()
    assert done.returncode == 0, done.stdout
    assert lines[0].startswith("1/1 buildings") and lines[-1].startswith("done in")
    assert any(": 1 building (0 unchanged)" in line for line in lines)
    assert any("1 building, 1 tile proxy (1 built)" in line for line in lines)


@contextmanager
def tcp_service(greeting: bytes | None) -> Iterator[str]:
    """A TCP service on 127.0.0.1 that is not Dask: it sends ``greeting`` on every connection (a
    banner), or, with None, waits for a request as an HTTP server does; yields its address."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    stop = threading.Event()
    clients: list[socket.socket] = []

    def serve() -> None:
        server.settimeout(0.1)
        while not stop.is_set():
            try:
                client, _ = server.accept()
            except TimeoutError:
                continue
            clients.append(client)
            if greeting is not None:
                client.sendall(greeting)

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield f"tcp://127.0.0.1:{server.getsockname()[1]}"
    finally:
        stop.set()
        thread.join()
        for client in clients:
            client.close()
        server.close()


def test_a_scheduler_address_that_is_not_dask_is_refused_in_bounded_time(tmp_path, capsys):
    pytest.importorskip("distributed", reason="dask.distributed: pip install -e '.[test]'")
    from exporter.config import Config
    from exporter.distributed import ClusterError, ClusterOptions
    from exporter.pipeline import export_tiles

    source = city_file(tmp_path / "a.city.json", ["A"])
    with tcp_service(b"SSH-2.0-OpenSSH_9.2\r\n") as address:  # was "out of memory"
        code, err = run(export(source, "--out", tmp_path / "o", "--scheduler", address), capsys)
    assert code == 2
    one_line(err, address, "not a Dask scheduler", "SSH-2.0-OpenSSH_9.2")
    raised: list[BaseException] = []

    def export_there(address: str) -> None:
        try:
            options = ClusterOptions(address, connect_timeout_s=1.0)
            export_tiles([source], tmp_path / "o", Config(), scheduler=options)
        except BaseException as error:
            raised.append(error)

    with tcp_service(None) as address:  # an HTTP server: Dask's client waited forever
        attempt = threading.Thread(target=export_there, args=(address,), daemon=True)
        attempt.start()
        attempt.join(timeout=60)
        assert not attempt.is_alive(), "no answer must not mean no time limit"
    assert isinstance(raised[0], ClusterError), raised
    assert "no Dask handshake within 1 s" in str(raised[0])
    assert not list((tmp_path / "o").rglob("*.glb"))


def case_11_an_unchanged_report_draws_nothing_again(tmp: Path, capsys, monkeypatch) -> None:
    import exporter.report as report

    tile, out = vworld_tile(tmp / "tile", count=3), tmp / "o"
    assert run(export(tile, "--out", out, "--report"), capsys)[0] == 0
    drawn: list[str] = []
    real = report.render_building
    monkeypatch.setattr(
        report, "render_building", lambda d, b, *a: drawn.append(b["id"]) or real(d, b, *a)
    )
    (page,) = out.glob("*/report.html")
    images = {p.name: p.read_bytes() for p in (page.parent / "report").glob("*.png")}
    assert run(export(tile, "--out", out, "--report"), capsys)[0] == 0
    assert drawn == [], "nothing changed: nothing drawn again"
    assert {p.name: p.read_bytes() for p in (page.parent / "report").glob("*.png")} == images
    assert "3 buildings unchanged since the last report" in page.read_text()
    # One building's level rewritten: that building only is drawn again.
    manifest = json.loads((page.parent / "lod_manifest.json").read_text())
    first = manifest["buildings"][0]
    lod1 = page.parent / first["lods"][1]["file"]
    lod1.write_bytes(lod1.read_bytes())  # same bytes, a new modification time
    assert main(["report", str(out)]) == 0
    assert drawn == [first["id"]]


def test_the_report_says_why_a_level_keeps_the_mesh_of_the_level_above():
    from exporter.report.page import BuildingRenders, LevelRender, building_html, no_smaller_html

    def building(name: str, kept: bool) -> dict:
        lods = [{"level": 0, "triangles": 40}, {"level": 1, "triangles": 20}]
        lods.append(
            {"level": 2, "triangles": 20 if kept else 10, "no_smaller_than_above": kept,
             "error_budget_m": 0.218}
        )  # fmt: skip
        return {"id": name, "lods": lods}

    manifest = {"buildings": [building("a", True), building("b", True), building("c", False)]}
    text = no_smaller_html(manifest)
    assert "LOD2: 2 of 3 buildings keep LOD1" in text and "error budget" in text
    assert no_smaller_html({"buildings": [building("c", False)]}) == ""
    renders = BuildingRenders(manifest["buildings"][0])
    renders.levels = [LevelRender(k, lod) for k, lod in enumerate(renders.building["lods"])]
    assert "same mesh as LOD1: no smaller one stays within its 21.8 cm error budget" in (
        building_html(1, renders)
    )


CASES = {name: case for name, case in globals().items() if name.startswith("case_")}


@pytest.mark.parametrize("name", sorted(CASES))
def test_what_a_new_user_ran_into(name, request):
    """Each case gets ``tmp_path`` then the fixtures its further parameters name."""
    case = CASES[name]
    names = ["tmp_path", *list(inspect.signature(case).parameters)[1:]]
    case(*(request.getfixturevalue(fixture) for fixture in names))


def test_the_readme_names_every_tool_a_test_needs_with_its_install_command():
    """Each tool of ``tests/conftest.TOOLS`` (the skips' one wording per tool) is in the README's
    Quick start with its install command; .ci/run runs the npm ones; the compilers are named."""
    from tests.conftest import TOOLS

    readme = (REPO / "README.md").read_text(encoding="utf-8")
    quick = readme[readme.index("## Quick start") : readme.index("## Command line")]
    for _, command in TOOLS.values():
        assert command.split(" (")[0] in quick, command
    ci = (REPO / ".ci" / "run").read_text(encoding="utf-8")
    assert "npm ci --prefix tests/validator" in ci and "npm ci --prefix tests/tileset_client" in ci
    assert "meshoptimizer==0.2.30a0" in quick and "g++" in quick
