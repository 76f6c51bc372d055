"""GPU texture bytes of exported tiles through the Unity package's Editor import (issue 35).

Compiles the package under mono against the test stand-ins (as ``tests/test_unity_package.py``
does) and runs its own ``GlbImages``, ``ImageHeader`` and ``TextureImportRules`` over every level's
``.glb`` of each manifest: the bytes the GPU holds with the package's import settings per platform
(full mip chains, Unity's block sizes), against glTFast's embedded textures (RGBA32 with mips).
Prints a Markdown table (``unity_package/Documentation~/textures.md`` has the sample tile's).

Run: ``python benchmarks/bench_unity_textures.py OUT/15_279418_116113/lod_manifest.json [...]``
(after ``vworld-lod export samples/15_279418_116113 --out OUT``). Needs mono (``apt-get install
mono-mcs mono-runtime``).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "tests"))

import test_unity_package as unity  # noqa: E402  (tests/test_unity_package.py)


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__)
        return 2
    if not (unity.MCS and unity.MONO):
        print("mono is not installed: apt-get install mono-mcs mono-runtime", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        build = unity.compile_package(Path(tmp))
        for manifest in map(Path, argv):
            measured = unity.texture_bytes(build, manifest)
            today = measured.pop("embedded_RGBA32")
            print(
                f"\n{manifest}\n\n| platform | GPU bytes | MiB | against today |\n|---|---|---|---|"
            )
            print(f"| today: embedded RGBA32 | {today:,} | {today / 2**20:.2f} | 1 |")
            for platform, size in measured.items():
                print(f"| {platform} | {size:,} | {size / 2**20:.2f} | 1/{today / size:.1f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
