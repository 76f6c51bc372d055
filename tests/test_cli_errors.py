"""The command line on what a user can give it: inputs as folders, single files and shell globs;
every unusable input, config or output answered with exit 2 and one line naming the path (never a
traceback), 130 on Ctrl-C, suggestions for misspelled verbs, options and config keys."""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from exporter import atomic
from exporter.cli import main
from exporter.manifest import validate_manifest
from exporter.model import TileId

REPO = Path(__file__).resolve().parents[1]
TILE = TileId(15, 279418, 116113)
IS_ROOT = hasattr(os, "geteuid") and os.geteuid() == 0


@pytest.fixture(scope="module")
def tile(tmp_path_factory) -> Path:
    """A 3-building VWorld tile folder (.dat, .xdo, .jpg)."""
    from exporter.samplegen import generate_tile

    folder = tmp_path_factory.mktemp("tile") / TILE.name
    generate_tile(folder, count=3, seed=3, tile=TILE, atlas_size=32, mean_triangles=120)
    return folder


def cityjson_box(path: Path, crs: str | None = "EPSG:2056") -> Path:
    """One 10 m box building (CityJSON 2.0, Solid, EPSG:2056 at Bern) written to ``path``."""
    faces = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]
    data: dict = {
        "type": "CityJSON",
        "version": "2.0",
        "transform": {"scale": [0.01, 0.01, 0.01], "translate": [2600000.0, 1200000.0, 500.0]},
        "CityObjects": {
            "box": {
                "type": "Building",
                "geometry": [{"type": "Solid", "lod": "2", "boundaries": [[[f] for f in faces]]}],
            }
        },
        "vertices": [
            [x, y, z] for z in (0, 1000) for x, y in ((0, 0), (1000, 0), (1000, 1000), (0, 1000))
        ],
    }
    if crs:
        data["metadata"] = {"referenceSystem": f"https://www.opengis.net/def/crs/EPSG/0/{crs[5:]}"}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    return path


