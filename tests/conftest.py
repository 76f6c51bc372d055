"""Shared fixtures: paths to ../shared, the Khronos glTF validator, small helpers."""

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
SHARED_REAL = REPO / "tests" / "data" / "real"  # carried in the repository (PROVENANCE.md)
VALIDATOR_DIR = REPO / "tests" / "validator"


@pytest.fixture
def shared_real() -> Path:
    """../shared/data/real, or a skip saying why (a clone outside this workspace has no ../shared)."""
    if not SHARED_REAL.is_dir():
        pytest.skip(
            f"{SHARED_REAL} not present: the real-data tests need the workspace's ../shared folder"
        )
    return SHARED_REAL


def _validator_available() -> str | None:
    if shutil.which("node") is None:
        return "node is not installed (needed for the Khronos glTF validator)"
    if not (VALIDATOR_DIR / "node_modules" / "gltf-validator").is_dir():
        return "gltf-validator not installed: run `npm ci --prefix tests/validator` (.ci/run does)"
    return None


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
    reason = _validator_available()
    if reason:
        pytest.skip(reason)
    return run_gltf_validator
