"""Config: defaults from the paper, YAML round trip, and refusal of bad configs before any work."""

import pytest
import yaml

from exporter.config import Config, config_from_dict, default_config_yaml, load_config
from exporter.errors import ConfigError


def test_defaults_are_the_papers():
    config = Config()
    assert [spec.transition for spec in config.lods] == [0.5, 0.17, 0.02]
    assert [spec.texture for spec in config.lods] == [1.0, 0.5, 0.25]
    assert config.lods[0].mesh == 1.0
    assert config.lods[1].mesh <= 0.6746 and config.lods[2].mesh <= 0.4807
    assert config.simplify.protect_largest == 0.30
    assert config.simplify.preserve_border_edges is True
    assert config.simplify.min_silhouette_iou == 0.97
    assert config.terrain_levels() == [15, 14, 13]


def test_init_config_yaml_loads_back_to_the_defaults(tmp_path):
    path = tmp_path / "lod.yaml"
    path.write_text(default_config_yaml())
    assert load_config(path) == Config()
    assert "# " in path.read_text()  # commented for the user


@pytest.mark.parametrize(
    "written, expected", [("50%", 0.5), (0.5, 0.5), ("12.5%", 0.125), (1, 1.0)]
)
def test_percentages_are_accepted_both_ways(written, expected):
    config = config_from_dict({"lods": [{"transition": written}]})
    assert config.lods[0].transition == pytest.approx(expected)


def test_partial_sections_keep_other_defaults():
    config = config_from_dict(
        {"simplify": {"protect_largest": "20%"}, "globe": {"unity_radius": 1000}}
    )
    assert config.simplify.protect_largest == pytest.approx(0.2)
    assert config.simplify.preserve_border_edges is True
    assert config.globe.unity_radius == 1000.0
    assert config.globe.earth_radius == 6378137.0


@pytest.mark.parametrize(
    "raw, key, allowed",
    [
        (
            {"lods": [{"transition": 0.5}, {"transition": 0.6}]},
            "lods[1].transition",
            "strictly decreasing",
        ),
        (
            {"lods": [{"transition": 0.5}, {"transition": 0.5}]},
            "lods[1].transition",
            "strictly decreasing",
        ),
        ({"lods": [{"transition": 0.5, "mesh": 1.5}]}, "lods[0].mesh", "(0, 1]"),
        ({"lods": [{"transition": 0.5, "mesh": 0}]}, "lods[0].mesh", "(0, 1]"),
        ({"simplify": {"min_silhouette_iou": 1.5}}, "simplify.min_silhouette_iou", "[0, 1]"),
        ({"lods": [{"transition": "fifty"}]}, "lods[0].transition", "(0, 1]"),
        ({"lods": [{"transition": 0.9 - i * 0.1} for i in range(9)]}, "lods", "1 to 8"),
        ({"lods": []}, "lods", "1 to 8"),
        ({"lods": [{"mesh": 1.0}]}, "lods[0]", "missing"),
        (
            {"simplify": {"preserve_border_edges": "yes"}},
            "simplify.preserve_border_edges",
            "true or false",
        ),
        ({"simplify": {"max_iterations": 2.5}}, "simplify.max_iterations", "integer"),
        ({"simplify": {"protect_biggest": 0.3}}, "simplify.protect_biggest", "allowed keys"),
        ({"colour": 1}, "colour", "allowed keys"),
        ({"unity": {"fade_mode": "dissolve"}}, "unity.fade_mode", "cross_fade"),
        ({"globe": {"unity_radius": -1}}, "globe.unity_radius", "> 0"),
        ({"globe": {"placement": "absolute"}}, "globe.placement", "tile_relative"),
    ],
)
def test_bad_configs_name_file_key_and_what_is_allowed(tmp_path, raw, key, allowed):
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(raw))
    with pytest.raises(ConfigError) as error:
        load_config(path)
    message = str(error.value)
    assert str(path) in message and key in message and allowed in message, message


def test_unreadable_and_invalid_yaml_files(tmp_path):
    with pytest.raises(ConfigError, match="cannot be read"):
        load_config(tmp_path / "missing.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("lods: [\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_config(broken)


@pytest.mark.parametrize(
    "key", ["globe.earth_radius", "globe.unity_radius", "simplify.vertex_link_distance",
            "simplify.max_screen_error_px", "readers.max_vertex_distance_m"],
)  # fmt: skip
@pytest.mark.parametrize("value", [".inf", "-.inf", ".nan", "1e300"])
def test_numbers_must_be_finite_and_in_range(tmp_path, key, value):
    section, name = key.split(".")
    path = tmp_path / "lod.yaml"
    path.write_text(f"{section}:\n  {name}: {value}\n")
    with pytest.raises(ConfigError) as error:
        load_config(path)
    assert error.value.key == key and "finite" in error.value.problem


def test_duplicate_keys_are_refused_with_their_lines(tmp_path):
    path = tmp_path / "lod.yaml"
    path.write_text("lods:\n  - {transition: 50%, mesh: 1, mesh: 0.5}\nglobe: {}\nglobe: {}\n")
    with pytest.raises(ConfigError) as error:
        load_config(path)
    assert error.value.key == "globe" and "lines 3, 4" in error.value.problem
    path.write_text("lods:\n  - {transition: 50%, mesh: 1, mesh: 0.5}\n")
    with pytest.raises(ConfigError) as error:
        load_config(path)
    assert error.value.key == "lods[0].mesh" and "lines 2, 2" in error.value.problem
