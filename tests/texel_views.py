"""Views of one building for CesiumJS (tests/tileset_client/render.js, POSES mode): a camera
path towards the centre of a building's south face, the client's run, and the on-surface texel
size of a content file. Shared by tests/test_tileset_client.py and
benchmarks/bench_texel_path.py.

Frames: positions and directions are ECEF metres / unit vectors (EPSG:4978); a building's box is
its LOD0 ``gltf_bounds`` (glTF frame: +X West, +Y Up, +Z North, metres) around its manifest
centre.
"""

from __future__ import annotations

import io
import json
import math
import os
import subprocess
import tempfile
from pathlib import Path

import numpy as np
from PIL import Image

from exporter.texel import level_texel_m
from exporter.tileset.frames import enu_to_ecef
from exporter.tileset.glb import read_primitives

CLIENT = Path(__file__).resolve().parent / "tileset_client"
ELEVATION = math.radians(20.0)  # the camera above the aimed point, seen from it
# CesiumJS's default field of view: 60 degrees across the *larger* side of the canvas
# (PerspectiveFrustum: fovy = 2 atan(tan(fov / 2) / aspect) when wider than high), so on a 16:9
# canvas the vertical one is 36 degrees, not 60.
CESIUM_FOV = math.radians(60.0)


def screen_px(metres: float, distance: float, width: int, height: int) -> float:
    """Pixels that ``metres`` facing the camera cover at ``distance`` metres in CesiumJS's
    default view on a ``width`` x ``height`` canvas: the rule its screen-space error uses
    (``error * height / (distance * 2 tan(fovy / 2))``, Cesium3DTile.getScreenSpaceError)."""
    aspect = width / height
    fovy = CESIUM_FOV if aspect <= 1 else 2.0 * math.atan(math.tan(CESIUM_FOV / 2) / aspect)
    return metres * height / (distance * 2.0 * math.tan(fovy / 2))


def target_building(out: Path) -> tuple[str, dict]:
    """(URI prefix ``tile/folder/``, manifest record) of the textured building nearest the centre
    of its tile's buildings."""
    candidates = []
    for manifest in sorted(out.glob("*/lod_manifest.json")):
        buildings = json.loads(manifest.read_text())["buildings"]
        centres = np.array([[b["center"]["lon"], b["center"]["lat"]] for b in buildings])
        middle = centres.mean(axis=0)
        for building, centre in zip(buildings, centres):
            if building["lods"][0]["texture_size"][0]:
                offset = float(np.hypot(*(centre - middle)))
                candidates.append((offset, manifest.parent.name, building))
    if not candidates:
        raise SystemExit(f"{out}: no textured building")
    _, tile, building = min(candidates, key=lambda c: c[0])
    return f"{tile}/{building['folder']}/", building


def camera_path(
    building: dict, frames: int, first: float = 3000.0, last: float = 15.0
) -> list[tuple[float, dict]]:
    """(distance m, CesiumJS view: ECEF position, unit direction and up) per frame, ``first`` to
    ``last`` metres (evenly on a log scale) from the centre of the manifest ``building``'s south
    face, looking north at it from 20 degrees above."""
    centre = building["center"]
    bounds = building["lods"][0]["gltf_bounds"]
    low, high = np.array(bounds["low"]), np.array(bounds["high"])
    # glTF (+X West, +Y Up, +Z North) -> East/North/Up metres at the building's centre.
    west, up, north = (low[0] + high[0]) / 2, (low[1] + high[1]) / 2, low[2]
    enu = enu_to_ecef(centre["lon"], centre["lat"], centre["elev"])
    aimed = (enu @ np.array([-west, north, up, 1.0]))[:3]
    north_axis, up_axis = enu[:3, 1], enu[:3, 2]
    towards = north_axis * math.cos(ELEVATION) - up_axis * math.sin(ELEVATION)  # camera -> face
    above = north_axis * math.sin(ELEVATION) + up_axis * math.cos(ELEVATION)
    path = []
    for k in range(frames):
        distance = first * (last / first) ** (k / max(frames - 1, 1))
        position = aimed - towards * distance
        view = {"position": position.tolist(), "direction": towards.tolist(), "up": above.tolist()}
        path.append((distance, view))
    return path


def content_texel(path: Path) -> float | None:
    """Metres per texel of a content file on its surface (exporter.texel.level_texel_m over its
    textured primitives; sizes from the images themselves)."""
    pieces = []
    for primitive in read_primitives(path):
        if primitive.uvs is None or primitive.image is None:
            continue
        size = Image.open(io.BytesIO(primitive.image)).size
        pieces.append((primitive.positions, primitive.triangles, primitive.uvs, size))
    return level_texel_m(pieces)


def fly(out: Path, target: str, path: list, width: int, height: int, name: str) -> list[dict]:
    """CesiumJS's views of ``out/name`` (render.js POSES mode), one dict per view."""
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as handle:
        json.dump({"width": width, "height": height, "target": target, "tileset": name,
                   "views": [view for _, view in path]}, handle)  # fmt: skip
    try:
        result = subprocess.run(
            ["node", str(CLIENT / "render.js"), str(out)],
            env=dict(os.environ, POSES=handle.name), capture_output=True, text=True, timeout=3600,
        )  # fmt: skip
    finally:
        os.unlink(handle.name)
    lines = [json.loads(line) for line in result.stdout.splitlines() if line.startswith("{")]
    if len(lines) != len(path) or any("fatal" in line for line in lines):
        raise SystemExit(
            f"CesiumJS failed on {out}: {result.stdout[-2000:]}{result.stderr[-2000:]}"
        )
    return lines
