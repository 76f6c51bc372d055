"""Benchmark of KTX2 (Basis Universal) encoding of texture atlases (issue 35): quality and cost.

For each 1024x1024 JPEG atlas (the real aerial atlases ``tests/data/real/rotterdam_textured/
appearances/*.jpg`` and generated facade atlases of ``exporter.samplegen``), measured with the
encoder behind ``textures.ktx2`` (``alktx2``, Basis Universal; ``pip install 'vworld-lod[ktx2]'``):

- encode seconds (process CPU time, one thread) per codec: ETC1S (``quality`` 128, small files,
  what ``textures.ktx2`` writes) and UASTC (larger, higher quality), both with mipmaps;
- the KTX2's bytes against the JPEG's;
- PSNR (dB, RGB) of the KTX2's decoded level 0 against the JPEG as decoded (the JPEG level is the
  reference: it is what the glTF carries today);
- a JPEG decode + re-encode (Pillow, q90) of the same atlas as the baseline time of the same run.

Run: ``python benchmarks/bench_ktx2.py [--limit 6]``. Prints one line per atlas and codec, and
medians.
"""

from __future__ import annotations

import argparse
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from PIL import Image

REPO = Path(__file__).resolve().parents[1]
REAL = REPO / "tests" / "data" / "real" / "rotterdam_textured" / "appearances"
CODECS = {"etc1s": {"codec": "etc1s", "quality": 128}, "uastc": {"codec": "uastc"}}


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    """PSNR in dB of two (h, w, 3) uint8 images."""
    mse = float(np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else 10 * np.log10(255.0**2 / mse)


def cpu(fn):
    start = time.process_time()
    result = fn()
    return result, time.process_time() - start


def reencode(jpeg: bytes) -> bytes:
    """The baseline: a JPEG decoded and encoded again (Pillow, q90)."""
    out = io.BytesIO()
    with Image.open(io.BytesIO(jpeg)) as image:
        image.convert("RGB").save(out, "JPEG", quality=90)
    return out.getvalue()


def atlases(limit: int) -> list[tuple[str, bytes]]:
    found = [(p.name, p.read_bytes()) for p in sorted(REAL.glob("*.jpg"))[:limit]]
    from exporter.samplegen import generate_tile

    with tempfile.TemporaryDirectory() as tmp:
        folder = generate_tile(Path(tmp) / "tile", max(1, limit // 2), seed=3, atlas_size=1024)
        found += [(f"generated/{p.name}", p.read_bytes()) for p in sorted(folder.glob("*.jpg"))]
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--limit", type=int, default=6, help="real atlases (and half as many generated)"
    )
    args = parser.parse_args(argv)
    try:
        import alktx2
    except ImportError:
        print("the KTX2 encoder is not installed: pip install 'vworld-lod[ktx2]'", file=sys.stderr)
        return 2
    rows: dict[str, list[tuple[float, float, float]]] = {c: [] for c in CODECS}
    baseline = []
    for name, jpeg in atlases(args.limit):
        with Image.open(io.BytesIO(jpeg)) as image:
            reference = np.asarray(image.convert("RGB"))
        if reference.shape[:2] != (1024, 1024):
            continue

        baseline.append(cpu(lambda data=jpeg: reencode(data))[1])
        for codec, options in CODECS.items():
            ktx2, seconds = cpu(
                lambda data=jpeg, given=options: alktx2.encode_bytes_to_ktx2(
                    data, mime="image/jpeg", mipmaps=True, threads=1, **given
                )
            )
            png, _ = alktx2.decode_ktx2_to_bytes(ktx2, format="png")
            with Image.open(io.BytesIO(png)) as decoded:
                quality = psnr(reference, np.asarray(decoded.convert("RGB")))
            ratio = len(ktx2) / len(jpeg)
            rows[codec].append((seconds, ratio, quality))
            print(
                f"{name:32s} {codec:6s} {seconds:6.2f} s  {ratio:5.2f}x JPEG bytes  {quality:5.1f} dB"
            )
    base = statistics.median(baseline)
    print(f"JPEG decode + re-encode (baseline, same run): median {base:.3f} s per atlas")
    for codec, values in rows.items():
        seconds = statistics.median(v[0] for v in values)
        print(
            f"{codec}: median {seconds:.2f} s per 1024^2 atlas ({seconds / base:.0f}x the baseline), "
            f"{statistics.median(v[1] for v in values):.2f}x the JPEG's bytes, "
            f"PSNR median {statistics.median(v[2] for v in values):.1f} dB "
            f"(min {min(v[2] for v in values):.1f}) over {len(values)} atlases"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
