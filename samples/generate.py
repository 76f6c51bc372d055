"""Write a deterministic VWorld-like sample tile (``.dat`` + ``.xdo`` + ``.jpg``) with
:func:`exporter.samplegen.generate_tile`.

    python samples/generate.py --out samples/15_279418_116113 --demo      # the committed demo tile
    python samples/generate.py --out /tmp/bench300 --count 300 --seed 1   # a benchmark tile
    python samples/generate.py --out /tmp/seoul1248 --count 1248          # the paper's building count

See samples/README.md.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

try:
    import exporter  # noqa: F401
except ImportError:  # running from a checkout without `pip install -e .`
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from exporter.model import TileId
from exporter.samplegen import KINDS, generate_tile

# The committed demo tile: every kind once, then two more, small atlases, some two-part buildings.
DEMO = dict(
    count=12,
    seed=7,
    atlas_size=512,
    mean_triangles=326.0,
    kinds=KINDS + ("l_shape", "box_gable"),
    two_part_share=0.25,
)
TILE_FILES = (".dat", ".xdo", ".jpg")


def parse_tile(text: str) -> TileId:
    try:
        level, idx, idy = (int(v) for v in text.split("_"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not <level>_<idx>_<idy>, e.g. 15_279418_116113"
        ) from None
    return TileId(level, idx, idy)


def positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text} is not a positive integer")
    return value


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--out",
        required=True,
        type=Path,
        help="tile folder to write (created; must hold no tile files unless --overwrite)",
    )
    parser.add_argument(
        "--demo",
        action="store_true",
        help="the committed demo tile's settings (ignores the options below)",
    )
    parser.add_argument("--count", type=positive, default=300, help="buildings (default 300)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    parser.add_argument(
        "--tile",
        type=parse_tile,
        default=TileId(15, 279418, 116113),
        help="<level>_<idx>_<idy> (default 15_279418_116113, Seoul City Hall)",
    )
    parser.add_argument(
        "--atlas", type=positive, default=1024, help="atlas side in pixels (default 1024)"
    )
    parser.add_argument(
        "--mean-triangles",
        type=float,
        default=326.0,
        help="mean triangles per building (default 326, the paper's Seoul mean)",
    )
    parser.add_argument(
        "--two-part-share",
        type=float,
        default=0.05,
        help="share of buildings with two textured parts (VWorld 3.0.0.2), default 0.05",
    )
    parser.add_argument(
        "--jobs",
        type=positive,
        default=1,
        help="processes drawing buildings (same result for any number; default 1)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="delete the .dat/.xdo/.jpg files already in --out first",
    )
    args = parser.parse_args(argv)

    existing = (
        [p for p in args.out.glob("*") if p.suffix.lower() in TILE_FILES]
        if args.out.is_dir()
        else []
    )
    if existing and not args.overwrite:
        parser.error(
            f"{args.out} already holds {len(existing)} tile files; pass --overwrite to replace them"
        )
    for path in existing:
        path.unlink()
    settings = (
        dict(DEMO)
        if args.demo
        else dict(
            count=args.count,
            seed=args.seed,
            atlas_size=args.atlas,
            mean_triangles=args.mean_triangles,
            kinds=None,
            two_part_share=args.two_part_share,
        )
    )
    tile = TileId(15, 279418, 116113) if args.demo else args.tile
    folder = generate_tile(
        args.out,
        settings["count"],
        settings["seed"],
        tile,
        settings["atlas_size"],
        settings["mean_triangles"],
        kinds=settings["kinds"],
        two_part_share=settings["two_part_share"],
        jobs=args.jobs,
    )
    size = sum(p.stat().st_size for p in folder.iterdir() if p.suffix.lower() in TILE_FILES)
    print(
        f"wrote {settings['count']} buildings of tile {tile.name} to {folder} ({size / 1e6:.2f} MB)"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
