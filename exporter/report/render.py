"""Headless software renderer for the report: a textured, lit view of one building LoD as an RGB image.

No GPU, no display, no system packages: a numpy z-buffer rasteriser, enough for buildings of a
few hundred to a few thousand triangles at a few hundred pixels.

Data form:

- A building level is a list of :class:`Mesh`: ``positions`` (n, 3) float64 in the **building-local
  East/Up/North frame, metres** (x = East, y = Up, z = North; glTF's +X = West is negated on load),
  ``triangles`` (m, 3) int64 wound outward (numerical ``(b - a) x (c - a)`` points out of the
  building), ``uvs`` (n, 2) float64 with the origin at the image's *bottom-left* (trimesh's
  convention; it flips glTF's top-left v on load) or None, ``image`` (h, w, 3) uint8 sRGB or None,
  ``color`` (3,) float32 0..1 (glTF ``baseColorFactor``, multiplied with the texture).
- A :class:`View` is a pinhole camera in the same local frame: ``eye`` (3,) metres, an orthonormal
  basis ``right``/``up``/``forward`` and ``focal`` in pixels. One view is fitted to LOD0 and reused
  for every level so the renders compare like for like.
- Images are (size, size, 3) uint8 RGB.

Shading: Lambert with one fixed sun (``SUN``, from the south-south-west, high) plus ambient, flat
per face, two-sided: a face seen from behind (a floorless model's inside) is lit with its flipped
normal and darkened, so open bottoms read as "inside" rather than as holes. A ground disc at the
building's base with the building's planar shadow anchors it. Texture lookup is bilinear (Unity's
default filter) with perspective-correct UVs (u/w, v/w, 1/w interpolated in screen space); the
image is rendered at ``supersample`` times the size and box-filtered down (anti-aliasing; the
default 1.5 trades smoothness for time).

Sources: the rasterisation follows the edge-function formulation in J. Pineda, "A Parallel Algorithm
for Polygon Rasterization" (SIGGRAPH 1988), walked as one span per pixel row (scan-line order), and
perspective-correct interpolation as in
P. Heckbert & H. Moreton, "Interpolation for Polygon Texture Mapping and Shading" (1991).
Planar shadows: J. Blinn, "Me and My (Fake) Shadow" (IEEE CG&A, 1988).
"""

from __future__ import annotations

import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import trimesh
from PIL import Image

from ..errors import InputError

# Unit direction *towards* the sun in the local East/Up/North frame: from the south-south-west
# (azimuth 200 deg), 50 deg high, so the shadow falls north-north-east, beside the 3/4 view.
SUN = np.array([-0.22, 0.766, -0.60]) / np.linalg.norm([-0.22, 0.766, -0.60])
AMBIENT = 0.38  # share of light that reaches faces turned away from the sun
BACK_FACE_DIM = 0.55  # inside faces (seen through an open bottom or a hole) are darker
# Atlases are sampled at most this many pixels per side: a 256 px thumbnail cannot show more, and
# decoding full 1024-4096 px atlases would dominate the report's time.
MAX_TEXTURE_SIDE = 512
BACKGROUND = np.array([0.96, 0.96, 0.97], dtype=np.float32)
GROUND = np.array([0.82, 0.84, 0.80], dtype=np.float32)
SHADOW = np.array([0.62, 0.64, 0.61], dtype=np.float32)


@dataclass
class Mesh:
    """One material's triangles of a building level (see the module doc for frames and shapes)."""

    positions: np.ndarray
    triangles: np.ndarray
    uvs: np.ndarray | None = None
    image: np.ndarray | None = None
    color: np.ndarray = field(default_factory=lambda: np.ones(3, dtype=np.float32))


@dataclass
class View:
    """Pinhole camera in the local East/Up/North frame: ``eye`` in metres, unit basis vectors,
    ``focal`` in pixels of a ``size`` x ``size`` image, ``shift`` (2,) the principal point's offset
    from the image centre in pixels (x right, y down); ``ground`` is the base height (metres, Up),
    ``ground_center`` (3,) and ``ground_reach`` (metres) the ground disc drawn under the building."""

    eye: np.ndarray
    right: np.ndarray
    up: np.ndarray
    forward: np.ndarray
    focal: float
    size: int
    ground: float
    ground_center: np.ndarray
    ground_reach: float
    shift: np.ndarray = field(default_factory=lambda: np.zeros(2))


