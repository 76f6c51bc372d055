"""The readers' one CRS rule (exporter.readers.crs): override > declared > option, never guessed."""

import pytest

from exporter.readers.crs import choose_crs


@pytest.mark.parametrize(
    "override, declared, option, expected",
    [
        ("EPSG:7415", "EPSG:28992", "EPSG:4326", ("EPSG:7415", "override")),
        (None, "EPSG:28992", "EPSG:4326", ("EPSG:28992", "declared")),
        (None, "", "EPSG:4326", ("EPSG:4326", "option")),
        (None, None, "EPSG:4326", ("EPSG:4326", "option")),
        ("", None, None, None),
        (None, None, None, None),
    ],
)
def test_an_override_beats_a_declared_crs_which_beats_the_option(
    override, declared, option, expected
):
    assert choose_crs(override, declared, option) == expected
