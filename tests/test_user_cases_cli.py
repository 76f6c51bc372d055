"""What a new user ran into on 0.4.3 (issue 36), the command line's and the pipeline's half: each
case ends with exit 0 and a correct result, or exit 2 and one line naming the path (or option)
and the problem. The readers' half is in ``tests/test_user_cases.py``."""

from __future__ import annotations

import inspect
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.test_user_cases import REPO, city_file, export, one_line, results, run, tree_bytes

ENV = {**os.environ, "PYTHONPATH": str(REPO)}


def shifted(boxes: int):
    """A ``city_file`` edit moving every vertex ``boxes`` building spacings (30 m) east: boxes 1 to
    3 of ``tests.test_user_cases`` all lie in level-15 tile 15_170611_124655."""

    def edit(vertices: list[list[float]]) -> None:
        for vertex in vertices:
            vertex[0] += 30.0 * boxes

    return edit


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
    tileset = (out / "tileset.json").read_text()
    assert all(f"{name}/lod0.glb" in tileset for name in ("A1", "A2", "B1"))
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
    assert run(export(source, "--out", out, "--force"), capsys)[0] == 0
    assert tree_bytes(elsewhere) == kept, "the link's target is left as it was"
    assert not folder.is_symlink() and (folder / "lod0.glb").is_file()
    assert set(results(out)[0]) == {"A", "B"}


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


CASES = {name: case for name, case in globals().items() if name.startswith("case_")}


@pytest.mark.parametrize("name", sorted(CASES))
def test_what_a_new_user_ran_into(name, request):
    """Each case gets ``tmp_path`` then the fixtures its further parameters name."""
    case = CASES[name]
    names = ["tmp_path", *list(inspect.signature(case).parameters)[1:]]
    case(*(request.getfixturevalue(fixture) for fixture in names))
