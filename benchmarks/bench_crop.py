"""Shared atlases cut to what a building uses (exporter/crop.py): pixels kept and cost.

For every building of the inputs (default: the sample tile and the Rotterdam CityJSON with its
shared aerial atlases), read as the exporter reads it (LOD0 parts; the cut looks at every level's
uvs, here LOD0's, which hold the others'):

- texture pixels of the distinct atlases before and after the cut, summed per input, and what
  a client allocates for them at LOD0 (RGBA8 with mips: 4/3 x 4 bytes a pixel);
- seconds of ``crop_to_used`` against ``build_texture_lods`` of the same building's atlases (the
  texture stage it runs before; on the cut atlases), best of ``--rounds``, as a ratio: both
  measured in the same run, the machine being shared.

Usage: ``python benchmarks/bench_crop.py [--rounds 5] [FOLDER ...]``
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from exporter.config import Config  # noqa: E402
from exporter.crop import crop_to_used  # noqa: E402
from exporter.readers import load_entry, scan_folder  # noqa: E402
from exporter.textures import build_texture_lods, clear_texture_cache  # noqa: E402

INPUTS = [
    REPO / "samples" / "15_279418_116113",
    REPO / "tests" / "data" / "real" / "rotterdam_textured",
]


def pixels(parts) -> int:
    atlases = {p.texture.data: p.texture for p in parts if p.texture is not None}
    return sum(t.width * t.height for t in atlases.values())


def best(function, rounds: int) -> float:
    times = []
    for _ in range(rounds):
        clear_texture_cache()  # every round does the work: no cached atlas
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="*", type=Path, default=INPUTS)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    config = Config()
    scales = [spec.texture for spec in config.lods]
    print(f"{'input':<22} {'buildings':>9} {'cut':>4} {'Mpx before':>10} {'Mpx after':>9} "
          f"{'LOD0 MiB before':>15} {'after':>7} {'cut s / textures s':>18}")  # fmt: skip
    for folder in args.folders:
        scan = scan_folder(folder, config.readers)
        before = after = cut = 0
        crop_s = texture_s = 0.0
        for entry in scan.entries:
            parts = load_entry(entry, config.readers).parts
            [cropped] = crop_to_used([parts], config.textures)
            before, after = before + pixels(parts), after + pixels(cropped)
            cut += int(pixels(cropped) < pixels(parts))
            crop_s += best(lambda p=parts: crop_to_used([p], config.textures), args.rounds)
            atlases = list({p.texture.data: p.texture for p in cropped if p.texture}.values())
            texture_s += best(
                lambda a=atlases: [build_texture_lods(t, scales, config.textures) for t in a],
                args.rounds,
            )
        mib = 4 / 3 * 4 / 2**20
        print(f"{folder.name:<22} {len(scan.entries):>9} {cut:>4} {before / 1e6:>10.2f} "
              f"{after / 1e6:>9.2f} {before * mib:>15.1f} {after * mib:>7.1f} "
              f"{crop_s / max(texture_s, 1e-9):>18.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
