"""The report pages in a real browser: headless Chromium (Debian package ``chromium``; also found as
``chromium-browser``, ``google-chrome`` or ``$CHROME``) opens them
from ``file://`` and the pages' own load script marks ``<body>`` with how many images loaded
(naturalWidth > 0) or broke and how many id'd tables and SVG plots were laid out with a non-zero
size; ``--dump-dom`` hands the marked DOM back. No network, no browser download.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from exporter.report import write_reports

sys.path.insert(0, str(Path(__file__).resolve().parent))
from test_report import TILE, make_fake_export

from tests.conftest import chromium, needs

CHROMIUM = chromium()  # $CHROME, chromium, chromium-browser or google-chrome
FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]

pytestmark = needs("chromium")


def body_marks(page: Path, profile: Path) -> dict[str, str]:
    """Open ``page`` in headless Chromium (fresh profile folder) and return <body>'s attributes."""
    command = [
        str(CHROMIUM),
        *FLAGS,
        f"--user-data-dir={profile}",
        "--virtual-time-budget=5000",
        "--dump-dom",
        page.resolve().as_uri(),
    ]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    body = re.search(r"<body([^>]*)>", result.stdout)
    assert body, (
        f"no <body> in Chromium's output (exit {result.returncode}): {result.stderr[-2000:]}"
    )
    return dict(re.findall(r'([\w-]+)="([^"]*)"', body.group(1)))


@pytest.fixture(scope="module")
def export(tmp_path_factory):
    out = tmp_path_factory.mktemp("out")
    make_fake_export(out)
    write_reports(out)
    return out


def test_every_image_loads_and_tables_render(export, tmp_path):
    page = export / TILE / "report.html"
    images = page.read_text(encoding="utf-8").count("<img ")
    assert (
        images == 2 * 11
    )  # render + atlas detail for 4 buildings x 3 levels, one level file missing
    marks = body_marks(page, tmp_path / "profile")
    assert marks.get("data-images-loaded") == str(images), marks
    assert marks.get("data-images-broken") == "0", marks
    assert {"level-table", "skipped-table"} <= set(marks.get("data-tables-shown", "").split()), (
        marks
    )
    assert marks.get("data-plots-shown") == "6", marks


def test_index_renders(export, tmp_path):
    marks = body_marks(export / "index.html", tmp_path / "profile")
    assert (
        marks.get("data-tables-shown") == "worst-table tile-table"
        and marks.get("data-images-broken") == "0"
    ), marks


def test_a_missing_image_is_counted_as_broken(export, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(export, copy)
    next((copy / TILE / "report").glob("*_lod1.png")).unlink()
    marks = body_marks(copy / TILE / "report.html", tmp_path / "profile")
    assert marks.get("data-images-broken") == "1" and marks.get("data-images-loaded") == str(
        2 * 11 - 1
    ), marks
