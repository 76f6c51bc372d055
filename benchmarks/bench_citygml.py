"""CityGML reader throughput and memory against file size: MB/s and peak RSS of scan + load of
every building, on generated files of ``--mb`` and 10 x ``--mb`` megabytes.

Usage: ``python benchmarks/bench_citygml.py [--mb 20] [--factor 10]``. Each file holds
textureless LoD2 boxes (6 thematic polygons, ground included, CityGML 2.0, EPSG:25832) written
into a temporary folder; each size is read in a fresh process (scan, then every building loaded
in file order, as one pipeline worker does) reporting its wall seconds and ``ru_maxrss``, after
timing the bare XML parse (the reader's own ``stream``, nothing built) as the floor. Prints
MB/s per size and the ratio to that floor, peak RSS, its growth over the interpreter with the
reader imported, and the ratio of the large file's peak to the small one's (the issue asks for
<= 1.5 at 10 x the size).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

X0, Y0 = 458000.0, 5438000.0  # EPSG:25832 metres


def _box(i: int) -> str:
    """One building: a 6 x 5 x (4..10) m box on a 100-column grid, 6 thematic polygons."""
    x0, y0, z0 = X0 + (i % 100) * 12.0, Y0 + (i // 100) * 12.0, 100.0
    x1, y1, z1 = x0 + 6.0, y0 + 5.0, z0 + 4.0 + (i % 7)
    faces = [
        ("GroundSurface", [(x0, y0, z0), (x0, y1, z0), (x1, y1, z0), (x1, y0, z0)]),
        ("RoofSurface", [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)]),
        ("WallSurface", [(x0, y0, z0), (x1, y0, z0), (x1, y0, z1), (x0, y0, z1)]),
        ("WallSurface", [(x1, y0, z0), (x1, y1, z0), (x1, y1, z1), (x1, y0, z1)]),
        ("WallSurface", [(x1, y1, z0), (x0, y1, z0), (x0, y1, z1), (x1, y1, z1)]),
        ("WallSurface", [(x0, y1, z0), (x0, y0, z0), (x0, y0, z1), (x0, y1, z1)]),
    ]
    body = []
    for k, (kind, ring) in enumerate(faces):
        pos = " ".join(f"{v:.3f}" for p in [*ring, ring[0]] for v in p)
        body.append(
            f"<bldg:boundedBy><bldg:{kind}><bldg:lod2MultiSurface><gml:MultiSurface>"
            f'<gml:surfaceMember><gml:Polygon gml:id="b{i}_p{k}"><gml:exterior><gml:LinearRing>'
            f"<gml:posList>{pos}</gml:posList></gml:LinearRing></gml:exterior></gml:Polygon>"
            f"</gml:surfaceMember></gml:MultiSurface></bldg:lod2MultiSurface></bldg:{kind}>"
            "</bldg:boundedBy>\n"
        )
    return (
        f'<cityObjectMember><bldg:Building gml:id="b{i}"><gml:name>b{i}</gml:name>'
        f'<bldg:measuredHeight uom="m">{z1 - z0}</bldg:measuredHeight>\n{"".join(body)}'
        "</bldg:Building></cityObjectMember>\n"
    )


def generate(path: Path, megabytes: float) -> int:
    """Write a CityGML file of about ``megabytes`` MB; returns its building count."""
    limit = int(megabytes * 1e6)
    with path.open("w", encoding="utf-8") as out:
        out.write(
            '<?xml version="1.0" encoding="UTF-8"?>\n<CityModel '
            'xmlns="http://www.opengis.net/citygml/2.0" '
            'xmlns:bldg="http://www.opengis.net/citygml/building/2.0" '
            'xmlns:gml="http://www.opengis.net/gml">\n<gml:boundedBy><gml:Envelope '
            'srsName="urn:ogc:def:crs,crs:EPSG::25832,crs:EPSG::5783" srsDimension="3">'
            "<gml:lowerCorner>0 0 0</gml:lowerCorner><gml:upperCorner>1 1 1</gml:upperCorner>"
            "</gml:Envelope></gml:boundedBy>\n"
        )
        count = 0
        while out.tell() < limit:
            out.write(_box(count))
            count += 1
        out.write("</CityModel>\n")
    return count


CHILD = r"""
import json, resource, sys, time
from exporter.config import ReaderOptions
from exporter.readers import load_entry, scan_folder
from exporter.readers.citygml import stream
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
start = time.perf_counter()
for _ in stream(__import__("pathlib").Path(sys.argv[1])):  # the XML parse alone: the floor
    pass
floor = time.perf_counter() - start
options = ReaderOptions()
start = time.perf_counter()
scan = scan_folder(sys.argv[1], options)
scanned = time.perf_counter()
triangles = sum(load_entry(entry, options).triangle_count for entry in scan.entries)
done = time.perf_counter()
print(json.dumps({"buildings": len(scan.entries), "triangles": triangles,
                  "scan_s": scanned - start, "load_s": done - scanned, "parse_s": floor,
                  "base_kb": base, "peak_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss}))
"""


def measure(path: Path) -> dict:
    result = subprocess.run(
        [sys.executable, "-c", CHILD, str(path)], capture_output=True, text=True, check=True
    )
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mb", type=float, default=20.0, help="size of the small file, MB")
    parser.add_argument("--factor", type=float, default=10.0, help="large file = factor x small")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="bench_citygml_") as folder:
        rows = []
        for megabytes in (args.mb, args.mb * args.factor):
            path = Path(folder) / f"city_{megabytes:g}mb.gml"
            count = generate(path, megabytes)
            size = path.stat().st_size / 1e6
            row = measure(path)
            row.update(mb=size, generated=count)
            rows.append(row)
            seconds = row["scan_s"] + row["load_s"]
            print(
                f"{size:8.1f} MB  {row['buildings']:7d} buildings  {row['triangles']:8d} triangles  "
                f"parse alone {size / row['parse_s']:5.1f} MB/s  scan {size / row['scan_s']:5.1f} MB/s  "
                f"scan+load {size / seconds:5.1f} MB/s ({seconds / row['parse_s']:.0f}x the parse)  "
                f"peak {row['peak_kb'] / 1024:6.1f} MB (+{(row['peak_kb'] - row['base_kb']) / 1024:.1f} over imports)",
                flush=True,
            )
            path.unlink()
        small, large = rows
        print(
            f"peak RSS ratio at {args.factor:g}x the size: {large['peak_kb'] / small['peak_kb']:.2f}x "
            f"(growth over imports {(large['peak_kb'] - large['base_kb']) / max(1, small['peak_kb'] - small['base_kb']):.2f}x)"
        )


if __name__ == "__main__":
    main()