# --------------------------------------------------------------------------- loading


def _image_array(material, max_side: int = MAX_TEXTURE_SIDE) -> np.ndarray | None:
    """The material's base colour texture as (h, w, 3) uint8, decoded at reduced size when larger
    than ``max_side`` pixels (JPEG: DCT scaling while decoding; others: integer box reduction)."""
    texture = getattr(material, "baseColorTexture", None)
    if texture is None:
        texture = getattr(material, "image", None)
    if texture is None:
        return None
    if max(texture.size) > max_side:
        if hasattr(texture, "draft") and texture.format == "JPEG":
            texture.draft("RGB", (max_side, max_side))  # lazy image: the decode below is reduced
        texture = texture.convert("RGB")
        factor = max(texture.size) // max_side
        if factor > 1:
            texture = texture.reduce(factor)
    return np.asarray(texture.convert("RGB"), dtype=np.uint8)


def _base_color(material) -> np.ndarray:
    """glTF ``baseColorFactor`` RGB as (3,) float32 0..1 (trimesh keeps it as uint8 0..255)."""
    factor = getattr(material, "baseColorFactor", None)
    if factor is None:
        factor = getattr(material, "main_color", None)
    if factor is None:
        return np.ones(3, dtype=np.float32)
    factor = np.asarray(factor)[:3]
    scale = 255.0 if np.issubdtype(factor.dtype, np.integer) else 1.0
    return (factor.astype(np.float32) / scale).astype(np.float32)


