"""Benchmark of texture LoDs (issue 6): fast vs careful JPEG downscaling, quality and codec floor.

Atlases: the real aerial atlases ``tests/data/real/rotterdam_textured/appearances/*.jpg``
(1024x1024 JPEG) when present, plus synthetic facade atlases (windows, brick, signs; JPEG q90).

Measured, per atlas (each repetition times the floor and every mode back to back with the cache
cleared; ratios are medians over ``--repeat`` repetitions):

- ``floor``: the codec floor = full decode of the source + JPEG encode of each reduced level;
- ``careful``: ``build_texture_lods`` with ``fast_jpeg_downscale: never`` (full decode, Lanczos
  from the full image for every level);
- ``auto`` / ``always``: the fast path (IDCT-scaled decode, each level from the previous one);
- PSNR (dB) of an IDCT-scaled decode at 1/2, 1/4, 1/8 against Lanczos from the full image (no
  encoding involved), and of each level's decoded output against that same reference;
- a tile of ``--buildings`` buildings sharing the atlases: whole texture time vs the codec floor of
  the distinct atlases (the cache's effect);
- ``--folder DIR``: the ``*.jpg`` atlases of a tile folder (e.g. ``exporter.samplegen.generate_tile``
  output) as one more group, with the PSNR of each mode's levels against what the default writes;
- ``auto``'s sampled check against the whole-image PSNR it estimates, per group (error, decisions
  that flip, its cost against the floor);
- ``--export DIR --baseline CHECKOUT``: the ``textures`` stage seconds of a real export of ``DIR``
  (``export_tiles(..., jobs=1)``) with this checkout and with ``CHECKOUT`` (e.g. ``git archive REV |
  tar -x -C /tmp/base``), alternated in fresh processes; median ratio.

Times are process CPU time (the work is single-threaded), printed as ratios against the baseline
measured in the same run.
Run: ``python benchmarks/bench_textures.py [--repeat 5] [--buildings 1000]``, or only a tile:
``python benchmarks/bench_textures.py --only-folder --folder /tmp/p100 --limit 40 --export /tmp/p100
--baseline /tmp/base``.
"""

from __future__ import annotations

import argparse
import io
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from exporter.config import TextureOptions
from exporter.model import Texture
from exporter.textures import (
    AUTO_MIN_PSNR_DB,
    box_psnr,
    build_texture_lods,
    clear_texture_cache,
    image_psnr,
    level_sizes,
    psnr,
    sampled_box_psnr,
)

# CPU time of this process: the codecs and resizes are single-threaded, and on a shared machine
# wall-clock time mostly measures the neighbours' load.
clock = time.process_time

REAL = (
    Path(__file__).resolve().parents[1]
    / "tests"
    / "data"
    / "real"
    / "rotterdam_textured"
    / "appearances"
)
SCALES = [1.0, 0.5, 0.25]
FACTORS = (2, 4, 8)
MODES = ("never", "auto", "always")


