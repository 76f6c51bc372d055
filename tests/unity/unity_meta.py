"""Unity ``.meta`` files for ``unity_package/`` with fixed GUIDs.

Unity identifies every asset by the GUID in its ``.meta`` file; a package shipped without them
gets random GUIDs on each import, which breaks references (asmdef references by GUID, prefabs
pointing at scripts). Here each GUID is the md5 hex digest of the asset's path relative to the
package root ('/' separated, e.g. ``Runtime/Plan/LodPlan.cs``), so regenerating is deterministic.

Folders ending in ``~`` (and their contents) and dot-files are ignored by Unity and get no meta.

Run ``python tests/unity/unity_meta.py`` from the repo root to (re)write the metas.
"""

from __future__ import annotations

import hashlib
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[2] / "unity_package"

_TAIL = "  externalObjects: {}\n  userData: \n  assetBundleName: \n  assetBundleVariant: \n"
_IMPORTERS = {
    ".cs": "MonoImporter:\n  externalObjects: {}\n  serializedVersion: 2\n  defaultReferences: []\n"
    "  executionOrder: 0\n  icon: {instanceID: 0}\n  userData: \n  assetBundleName: \n  assetBundleVariant: \n",
    ".asmdef": "AssemblyDefinitionImporter:\n" + _TAIL,
    ".md": "TextScriptImporter:\n" + _TAIL,
    ".json": "TextScriptImporter:\n" + _TAIL,
    ".txt": "TextScriptImporter:\n" + _TAIL,
}
_FOLDER = "folderAsset: yes\nDefaultImporter:\n" + _TAIL
_PACKAGE_MANIFEST = "PackageManifestImporter:\n" + _TAIL


def guid_of(relative: str) -> str:
    """32 lower-case hex digits: md5 of the package-relative path."""
    return hashlib.md5(relative.encode("utf-8")).hexdigest()


def meta_text(relative: str, is_folder: bool) -> str:
    """The full ``.meta`` text for the asset at ``relative`` (package-relative, '/' separated)."""
    if is_folder:
        body = _FOLDER
    elif relative == "package.json":
        body = _PACKAGE_MANIFEST
    else:
        body = _IMPORTERS.get(Path(relative).suffix, "DefaultImporter:\n" + _TAIL)
    return f"fileFormatVersion: 2\nguid: {guid_of(relative)}\n{body}"


def assets(package: Path = PACKAGE) -> list[tuple[str, bool]]:
    """(relative path, is folder) of every asset Unity imports from the package."""
    result = []
    for path in sorted(package.rglob("*")):
        parts = path.relative_to(package).parts
        if path.suffix == ".meta" or any(p.startswith(".") or p.endswith("~") for p in parts):
            continue
        result.append(("/".join(parts), path.is_dir()))
    return result


def expected_metas(package: Path = PACKAGE) -> dict[Path, str]:
    return {package / (rel + ".meta"): meta_text(rel, is_dir) for rel, is_dir in assets(package)}


def write_metas(package: Path = PACKAGE) -> list[Path]:
    """Write every missing or outdated meta; returns the paths written."""
    written = []
    for path, text in expected_metas(package).items():
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
            written.append(path)
    return written


if __name__ == "__main__":
    for p in write_metas():
        print(p)
    sys.exit(0)