def load_glb(path: str | Path) -> list[Mesh]:
    """Read a ``.glb`` (glTF frame: +X = West, +Y = Up, +Z = North, metres) into meshes in the local
    East/Up/North frame, node transforms applied. Raises InputError naming the file when it cannot
    be read or holds no triangles."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: file missing")
    try:
        scene: Any = trimesh.load(str(path), file_type="glb", force="scene", process=False)

    except Exception as error:  # trimesh raises many types for a broken file
        raise InputError(
            f"{path}: cannot be read as glTF binary ({type(error).__name__}: {error})"
        ) from None
    meshes = []
    for node in scene.graph.nodes_geometry:
        transform, name = scene.graph[node]
        geometry = scene.geometry[name]
        if not isinstance(geometry, trimesh.Trimesh) or len(geometry.faces) == 0:
            continue
        positions = trimesh.transform_points(
            np.asarray(geometry.vertices, dtype=np.float64), transform
        )
        # glTF -> local: negate X (West -> East); reversing the triangles keeps them wound outward.
        positions[:, 0] *= -1.0
        triangles = np.asarray(geometry.faces, dtype=np.int64)[:, ::-1]
        visual = geometry.visual
        material = getattr(visual, "material", None)
        uvs = getattr(visual, "uv", None)
        image = _image_array(material) if material is not None else None
        if uvs is None or image is None or len(uvs) != len(positions):
            uvs, image = None, None
        color = _base_color(material) if material is not None else np.ones(3, dtype=np.float32)
        meshes.append(
            Mesh(
                positions,
                triangles,
                None if uvs is None else np.asarray(uvs, dtype=np.float64),
                image,
                color,
            )
        )
    if not meshes:
        raise InputError(f"{path}: holds no triangle meshes")
    return meshes


# --------------------------------------------------------------------------- camera


def fit_view(
    meshes: list[Mesh],
    size: int = 256,
    azimuth_deg: float = 135.0,
    elevation_deg: float = 32.0,
    fov_deg: float = 30.0,
    fill: float = 0.9,
) -> View:
    """A 3/4 view from above whose image ``fill`` share (per side) is the building's projection.

    ``azimuth_deg`` is the compass direction the camera stands in, seen from the building (0 =
    North, 90 = East, clockwise); ``elevation_deg`` its angle above the horizon; ``size`` in pixels.
    The camera stands outside the bounding sphere (every point in front of it); then the focal
    length and the principal point are set so the projected points span ``fill`` of the image
    and sit in its middle (a tall tower fills the height, a long slab the width).
    """
    points = np.concatenate([m.positions for m in meshes])
    low, high = points.min(axis=0), points.max(axis=0)
    center = (low + high) / 2.0
    radius = max(float(np.linalg.norm(high - low)) / 2.0, 1e-3)
    azimuth, elevation = np.radians(azimuth_deg), np.radians(elevation_deg)
    # Direction from the building to the camera in East/Up/North.
    back = np.array(
        [
            np.cos(elevation) * np.sin(azimuth),
            np.sin(elevation),
            np.cos(elevation) * np.cos(azimuth),
        ]
    )
    half_fov = np.radians(fov_deg) / 2.0
    distance = radius / np.sin(half_fov) * 1.08
    forward = -back
    # East appears to the right when looking North: right = (f_z, 0, -f_x) in this left-handed frame.
    right = np.array([forward[2], 0.0, -forward[0]])
    right /= np.linalg.norm(right)
    up = np.array([0.0, 1.0, 0.0]) - forward * forward[1]
    up /= np.linalg.norm(up)
    eye = center + back * distance
    # Normalised image coordinates (x right, y down) of every point, then zoom and centre on them.
    relative = points - eye
    depth = relative @ forward
    x, y = relative @ right / depth, -(relative @ up) / depth
    extent = max(float(np.ptp(x)), float(np.ptp(y)), 1e-9)
    focal = fill * size / extent
    shift = -np.array([x.min() + x.max(), y.min() + y.max()]) / 2.0 * focal
    reach = float(np.hypot(high[0] - low[0], high[2] - low[2])) * 0.75  # metres: past the shadow
    return View(
        eye, right, up, forward, float(focal), int(size), float(low[1]), center, reach, shift
    )


def project(points: np.ndarray, view: View, size: int) -> np.ndarray:
    """(n, 3) local metres -> (n, 3) of pixel x, pixel y (row, down), camera depth in metres, in an
    image of ``size`` pixels (a multiple of ``view.size`` when supersampling)."""
    relative = points - view.eye
    depth = relative @ view.forward
    scale = size / view.size
    x = (
        size / 2.0
        + (view.shift[0] + (relative @ view.right) * view.focal / np.maximum(depth, 1e-6)) * scale
    )
    y = (
        size / 2.0
        + (view.shift[1] - (relative @ view.up) * view.focal / np.maximum(depth, 1e-6)) * scale
    )
    return np.stack([x, y, depth], axis=1)


# --------------------------------------------------------------------------- shading


def face_shading(positions: np.ndarray, triangles: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """(m,) float32 Lambert brightness per face, two-sided (back faces flipped and dimmed)."""
    a, b, c = (positions[triangles[:, i]] for i in range(3))
    normals = np.cross(b - a, c - a)
    normals /= np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
    facing = np.einsum("ij,ij->i", normals, eye - (a + b + c) / 3.0) >= 0.0
    normals[~facing] *= -1.0
    light = AMBIENT + (1.0 - AMBIENT) * np.clip(normals @ SUN, 0.0, 1.0)
    return np.where(facing, light, light * BACK_FACE_DIM).astype(np.float32)


def shadow_triangles(positions: np.ndarray, ground: float) -> np.ndarray:
    """Project (n, 3) local points onto the plane Up = ``ground`` along the sun direction."""
    lift = np.maximum(positions[:, 1] - ground, 0.0)
    shadow = positions - np.outer(lift / SUN[1], SUN)
    shadow[:, 1] = ground
    return shadow


# --------------------------------------------------------------------------- rasterising

FRAGMENT_CHUNK = 1 << 20  # pixels handled per numpy batch (bounded memory)
ROW_CHUNK = 1 << 18  # triangle rows handled per batch
NEAR = 1e-3  # metres: triangles with a corner closer to the camera plane than this are not drawn


def _expand(counts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For (n,) non-negative counts: (sum,) owner index and (sum,) position within its owner."""
    owner = np.repeat(np.arange(len(counts)), counts)
    first = np.repeat(np.cumsum(counts) - counts, counts)
    return owner, np.arange(len(owner)) - first


