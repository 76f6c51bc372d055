"""Shared fixtures: the real test data (tests/data/real), the tools some tests need with one skip
wording per tool (:func:`missing_tool`), the Khronos glTF validator, small helpers."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest
from hypothesis import settings

# CI runs the property tests with a fixed seed (a landing must not depend on luck); developers'
# runs keep exploring new examples. Failures found locally belong in explicit @example()s.
settings.register_profile("ci", derandomize=True, print_blob=True)
if os.environ.get("CI"):
    settings.load_profile("ci")

REPO = Path(__file__).resolve().parents[1]
REAL = REPO / "tests" / "data" / "real"  # public data carried in the repository (PROVENANCE.md)
SHARED_REAL = REAL  # the name older tests use
VALIDATOR_DIR = REPO / "tests" / "validator"
TILESET_CLIENT_DIR = REPO / "tests" / "tileset_client"


@pytest.fixture
def shared_real() -> Path:
    """tests/data/real: real CityJSON and CityGML files (always in the repository)."""
    return REAL


# --------------------------------------------------------------------------- tools pip cannot install

# What each tool is and the command that installs it (README, "Quick start"; .ci/run runs them).
TOOLS = {
    "node": ("Node.js (node and npm)", "apt-get install nodejs npm"),
    "gltf-validator": ("the Khronos glTF validator", "npm ci --prefix tests/validator"),
    "tileset-client": ("CesiumJS and puppeteer-core", "npm ci --prefix tests/tileset_client"),
    "mono": ("mono's C# compiler and runtime", "apt-get install mono-mcs mono-runtime"),
    "chromium": (
        "Chromium or Chrome",
        "apt-get install chromium (or set CHROME to a Chromium/Chrome binary)",
    ),
}

# Names a Chromium or Chrome binary goes by (Debian, Ubuntu's snap wrapper, Google's packages).
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def chromium() -> Path | None:
    """The Chromium/Chrome binary: ``$CHROME`` when set, else the first of ``CHROMIUM_NAMES`` on
    PATH, else None."""
    given = os.environ.get("CHROME")
    if given:
        return Path(given) if Path(given).is_file() else None
    found = next((shutil.which(name) for name in CHROMIUM_NAMES if shutil.which(name)), None)
    return Path(found) if found else None


def _present(tool: str) -> bool:
    if tool == "node":
        return shutil.which("node") is not None
    if tool == "gltf-validator":
        return (VALIDATOR_DIR / "node_modules" / "gltf-validator").is_dir()
    if tool == "tileset-client":
        return all(
            (TILESET_CLIENT_DIR / "node_modules" / package).is_dir()
            for package in ("cesium", "puppeteer-core")
        )
    if tool == "mono":
        return shutil.which("mcs") is not None and shutil.which("mono") is not None
    if tool == "chromium":
        return chromium() is not None
    raise KeyError(tool)


def missing_tool(*tools: str) -> str | None:
    """The skip reason for the first of ``tools`` (keys of ``TOOLS``) that is not installed, in
    one wording per tool: "<what> not installed: <install command>"; None when all are there."""
    for tool in tools:
        if not _present(tool):
            what, command = TOOLS[tool]
            return f"{what} not installed: {command}"
    return None


def needs(*tools: str) -> pytest.MarkDecorator:
    """A ``skipif`` mark for tests that need ``tools`` (:func:`missing_tool`)."""
    reason = missing_tool(*tools)
    return pytest.mark.skipif(reason is not None, reason=reason or "")


def run_gltf_validator(paths: list[Path]) -> list[dict]:
    """Validate .glb files with the Khronos validator; one report dict per file
    (``file``, ``errors``, ``warnings``, ``messages``)."""
    reports = []
    for start in range(0, len(paths), 200):  # bounded command lines
        chunk = [str(p) for p in paths[start : start + 200]]
        result = subprocess.run(
            ["node", str(VALIDATOR_DIR / "validate.js"), *chunk],
            capture_output=True,
            text=True,
            timeout=300,
        )
        lines = [line for line in result.stdout.splitlines() if line.startswith("{")]
        assert len(lines) == len(chunk), (
            f"validator output incomplete: {result.stdout[-2000:]} {result.stderr[-2000:]}"
        )
        reports += [json.loads(line) for line in lines]
    return reports


@pytest.fixture
def gltf_validator():
    reason = missing_tool("node", "gltf-validator")
    if reason:
        pytest.skip(reason)
    return run_gltf_validator