def facade_atlas(seed: int, width: int = 1024, height: int = 1024, style: str = "vworld") -> bytes:
    """A synthetic facade atlas as JPEG q90 bytes: wall grain, a grid of framed windows, signs.

    ``style``:
    - ``vworld``: texel size of VWorld's photogrammetric atlases (~8 cm/px: window bays 30-46 px,
      storeys 34-48 px, brick courses below a pixel); drawn at twice the size and reduced with
      Lanczos, as a camera's optics band-limit a photograph; wall grain with a 1/f amplitude spectrum
      like natural images (Field 1987, JOSA A 4(12)).
    - ``fine``: the same photo model at close-range texel size (~1.5 cm/px: bays 48-96 px, brick
      courses every 6 px): periodic detail near the pixel size.
    - ``sharp``: like ``fine`` but drawn at the final size with white per-pixel noise: pixel-sharp
      edges no photo has (a stress case).
    """
    rng = np.random.default_rng(seed)
    k = 1 if style == "sharp" else 2
    h, w = height * k, width * k
    y, x = np.mgrid[0:h, 0:w]
    if style == "sharp":
        noise = rng.normal(0, 12, (h, w, 3))
    else:
        fy, fx = np.fft.fftfreq(h)[:, None], np.fft.rfftfreq(w)[None, :]
        spectrum = rng.normal(size=(h, w // 2 + 1)) + 1j * rng.normal(size=(h, w // 2 + 1))
        grain = np.fft.irfft2(spectrum / np.maximum(np.hypot(fy, fx), 1.0 / max(h, w)), s=(h, w))
        noise = (grain * (14.0 / grain.std()))[..., None] + rng.normal(0, 2, (h, w, 3))
    image = np.array(rng.integers(90, 200, 3), dtype=np.float64) + noise
    if style == "vworld":
        cell_w, cell_h = int(rng.integers(30, 46)) * k, int(rng.integers(34, 48)) * k
    else:
        cell_w, cell_h = int(rng.integers(48, 96)) * k, int(rng.integers(64, 128)) * k
        course = 6 * k
        mortar = (y % course < k) | ((x + (y // course % 2) * 8 * k) % (16 * k) < k)
        image += np.where(mortar[..., None], -25.0, 0.0)
    for top in range(8 * k, h - cell_h, cell_h):
        for left in range(8 * k, w - cell_w, cell_w):
            image[top + 6 * k : top + cell_h - 10 * k, left + 6 * k : left + cell_w - 6 * k] = 235.0
            rows, cols = cell_h - 22 * k, cell_w - 18 * k
            sky = np.linspace(40, 140, rows)[:, None, None] * np.array([0.6, 0.8, 1.0])
            image[top + 9 * k : top + 9 * k + rows, left + 9 * k : left + 9 * k + cols] = (
                sky + rng.normal(0, 6, (rows, cols, 3))
            )
            image[
                top + cell_h // 2 - k : top + cell_h // 2 + k, left + 9 * k : left + cell_w - 9 * k
            ] = 235.0
    glyph = 1 if style == "sharp" else 4  # sign lettering: strokes of this many pixels
    for _ in range(6):
        top, left = int(rng.integers(0, h - 40 * k)), int(rng.integers(0, w - 200 * k))
        strokes = np.kron(
            rng.random((32 // glyph, 192 // glyph)) > 0.55,
            np.ones((glyph * k, glyph * k), dtype=bool),
        )
        image[top : top + 32 * k, left : left + 192 * k] = np.where(strokes[..., None], 20.0, 250.0)
    picture = Image.fromarray(np.clip(image, 0, 255).astype(np.uint8))
    if k > 1:
        picture = picture.resize((width, height), Image.Resampling.LANCZOS)
    out = io.BytesIO()
    picture.save(out, "JPEG", quality=90)
    return out.getvalue()


def atlases() -> list[tuple[str, bytes]]:
    found = (
        [(path.name, path.read_bytes()) for path in sorted(REAL.glob("*.jpg"))]
        if REAL.is_dir()
        else []
    )
    if not found:
        print(f"note: {REAL} not present; synthetic atlases only")
    synthetic = [(f"facade_{seed}.jpg", facade_atlas(seed)) for seed in range(6)]
    synthetic.append(("facade_wide.jpg", facade_atlas(99, 1024, 512)))
    stress = [(f"fine_{seed}.jpg", facade_atlas(seed, style="fine")) for seed in range(3)]
    stress += [(f"sharp_{seed}.jpg", facade_atlas(seed, style="sharp")) for seed in range(2)]
    return found + synthetic + samplegen_atlases() + stress


def samplegen_atlases(count: int = 5) -> list[tuple[str, bytes]]:
    """The atlases of the project's own sample buildings (``exporter.samplegen``, Pillow-drawn)."""
    from exporter.samplegen import generate_buildings

    found = {}
    for building in generate_buildings(count, seed=1):
        for part in building.parts:
            if part.texture is not None:
                found.setdefault(f"samplegen_{part.texture.name}", part.texture.data)
    return list(found.items())


def pixels(image: Image.Image) -> np.ndarray:
    return np.asarray(image.convert("RGB"))


def codec_floor(data: bytes, reduced: list[Image.Image]) -> None:
    """The codec floor of one atlas: decode it in full, encode its reduced levels."""
    Image.open(io.BytesIO(data)).load()
    for image in reduced:
        image.save(io.BytesIO(), "JPEG", quality=TextureOptions().jpeg_quality)


def reduced_levels(data: bytes) -> list[Image.Image]:
    full = Image.open(io.BytesIO(data))
    sizes = level_sizes(full.width, full.height, SCALES, TextureOptions().min_size)
    return [full.resize(size, Image.Resampling.LANCZOS) for size in sizes[1:]]


def measure_atlas(name: str, data: bytes, repeat: int) -> dict:
    full = Image.open(io.BytesIO(data))
    full.load()
    reference = {image.size: image for image in reduced_levels(data)}
    texture = Texture(data, "image/jpeg", full.width, full.height, name, name)

    def floor() -> None:
        codec_floor(data, list(reference.values()))

    # Each repetition times the floor and every mode back to back; ratios are taken per
    # repetition (the machine's load drifts between them) and their median is reported.
    runs = {"floor": floor}
    for mode in MODES:
        options = TextureOptions(fast_jpeg_downscale=mode)
        runs[mode] = lambda options=options: build_texture_lods(texture, SCALES, options)
    times = {key: [] for key in runs}
    for _ in range(repeat):
        for key, run in runs.items():
            clear_texture_cache()
            start = clock()
            run()
            times[key].append(clock() - start)
    result = {"name": name, "floor": statistics.median(times["floor"])}
    for mode in MODES:
        result[mode] = statistics.median(times[mode])
        result[f"{mode}/floor"] = statistics.median(
            t / f for t, f in zip(times[mode], times["floor"])
        )
        result[f"{mode}/never"] = statistics.median(
            t / f for t, f in zip(times[mode], times["never"])
        )
        clear_texture_cache()
        levels = build_texture_lods(texture, SCALES, TextureOptions(fast_jpeg_downscale=mode))
        result[f"psnr_{mode}"] = [
            psnr(pixels(reference[(t.width, t.height)]), pixels(Image.open(io.BytesIO(t.data))))
            for t in levels[1:]
        ]
        result[f"out_{mode}"] = [pixels(Image.open(io.BytesIO(t.data))) for t in levels[1:]]
    # Each mode's output against the default's (what a default export writes), per level.
    default = result[f"out_{TextureOptions().fast_jpeg_downscale}"]
    for mode in MODES:
        result[f"vs_default_{mode}"] = [
            psnr(a, b) for a, b in zip(default, result.pop(f"out_{mode}"))
        ]
    for factor in FACTORS:
        size = (-(-full.width // factor), -(-full.height // factor))
        drafted = Image.open(io.BytesIO(data))
        drafted.draft(drafted.mode, size)
        drafted.load()
        careful = full.resize(drafted.size, Image.Resampling.LANCZOS)
        result[f"draft_{factor}"] = psnr(pixels(careful), pixels(drafted))
        # What auto's one-octave-down check estimates for it.
        result[f"estimate_{factor}"] = sampled_box_psnr(drafted.convert("RGB"), 2)
        # Context: a box filter (what mipmapping does) against the same reference.
        result[f"box_{factor}"] = psnr(pixels(careful), pixels(full.reduce(factor)))
    return result


def measure_tile(
    label: str, atlas_list: list[tuple[str, bytes]], buildings: int, repeat: int
) -> None:
    """Texture time of a tile of ``buildings`` buildings sharing ``atlas_list`` against the codec
    floor of the distinct atlases, both timed back to back (medians of ``repeat``); with the same
    bytes objects (a reader that caches files) and with fresh copies (each building reads its file
    again, so every call compares its bytes)."""
    choice = np.random.default_rng(0).integers(0, len(atlas_list), buildings)
    levels = [reduced_levels(data) for _, data in atlas_list]
    for kind, copy in (("same bytes objects", False), ("fresh copies", True)):
        textures = []
        for k, i in enumerate(choice):
            name, data = atlas_list[i]
            textures.append(
                Texture(
                    bytes(bytearray(data)) if copy else data,
                    "image/jpeg",
                    0,
                    0,
                    name,
                    f"b{k}/{name}",
                )
            )
        ratios = []
        for _ in range(repeat):
            start = clock()
            for (_, data), reduced in zip(atlas_list, levels):
                codec_floor(data, reduced)
            floor = clock() - start
            clear_texture_cache()
            start = clock()
            for texture in textures:
                build_texture_lods(texture, SCALES, TextureOptions())
            ratios.append((clock() - start) / floor)
        print(
            f"  tile of {buildings} buildings sharing {len(atlas_list)} {label} atlases, {kind}: "
            f"{statistics.median(ratios):.2f} x the codec floor of the distinct atlases"
        )


_EXPORT_SCRIPT = """
import json, sys, tempfile
sys.path.insert(0, sys.argv[1])
from exporter.config import Config
from exporter.pipeline import export_tiles
with tempfile.TemporaryDirectory() as out:
    print(json.dumps(export_tiles([sys.argv[2]], out, Config(), jobs=1, force=True).seconds))
"""


def export_stage_seconds(checkout: Path, folder: str) -> dict:
    """Seconds per stage of a one-process export of ``folder`` with the exporter at ``checkout``."""
    done = subprocess.run(
        [sys.executable, "-c", _EXPORT_SCRIPT, str(checkout), folder],
        capture_output=True,
        text=True,
        check=True,
        cwd=tempfile.gettempdir(),
    )
    return json.loads(done.stdout.strip().splitlines()[-1])


def measure_export(folder: str, baseline: Path, repeat: int) -> None:
    """``textures`` stage seconds of a real export, this checkout vs ``baseline``, alternated."""
    here = Path(__file__).resolve().parents[1]
    ratios, times = [], {"this": [], "baseline": []}
    for _ in range(repeat):
        now, before = (
            export_stage_seconds(here, folder)["textures"],
            export_stage_seconds(baseline, folder)["textures"],
        )
        times["this"].append(now)
        times["baseline"].append(before)
        ratios.append(now / before)
    print(
        f"\nexport of {folder} (jobs=1), textures stage: this / baseline = {statistics.median(ratios):.2f} "
        f"(median of {repeat}; {statistics.median(times['this']):.2f} s vs {statistics.median(times['baseline']):.2f} s)"
    )


def cost_breakdown(atlas_list: list[tuple[str, bytes]], repeat: int) -> None:
    """What the steps of the fast path cost against the codec floor (same atlases, one run): the
    draft decode, LOD2 by Lanczos or by box, ``auto``'s check sampled or on the whole image."""

    def decode(data, size=None):
        image = Image.open(io.BytesIO(data))
        if size:
            image.draft("RGB", size)
        image.load()
        return image

    steps = {
        "floor: full decode + encode levels": [],
        "draft decode 1/2": [],
        "Lanczos 1/2 -> 1/4": [],
        "auto's sampled check (sampled_box_psnr)": [],
        "whole-image check (box_psnr)": [],
        "box 1/2 -> 1/4 (Image.reduce)": [],
        "encode levels": [],
    }
    for _ in range(repeat):
        spent = dict.fromkeys(steps, 0.0)
        for _, data in atlas_list:
            width, height = Image.open(io.BytesIO(data)).size
            half_size, quarter_size = (width // 2, height // 2), (width // 4, height // 4)
            start = clock()
            decode(data)
            full_decode = clock() - start
            start = clock()
            half = decode(data, half_size)
            spent["draft decode 1/2"] += clock() - start
            start = clock()
            quarter = half.resize(quarter_size, Image.Resampling.LANCZOS)
            spent_lanczos = clock() - start
            spent["Lanczos 1/2 -> 1/4"] += spent_lanczos
            start = clock()
            image_psnr(quarter, half.reduce(2))
            spent["whole-image check (box_psnr)"] += clock() - start + spent_lanczos
            start = clock()
            sampled_box_psnr(half, 2)
            spent["auto's sampled check (sampled_box_psnr)"] += clock() - start
            start = clock()
            half.reduce(2)
            spent["box 1/2 -> 1/4 (Image.reduce)"] += clock() - start
            start = clock()
            for image in (half, quarter):
                image.save(io.BytesIO(), "JPEG", quality=TextureOptions().jpeg_quality)
            encode = clock() - start
            spent["encode levels"] += encode
            spent["floor: full decode + encode levels"] += full_decode + encode
        for key, value in spent.items():
            steps[key].append(value / spent["floor: full decode + encode levels"])
    print(f"\ncost of each step / codec floor ({len(atlas_list)} atlases, median of {repeat}):")
    for key, ratios in steps.items():
        print(f"  {key:40s} {statistics.median(ratios):.2f}")


def lod2_filters(label: str, atlas_list: list[tuple[str, bytes]]) -> None:
    """LOD2 (1/4 per side) made from the 1/2 IDCT-scaled decode by other filters: PSNR (dB) of its
    JPEG q90 output against Lanczos from the full image, min/mean over the atlases."""

    def luma_lanczos(half: Image.Image, size: tuple[int, int]) -> Image.Image:
        y, cb, cr = half.convert("YCbCr").split()
        return Image.merge(
            "YCbCr", (y.resize(size, Image.Resampling.LANCZOS), cb.reduce(2), cr.reduce(2))
        ).convert("RGB")

    filters = {
        "Lanczos (never; auto where its check fails)": lambda half, size: half.resize(
            size, Image.Resampling.LANCZOS
        ),
        "Lanczos luma, box chroma": luma_lanczos,
        "bicubic": lambda half, size: half.resize(size, Image.Resampling.BICUBIC),
        "Hamming": lambda half, size: half.resize(size, Image.Resampling.HAMMING),
        "box (always; auto where its check passes)": lambda half, size: half.reduce(2),
    }
    found = {name: [] for name in filters}
    for _, data in atlas_list:
        full = Image.open(io.BytesIO(data)).convert("RGB")
        size = (full.width // 4, full.height // 4)
        reference = pixels(full.resize(size, Image.Resampling.LANCZOS))
        half = Image.open(io.BytesIO(data))
        half.draft("RGB", (full.width // 2, full.height // 2))
        half.load()
        for name, make in filters.items():
            out = io.BytesIO()
            make(half, size).save(out, "JPEG", quality=TextureOptions().jpeg_quality)
            found[name].append(psnr(reference, pixels(Image.open(out))))
    print(
        f"\nLOD2 of {label} ({len(atlas_list)} atlases) from the 1/2 decode, q90 vs Lanczos from full, min/mean dB: "
        + ", ".join(f"{name} {min(v):.1f}/{statistics.mean(v):.1f}" for name, v in found.items())
    )


def check_agreement(label: str, atlas_list: list[tuple[str, bytes]], repeat: int) -> None:
    """``auto``'s sampled check (``sampled_box_psnr``) against the whole-image value it estimates
    (``box_psnr``), at 2x on the two images it is taken on: the 1/2 IDCT-scaled decode (the guard
    of LOD1, and LOD2's box-or-Lanczos choice) and a Lanczos 1/2 of the full image (the fallback's
    LOD1). Sampled - whole in dB, decisions on the other side of the threshold, and the check's CPU
    time against the codec floor (median of ``repeat``)."""
    errors, flips, ratios = [], [], []
    for name, data in atlas_list:
        half = Image.open(io.BytesIO(data))
        size = (half.width // 2, half.height // 2)
        half.draft("RGB", size)
        half.load()
        careful = Image.open(io.BytesIO(data)).convert("RGB").resize(size, Image.Resampling.LANCZOS)
        for image in (half.convert("RGB"), careful):
            whole, sampled = box_psnr(image, 2), sampled_box_psnr(image, 2)
            errors.append(sampled - whole)
            if (whole >= AUTO_MIN_PSNR_DB) != (sampled >= AUTO_MIN_PSNR_DB):
                flips.append(f"{name} whole {whole:.1f} sampled {sampled:.1f}")
        runs = []
        for _ in range(repeat):
            start = clock()
            codec_floor(data, [careful, careful.reduce(2)])
            floor = clock() - start
            start = clock()
            sampled_box_psnr(half, 2)
            runs.append((clock() - start) / floor)
        ratios.append(statistics.median(runs))
    print(
        f"\nauto's sampled check on {label} ({len(atlas_list)} atlases x 2 images): sampled - whole "
        f"{min(errors):+.2f}..{max(errors):+.2f} dB; other side of {AUTO_MIN_PSNR_DB:g} dB: {len(flips)} {flips}; "
        f"check / floor mean {statistics.mean(ratios):.3f} (max {max(ratios):.3f})"
    )


def folder_atlases(folder: str, limit: int) -> list[tuple[str, bytes]]:
    """The ``*.jpg`` atlases of a tile folder, named ``tile_<file>``."""
    paths = sorted(Path(folder).glob("*.jpg"))[:limit]
    return [(f"tile_{path.name}", path.read_bytes()) for path in paths]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--buildings", type=int, default=1000)
    parser.add_argument("--folder", help="also measure the *.jpg atlases of this tile folder")
    parser.add_argument(
        "--limit", type=int, default=40, help="at most this many atlases of --folder"
    )
    parser.add_argument(
        "--only-folder", action="store_true", help="skip the built-in atlas sets and the cache runs"
    )
    parser.add_argument(
        "--export", help="a tile folder to export with this checkout and --baseline"
    )
    parser.add_argument(
        "--baseline", type=Path, help="another checkout of the project (for --export)"
    )
    args = parser.parse_args()
    atlas_list = [] if args.only_folder else atlases()
    if args.folder:
        atlas_list += folder_atlases(args.folder, args.limit)
    rows = [measure_atlas(name, data, args.repeat) for name, data in atlas_list]

    print(
        f"scales {SCALES}; times relative to the codec floor (decode full + encode reduced levels)"
    )
    print(
        f"{'atlas':24s} {'floor ms':>8s} {'careful':>8s} {'auto':>6s} {'always':>6s} | PSNR dB draft (estimate) 1/2 1/4 1/8 | levels auto / careful"
    )
    for r in rows:
        print(
            f"{r['name']:24s} {r['floor'] * 1000:8.1f} {r['never/floor']:8.2f} {r['auto/floor']:6.2f} {r['always/floor']:6.2f} | "
            + " ".join(f"{r[f'draft_{f}']:4.1f} ({r[f'estimate_{f}']:4.1f})" for f in FACTORS)
            + " | "
            f"{' '.join(f'{v:.1f}' for v in r['psnr_auto'])} / {' '.join(f'{v:.1f}' for v in r['psnr_never'])}"
        )
    kinds = {
        "facade": "facade (synthetic, VWorld texel size)",
        "fine": "fine (synthetic close-range facade)",
        "sharp": "sharp (synthetic stress case)",
    }
    kinds["samplegen"] = "samplegen (the project's sample atlases)"
    kinds["tile_"] = f"tile ({args.folder})"
    groups = {"real aerial": [r for r in rows if not r["name"].startswith(tuple(kinds))]}
    groups.update(
        {
            label: [r for r in rows if r["name"].startswith(prefix)]
            for prefix, label in kinds.items()
        }
    )
    print()
    for label, group in groups.items():
        if not group:
            continue
        print(
            f"{label} ({len(group)} atlases, floor {statistics.mean(r['floor'] for r in group) * 1000:.1f} ms per atlas): PSNR min/mean dB vs Lanczos from full, IDCT-scaled decode: "
            + ", ".join(
                f"1/{f} {min(r[f'draft_{f}'] for r in group):.1f}/{statistics.mean(r[f'draft_{f}'] for r in group):.1f}"
                for f in FACTORS
            )
            + "; box filter: "
            + ", ".join(
                f"1/{f} {min(r[f'box_{f}'] for r in group):.1f}/{statistics.mean(r[f'box_{f}'] for r in group):.1f}"
                for f in FACTORS
            )
        )
        agree = ", ".join(
            f"1/{f} {sum((r[f'estimate_{f}'] >= AUTO_MIN_PSNR_DB) == (r[f'draft_{f}'] >= AUTO_MIN_PSNR_DB) for r in group)}/{len(group)} "
            f"(estimate - true {min(r[f'estimate_{f}'] - r[f'draft_{f}'] for r in group):+.1f}..{max(r[f'estimate_{f}'] - r[f'draft_{f}'] for r in group):+.1f} dB)"
            for f in FACTORS
        )
        print(
            f"  auto's estimate on the same side of {AUTO_MIN_PSNR_DB:g} dB as the truth: {agree}"
        )
        for mode in MODES:
            per_level = list(zip(*[r[f"psnr_{mode}"] for r in group]))
            vs_default = list(zip(*[r[f"vs_default_{mode}"] for r in group]))
            print(
                f"  {mode:7s} {statistics.mean(r[mode] for r in group) * 1000:5.1f} ms per atlas; "
                f"time / floor: mean {statistics.mean(r[f'{mode}/floor'] for r in group):.2f}, "
                f"time / careful: mean {statistics.mean(r[f'{mode}/never'] for r in group):.2f}; "
                f"output PSNR min/mean per level: {' '.join(f'{min(v):.1f}/{statistics.mean(v):.1f}' for v in per_level)}; "
                f"vs the default's output min/mean: {' '.join(f'{min(v):.1f}/{statistics.mean(v):.1f}' for v in vs_default)}"
            )
    if not args.only_folder:
        print("\ncache (auto):")
        for label, group in groups.items():
            names = {r["name"] for r in group}
            if group and not label.startswith(("fine", "sharp", "samplegen", "tile")):
                measure_tile(
                    label.split(" (")[0],
                    [a for a in atlas_list if a[0] in names],
                    args.buildings,
                    args.repeat,
                )
    if args.folder:
        cost_breakdown(folder_atlases(args.folder, args.limit), args.repeat)
        lod2_filters(args.folder, folder_atlases(args.folder, args.limit))
    if REAL.is_dir():
        lod2_filters(
            "the real aerial atlases",
            [(path.name, path.read_bytes()) for path in sorted(REAL.glob("*.jpg"))],
        )
    for label, group in groups.items():
        names = {r["name"] for r in group}
        if group:
            check_agreement(label, [a for a in atlas_list if a[0] in names], args.repeat)
    if args.export:
        if args.baseline is None:
            parser.error("--export needs --baseline")
        measure_export(args.export, args.baseline, args.repeat)


if __name__ == "__main__":
    main()