def fragments(screen: np.ndarray, triangles: np.ndarray, size: int):
    """Yield the covered pixels of all triangles, in batches, vectorised over triangles.

    ``screen`` (n, 3) projected points (pixel x, pixel y, depth); ``triangles`` (m, 3). Yields
    ``(rows, cols, faces, weights)``: (k,) pixel row and column, (k,) triangle index, (k, 3)
    screen-space barycentric weights of the pixel centre. A pixel belongs to a triangle when its
    centre is inside (all three edge functions >= 0); top-left ties are not resolved, which only
    matters for depth-equal overlaps. Work follows the covered pixels, not the bounding boxes:
    each triangle is cut into one span per pixel row (long thin triangles of retriangulated
    walls would otherwise cost their whole bounding box).
    """
    corners = screen[triangles][:, :, :2].astype(np.float64)  # (m, 3, 2)
    low = np.maximum(np.floor(corners.min(axis=1)).astype(np.int64), 0)
    high = np.minimum(np.ceil(corners.max(axis=1)).astype(np.int64) + 1, size)
    (x0, y0), (x1, y1), (x2, y2) = (corners[:, i].T for i in range(3))
    area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0)
    # Skip degenerate triangles and any reaching behind the camera (a spike of a broken level):
    # their screen positions are meaningless, the rest of the building still draws.
    valid = (
        (np.abs(area) > 1e-9)
        & (screen[triangles][:, :, 2] > NEAR).all(axis=1)
        & (high > low).all(axis=1)
    )
    area = np.where(valid, area, 1.0)
    # Edge functions (barycentric weights) are affine in the pixel centre: w_i = a_i x + b_i y + c_i,
    # edge i opposite corner i. Shapes (m, 3).
    a = np.stack([y1 - y2, y2 - y0, y0 - y1], axis=1) / area[:, None]
    b = np.stack([x2 - x1, x0 - x2, x1 - x0], axis=1) / area[:, None]
    c = np.stack([x1 * y2 - x2 * y1, x2 * y0 - x0 * y2, x0 * y1 - x1 * y0], axis=1) / area[:, None]
    heights = np.where(valid, high[:, 1] - low[:, 1], 0)
    for batch in _batches(heights, ROW_CHUNK):
        yield from _span_fragments(batch, heights[batch], low, high, a, b, c, size)


def _batches(counts: np.ndarray, limit: int):
    """Consecutive index arrays over the non-zero ``counts`` holding about ``limit`` in total each."""
    order = np.flatnonzero(counts)
    start = 0
    while start < len(order):
        stop = start + max(
            1, int(np.searchsorted(np.cumsum(counts[order[start:]]), limit, side="right"))
        )
        yield order[start:stop]
        start = stop


def _span_fragments(triangles: np.ndarray, heights: np.ndarray, low, high, a, b, c, size: int):
    """Fragments of the given triangle indices (see :func:`fragments`), one span per pixel row:
    the columns whose centre satisfies all three w_i >= 0."""
    owner, dy = _expand(heights)
    faces = triangles[owner]
    y = (low[faces, 1] + dy) + 0.5
    d = b[faces] * y[:, None] + c[faces]  # w_i = a_i x + d_i on this row
    slope = a[faces]
    with np.errstate(divide="ignore", invalid="ignore"):
        bound = -d / slope
    x_min = np.where(slope > 0, bound, -np.inf).max(axis=1)
    x_max = np.where(slope < 0, bound, np.inf).min(axis=1)
    empty = ((slope == 0) & (d < 0)).any(axis=1)
    first = np.maximum(np.ceil(np.nan_to_num(x_min - 0.5, neginf=-1.0)), low[faces, 0]).astype(
        np.int64
    )
    last = np.minimum(np.floor(np.nan_to_num(x_max - 0.5, posinf=size)), high[faces, 0] - 1).astype(
        np.int64
    )
    counts = np.where(empty, 0, np.maximum(last - first + 1, 0))
    for spans in _batches(counts, FRAGMENT_CHUNK):
        span_of, dx = _expand(counts[spans])
        span = spans[span_of]
        face = faces[span]
        cols = first[span] + dx
        xs, ys = cols + 0.5, y[span]
        w0 = a[face, 0] * xs + b[face, 0] * ys + c[face, 0]
        w1 = a[face, 1] * xs + b[face, 1] * ys + c[face, 1]
        weights = np.column_stack([w0, w1, 1.0 - w0 - w1]).astype(np.float32)
        yield (ys - 0.5).astype(np.int64), cols, face, weights