def run(argv: list[str], capsys) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def assert_one_line(err: str, *names: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for name in names:
        assert name in lines[0], (name, lines[0])
    return lines[0]


# --------------------------------------------------------------------------- the table
# Each case makes its bad input under ``tmp`` and returns (argv, text the one line must name).


def _file(tmp: Path, name: str, data: bytes = b"") -> Path:
    path = tmp / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return path


def _binary(tmp: Path, name: str) -> Path:
    return _file(tmp, name, bytes(range(256)) * 8)


def _report_with_broken_manifest(tmp: Path) -> Path:
    out = tmp / "broken_out"
    _file(out / TILE.name, "lod_manifest.json", b'{"format": "vworld-lod-manifest", ')
    return out


def _export(*args) -> list[str]:
    return ["export", *map(str, args), "--quiet", "--jobs", "1"]


CASES = {
    # export: the output
    "export --out is an existing file": lambda t, tile: (
        _export(tile, "--out", _file(t, "README.md", b"mine")),
        "README.md",
    ),
    "export --out below a file": lambda t, tile: (
        _export(tile, "--out", _file(t, "plain") / "out"),
        "plain",
    ),
    # export: the inputs
    "export missing input": lambda t, tile: (_export(t / "nowhere", "--out", t / "o"), "nowhere"),
    "export glob that matched nothing": lambda t, tile: (
        _export(t / "tiles" / "*.city.json", "--out", t / "o"),
        "*.city.json",
    ),
    "export folder with no building data": lambda t, tile: (
        _export((t / "empty").mkdir() or t / "empty", "--out", t / "o"),
        "empty",
    ),
    "export empty .city.json": lambda t, tile: (
        _export(_file(t, "empty.city.json"), "--out", t / "o"),
        "empty.city.json",
    ),
    "export binary named .city.json": lambda t, tile: (
        _export(_binary(t, "noise.city.json"), "--out", t / "o"),
        "noise.city.json",
    ),
    "export binary named .dat": lambda t, tile: (
        _export(_binary(t, "15_1_1.dat"), "--out", t / "o"),
        "15_1_1.dat",
    ),
    "export CityJSON without a CRS": lambda t, tile: (
        _export(cityjson_box(t / "nocrs.city.json", crs=None), "--out", t / "o"),
        "nocrs.city.json",
    ),
    "export an .xdo alone": lambda t, tile: (
        _export(tile / "B0000.xdo", "--out", t / "o"),
        "B0000.xdo",
    ),
    "export a file of no input format": lambda t, tile: (
        _export(_file(t, "notes.txt", b"hello"), "--out", t / "o"),
        "notes.txt",
    ),
    "export index without its columns": lambda t, tile: (
        _export(_file(t, "models/buildings.csv", b"name,x\nhall.glb,1\n"), "--out", t / "o"),
        "buildings.csv",
    ),
    # export: the config
    "export config YAML that is a list": lambda t, tile: (
        _export(tile, "--out", t / "o", "--config", _file(t, "list.yaml", b"- a\n- b\n")),
        "list.yaml",
    ),
    "export config path that is a folder": lambda t, tile: (
        _export(tile, "--out", t / "o", "--config", t),
        str(t),
    ),
    "export missing config": lambda t, tile: (
        _export(tile, "--out", t / "o", "--config", t / "absent.yaml"),
        "absent.yaml",
    ),
    "export config not YAML": lambda t, tile: (
        _export(tile, "--out", t / "o", "--config", _file(t, "bad.yaml", b"lods: [\n")),
        "bad.yaml",
    ),
    "export binary config": lambda t, tile: (
        _export(tile, "--out", t / "o", "--config", _binary(t, "noise.yaml")),
        "noise.yaml",
    ),
    # inspect
    "inspect missing input": lambda t, tile: (["inspect", str(t / "nowhere")], "nowhere"),
    "inspect empty file": lambda t, tile: (
        ["inspect", str(_file(t, "empty.city.json"))],
        "empty.city.json",
    ),
    "inspect binary named .city.json": lambda t, tile: (
        ["inspect", str(_binary(t, "noise.city.json"))],
        "noise.city.json",
    ),
    "inspect folder with no building data": lambda t, tile: (
        ["inspect", str((t / "empty").mkdir() or t / "empty")],
        "empty",
    ),
    "inspect glob that matched nothing": lambda t, tile: (
        ["inspect", str(t / "*.dat")],
        "*.dat",
    ),
    "inspect config YAML that is a list": lambda t, tile: (
        ["inspect", str(tile), "--config", str(_file(t, "list.yaml", b"- 1\n"))],
        "list.yaml",
    ),
    # init-config
    "init-config path that is a folder": lambda t, tile: (["init-config", str(t)], str(t)),
    "init-config existing file": lambda t, tile: (
        ["init-config", str(_file(t, "lod.yaml", b"mine"))],
        "lod.yaml",
    ),
    "init-config below a file": lambda t, tile: (
        ["init-config", str(_file(t, "plain") / "lod.yaml"), "--force"],
        "plain",
    ),
    # report
    "report missing folder": lambda t, tile: (["report", str(t / "nowhere")], "nowhere"),
    "report a file": lambda t, tile: (["report", str(_file(t, "x.html", b"x"))], "x.html"),
    "report folder that is no export": lambda t, tile: (
        ["report", str((t / "empty").mkdir() or t / "empty")],
        "empty",
    ),
    "report broken manifest": lambda t, tile: (
        ["report", str(_report_with_broken_manifest(t))],
        "lod_manifest.json",
    ),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_input_exits_2_with_one_line_naming_the_path(case, tmp_path, tile, capsys):
    argv, named = CASES[case](tmp_path, tile)
    before = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*") if p.is_file()}
    code, _, err = run(argv, capsys)
    assert code == 2, err
    assert_one_line(err, named)
    # nothing the user had is touched
    assert all(p.stat().st_mtime_ns == t for p, t in before.items())


def test_directory_without_permission(tmp_path, tile, capsys, monkeypatch):
    locked = tmp_path / "locked"
    locked.mkdir()
    (locked / "a.city.json").write_text("{}")
    if IS_ROOT:  # root reads a chmod 000 folder: the denial is made where the folder is listed
        real_iterdir, real_listdir = Path.iterdir, os.listdir

        def check(folder) -> None:
            if Path(folder) == locked:
                raise PermissionError(errno.EACCES, "Permission denied", str(folder))

        def iterdir(self):
            check(self)
            return real_iterdir(self)

        def listdir(folder="."):
            check(folder)
            return real_listdir(folder)

        monkeypatch.setattr(Path, "iterdir", iterdir)
        monkeypatch.setattr(os, "listdir", listdir)
    else:
        locked.chmod(0)
    try:
        for argv in (["inspect", str(locked)], _export(locked, "--out", tmp_path / "o")):
            code, _, err = run(argv, capsys)
            assert code == 2
            assert "Permission denied" in assert_one_line(err, "locked")
    finally:
        locked.chmod(0o755)


@pytest.mark.skipif(IS_ROOT, reason="runs as root: chmod cannot make a folder unwritable for root")
def test_unwritable_out_folder(tmp_path, tile, capsys):
    out = tmp_path / "readonly"
    out.mkdir()
    out.chmod(0o555)
    try:
        code, _, err = run(_export(tile, "--out", out / "o"), capsys)
    finally:
        out.chmod(0o755)
    assert code == 2
    assert_one_line(err, "readonly")


def test_read_only_file_system_names_the_output_file(tmp_path, tile, capsys, monkeypatch):
    """EROFS from the first output file (made where root cannot be denied: at the open)."""

    def read_only(path, flags, mode=0o777):
        raise OSError(errno.EROFS, "Read-only file system", path)

    monkeypatch.setattr(atomic.os, "open", read_only)
    code, _, err = run(_export(tile, "--out", tmp_path / "o"), capsys)
    assert code == 2
    line = assert_one_line(err, str(tmp_path / "o"), "Read-only file system")
    assert ".tmp" not in line, "names the file the user asked for, not the hidden temporary"


@pytest.mark.parametrize("jobs", ["1", "2"])  # 2: the error comes back from a worker process
def test_full_disk_leaves_nothing_half_written_and_the_next_run_finishes(
    jobs, tmp_path, tile, capsys, monkeypatch
):
    reference = tmp_path / "reference"
    assert main(_export(tile, "--out", reference)) == 0
    out = tmp_path / "out"
    real_write, calls = atomic.os.write, []

    def fills_up(fd, data):
        calls.append(1)
        # The disk is full during the second building's writes only (another program then frees
        # space): the run must stop there, not list the building as skipped and go on.
        if 5 < len(calls) <= 7:
            raise OSError(errno.ENOSPC, "No space left on device")

        return real_write(fd, data)

    monkeypatch.setattr(atomic.os, "write", fills_up)
    code, _, err = run(_export(tile, "--out", out, "--jobs", jobs), capsys)
    assert code == 2
    line = assert_one_line(err, str(out), "No space left on device", "re-run")

    assert ".tmp" not in line
    assert not list(out.rglob("lod_manifest.json")), "a tile is complete only with its manifest"
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]
    finished = list(out.rglob("building.json"))
    assert finished, "the buildings finished before the disk filled are kept"
    monkeypatch.setattr(atomic.os, "write", real_write)
    assert main(_export(tile, "--out", out)) == 0
    manifest = lambda root: json.loads(next(root.rglob("lod_manifest.json")).read_text())
    assert manifest(out) == manifest(reference)
    names = lambda root: sorted(str(p.relative_to(root)) for p in root.rglob("*"))
    assert names(out) == names(reference)


# --------------------------------------------------------------------------- Ctrl-C, bugs, --debug


INTERRUPT_AT = {
    "export": "exporter.pipeline.export_tiles",
    "inspect": "exporter.readers.scan_folder",
    "init-config": "exporter.atomic.write_text_atomic",
    "report": "exporter.report.write_reports",
}


def _argv(command: str, tmp: Path, tile: Path) -> list[str]:
    return {
        "export": _export(tile, "--out", tmp / "o"),
        "inspect": ["inspect", str(tile)],
        "init-config": ["init-config", str(tmp / "lod.yaml")],
        "report": ["report", str(tmp)],
    }[command]


@pytest.mark.parametrize("command", list(INTERRUPT_AT))
def test_ctrl_c_exits_130_with_one_line(command, tmp_path, tile, capsys, monkeypatch):
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(INTERRUPT_AT[command], interrupted)
    code, _, err = run(_argv(command, tmp_path, tile), capsys)
    assert code == 130
    assert "interrupted" in assert_one_line(err)


def test_a_bug_is_one_line_exit_1_and_debug_shows_the_traceback(
    tmp_path, tile, capsys, monkeypatch
):
    def bug(*args, **kwargs):
        raise ZeroDivisionError("division by zero")

    monkeypatch.setattr("exporter.readers.scan_folder", bug)
    code, _, err = run(["inspect", str(tile)], capsys)
    assert code == 1
    assert "--debug" in assert_one_line(err, "ZeroDivisionError")
    with pytest.raises(ZeroDivisionError):
        main(["inspect", str(tile), "--debug"])
    monkeypatch.setenv("VWORLD_LOD_DEBUG", "1")
    with pytest.raises(ZeroDivisionError):
        main(["inspect", str(tile)])


# --------------------------------------------------------------------------- suggestions


@pytest.mark.parametrize(
    "argv, wanted",
    [
        (["exprt", "x"], "did you mean 'export'?"),
        (["inspct", "x"], "did you mean 'inspect'?"),
        (["export", "x", "--ot", "o"], "--ot: did you mean --out?"),
        (["export", "x", "--out", "o", "--forse"], "--forse: did you mean --force?"),
    ],
)
def test_misspelled_verbs_and_options_get_the_likely_one(argv, wanted, capsys):
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    assert wanted in assert_one_line(capsys.readouterr().err)


def test_misspelled_config_key_gets_the_likely_one(tmp_path, tile, capsys):
    config = tmp_path / "lod.yaml"
    config.write_text("simplfy: {protect_largest: 30%}\n")
    code, _, err = run(["inspect", str(tile), "--config", str(config)], capsys)
    assert code == 2
    assert "simplfy: unknown key; did you mean 'simplify'?" in assert_one_line(err, "lod.yaml")
    config.write_text("simplify: {protect_largst: 30%}\n")
    code, _, err = run(["inspect", str(tile), "--config", str(config)], capsys)
    assert "did you mean 'protect_largest'?" in assert_one_line(err, "simplify.protect_largst")
    config.write_text("zzz: 1\n")
    code, _, err = run(["inspect", str(tile), "--config", str(config)], capsys)
    assert "did you mean" not in assert_one_line(err, "zzz") and "allowed keys" in err


# --------------------------------------------------------------------------- single files, globs


def _inspected(argv: list[str], capsys) -> str:
    code, out, err = run(argv, capsys)
    assert code == 0, err
    return out


def test_a_dat_file_alone_reads_its_folders_models(tmp_path, tile, capsys):
    dat = next(tile.glob("*.dat"))
    by_file, by_folder = tmp_path / "file", tmp_path / "folder"
    assert main(_export(dat, "--out", by_file)) == 0
    assert main(_export(tile, "--out", by_folder)) == 0
    manifest = lambda root: json.loads(next(root.rglob("lod_manifest.json")).read_text())
    assert len(manifest(by_file)["buildings"]) == 3
    assert manifest(by_file)["buildings"] == manifest(by_folder)["buildings"]


def test_shell_glob_over_a_tile_folder_reads_each_building_once(tile, capsys):
    everything = sorted(str(p) for p in tile.iterdir())  # what `tile/*` expands to
    out = _inspected(["inspect", *everything], capsys)
    assert "total: 3 buildings" in out and out.count("format vworld") == 1
    both = _inspected(["inspect", str(tile), *everything], capsys)
    assert both.count("format vworld") == 1 and "total: 3 buildings" in both


def test_files_and_folders_mixed_in_one_call(tmp_path, tile, capsys):
    a = cityjson_box(tmp_path / "a.city.json")
    b = cityjson_box(tmp_path / "more" / "b.json")  # a plain .json recognised by its content
    out = tmp_path / "out"
    code, _, err = run(_export(a, b, tile, "--out", out), capsys)
    assert code == 0, err
    manifests = [json.loads(p.read_text()) for p in out.rglob("lod_manifest.json")]
    for manifest in manifests:
        validate_manifest(manifest)
    sources = sorted(Path(b["source"]).name for m in manifests for b in m["buildings"])
    assert sources.count("a.city.json") == sources.count("b.json") == 1
    assert sum(name.endswith(".xdo") for name in sources) == 3


def test_an_index_file_alone_reads_the_models_beside_it(tmp_path, capsys):
    import trimesh

    models = tmp_path / "models"
    models.mkdir()
    trimesh.creation.box(extents=(4.0, 6.0, 8.0)).export(models / "hall.glb")
    index = models / "city_hall.csv"  # any name, given on the command line
    index.write_text("file,lon,lat,elev\nhall.glb,126.978,37.5665,38.5\n")
    out = _inspected(["inspect", str(index)], capsys)
    assert "format folder" in out and "hall: 1 part(s), 12 triangles" in out


def test_real_zurich_file_exports(tmp_path, shared_real, capsys):
    source = shared_real / "zurich_lod2.city.json"
    out = tmp_path / "out"
    code, _, err = run(["export", str(source), "--out", str(out), "--quiet", "--jobs", "2"], capsys)
    assert code == 0, err
    manifests = [json.loads(p.read_text()) for p in out.rglob("lod_manifest.json")]
    assert manifests
    for manifest in manifests:
        validate_manifest(manifest)
    buildings = sum(len(m["buildings"]) for m in manifests)
    listed = json.loads(source.read_text())["CityObjects"]
    assert buildings == sum(o.get("type") == "Building" for o in listed.values())


# --------------------------------------------------------------------------- as a user runs it


@pytest.mark.parametrize(
    "argv, code, named",
    [
        (["export", "samples/15_279418_116113", "--out", "README.md"], 2, "README.md"),
        (["inspect", "samples/15_279418_116113/B0000.xdo"], 2, "B0000.xdo"),
        (["exprt", "samples"], 2, "export"),
    ],
)
def test_as_a_subprocess(argv, code, named):
    result = subprocess.run(
        [sys.executable, "-m", "exporter", *argv],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == code
    assert_one_line(result.stderr, named)
    assert (REPO / "README.md").read_text().startswith("# vworld-lod")


def test_debug_env_shows_the_traceback_in_a_subprocess(tmp_path):
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "exporter",
            "export",
            "samples/15_279418_116113",
            "--out",
            "README.md",
        ],
        cwd=REPO,
        env={**os.environ, "PYTHONPATH": str(REPO), "VWORLD_LOD_DEBUG": "1"},
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 1 and "Traceback" in result.stderr
    assert "README.md" in result.stderr.strip().splitlines()[-1]