def fill_flat(
    canvas: np.ndarray, screen: np.ndarray, triangles: np.ndarray, color: np.ndarray
) -> None:
    """Paint triangles (no depth test) of (n, 3) screen points in one colour onto (h, w, 3) canvas."""
    for rows, cols, _, _ in fragments(screen, triangles, canvas.shape[0]):
        canvas[rows, cols] = color


def nearest_per_pixel(pixels: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Indices of the nearest fragment (smallest positive ``z``) for every distinct value in ``pixels``.

    One integer sort: positive float32 depths keep their order as uint32 bit patterns, so
    ``pixel << 32 | bits(z)`` sorts by pixel, then depth."""
    key = (pixels.astype(np.uint64) << np.uint64(32)) | z.astype(np.float32).view(np.uint32).astype(
        np.uint64
    )
    order = np.argsort(key)
    sorted_pixels = pixels[order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = sorted_pixels[1:] != sorted_pixels[:-1]
    return order[first]


def sample_bilinear(image: np.ndarray, texel: np.ndarray) -> np.ndarray:
    """Bilinear lookup of (k, 2) texel coordinates (x right, y down, in pixels; pixel centres at
    +0.5) in an (h, w, 3) uint8 image, wrapping like glTF's default REPEAT sampler; (k, 3) float32."""
    height, width = image.shape[:2]
    x, y = texel[:, 0] - 0.5, texel[:, 1] - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None].astype(np.float32), (y - y0)[:, None].astype(np.float32)
    c0, r0 = np.mod(x0.astype(np.int64), width), np.mod(y0.astype(np.int64), height)
    c1, r1 = np.mod(c0 + 1, width), np.mod(r0 + 1, height)
    top = image[r0, c0] * (1.0 - fx) + image[r0, c1] * fx
    bottom = image[r1, c0] * (1.0 - fx) + image[r1, c1] * fx
    return (top * (1.0 - fy) + bottom * fy).astype(np.float32)


def fill_mesh(
    canvas: np.ndarray, depth: np.ndarray, screen: np.ndarray, mesh: Mesh, shading: np.ndarray
) -> None:
    """Z-buffered, textured, flat-lit triangles of one mesh; ``screen`` is its (n, 3) projection."""
    size = canvas.shape[0]
    inverse_depth = (1.0 / np.maximum(screen[:, 2], 1e-6)).astype(np.float32)
    textured = mesh.image is not None and mesh.uvs is not None
    if textured:
        assert mesh.image is not None and mesh.uvs is not None
        height, width = mesh.image.shape[:2]
        # Texel coordinates: u to the right, v up from the bottom row (trimesh's convention).
        texels = np.stack([mesh.uvs[:, 0] * width, (1.0 - mesh.uvs[:, 1]) * height], axis=1).astype(
            np.float32
        )
    for rows, cols, faces, weights in fragments(screen, mesh.triangles, size):
        corners = mesh.triangles[faces]  # (k, 3)
        perspective = weights * inverse_depth[corners]
        one_over_z = perspective[:, 0] + perspective[:, 1] + perspective[:, 2]
        z = 1.0 / one_over_z
        keep = nearest_per_pixel(rows * size + cols, z)
        keep = keep[z[keep] < depth[rows[keep], cols[keep]]]
        if len(keep) == 0:
            continue
        rows, cols, faces, z = rows[keep], cols[keep], faces[keep], z[keep]
        if textured:
            assert mesh.image is not None
            texel = (
                np.einsum("ki,kij->kj", perspective[keep], texels[corners[keep]])
                / one_over_z[keep, None]
            )
            colors = sample_bilinear(mesh.image, texel) * (mesh.color / 255.0)
        else:
            colors = np.broadcast_to(mesh.color, (len(z), 3))
        depth[rows, cols] = z
        canvas[rows, cols] = colors * shading[faces, None]


def backdrop(view: View, supersample: float = 1.5) -> np.ndarray:
    """The (s, s, 3) float32 background of every level's render, s = size x supersample: a ground
    disc (radius ``view.ground_reach`` metres around ``view.ground_center``, at Up = ``view.ground``)
    found by casting one ray per pixel. The camera is above the ground, so the building always
    covers it. Computed once per building and reused for each level."""
    size = int(round(view.size * supersample))
    canvas = np.empty((size, size, 3), dtype=np.float32)
    canvas[:] = BACKGROUND
    scale = size / view.size
    pixels = np.arange(size, dtype=np.float64) + 0.5 - size / 2.0
    across = (pixels / scale - view.shift[0]) / view.focal  # per column: x / depth
    down = (pixels / scale - view.shift[1]) / view.focal  # per row: y / depth (y down)
    # Ray direction per pixel = forward + across right - down up, kept separable (rows x columns).
    up_component = view.forward[1] - down[:, None] * view.up[1] + across[None, :] * view.right[1]
    with np.errstate(divide="ignore", invalid="ignore"):
        distance = (view.ground - view.eye[1]) / up_component
    hit_x = view.eye[0] + distance * (
        view.forward[0] - down[:, None] * view.up[0] + across[None, :] * view.right[0]
    )
    hit_z = view.eye[2] + distance * (
        view.forward[2] - down[:, None] * view.up[2] + across[None, :] * view.right[2]
    )
    center = view.ground_center
    on_disc = (distance > 0.0) & (
        (hit_x - center[0]) ** 2 + (hit_z - center[2]) ** 2 <= view.ground_reach**2
    )
    canvas[on_disc] = GROUND
    return canvas


# --------------------------------------------------------------------------- entry point


def render(
    meshes: list[Mesh],
    view: View,
    supersample: float = 1.5,
    background: np.ndarray | None = None,
) -> np.ndarray:
    """Render ``meshes`` (local East/Up/North, metres) seen from ``view`` into a (size, size, 3)
    uint8 RGB image: ground disc, the building's sun shadow, then the lit building.
    ``background`` is :func:`backdrop` of the same view and supersample (computed when None)."""
    size = int(round(view.size * supersample))
    canvas = backdrop(view, supersample) if background is None else background.copy()
    if canvas.shape[:2] != (size, size):
        raise ValueError(f"background is {canvas.shape[:2]}, the render needs {(size, size)}")
    depth = np.full((size, size), np.inf, dtype=np.float32)
    for mesh in meshes:
        fill_flat(
            canvas,
            project(shadow_triangles(mesh.positions, view.ground), view, size),
            mesh.triangles,
            SHADOW,
        )
    for mesh in meshes:
        fill_mesh(
            canvas,
            depth,
            project(mesh.positions, view, size),
            mesh,
            face_shading(mesh.positions, mesh.triangles, view.eye),
        )
    image = (np.clip(canvas, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if size != view.size:
        image = np.asarray(
            Image.fromarray(image, "RGB").resize((view.size, view.size), Image.Resampling.BOX)
        )
    return image


def png_bytes(image: np.ndarray) -> bytes:
    """A (h, w, 3) uint8 RGB image encoded as PNG (light compression: thumbnails, written often)."""
    buffer = io.BytesIO()
    Image.fromarray(image, "RGB").save(buffer, format="PNG", compress_level=3)
    return buffer.getvalue()
