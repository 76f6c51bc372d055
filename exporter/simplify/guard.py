"""The error guard: how far a simplified mesh strays from the source (symmetric, sampled).

Data form: meshes as ``(positions (k, 3) float64 metres, faces (m, 3) int64)`` in the
building-local East/Up/North frame. Distances are exact point-to-triangle distances
(:class:`exporter.quality.SurfaceIndex`) from every vertex plus ``SAMPLES`` area-weighted points
(fixed seed) of each side to the other side's surface.

Quadric collapse ranks collapses by error but has no error bound in pymeshlab; the guard adds
one: a level is accepted only when this deviation stays below ``max_error`` x the source's
bounding-box diagonal, otherwise the level's target is raised by bisection. The simplifier asks
:func:`exceeds` (the decision only, with less work); :func:`deviation` gives the distance.

The reference side (LOD0: its probe points, its surface index, the generator state after its
samples) is prepared once per building (:class:`Reference`) and shared by every level and every
bisection step.
"""

from __future__ import annotations

import numpy as np

from ..quality import SurfaceIndex, sample_surface

SAMPLES = 96
SEED = 7


class Reference:
    """The guard's reference mesh ``(positions (k, 3) metres, faces (m, 3))``, prepared once."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray) -> None:
        self.positions, self.faces = positions, faces
        self._points: np.ndarray | None = None
        self._rng_after: np.random.Generator | None = None
        self._index: SurfaceIndex | None = None

    def _sample(self) -> None:
        # Lazily: most buildings never run the guard (the planar pass alone meets the targets).
        rng = np.random.default_rng(SEED)
        corners = self.positions[np.unique(self.faces)]
        self._corner_count = len(corners)
        self._points = np.vstack(
            [corners, sample_surface(self.positions, self.faces, SAMPLES, rng)]
        )
        self._rng_after = rng  # the level's samples continue this stream

    @property
    def points(self) -> np.ndarray:
        """(p, 3) metres: the reference's vertices and its ``SAMPLES`` surface samples."""
        if self._points is None:
            self._sample()
        assert self._points is not None
        return self._points

    @property
    def corners(self) -> np.ndarray:
        """(c, 3) metres: the reference's vertices used by a face (the first rows of ``points``)."""
        return self.points[: self._corner_count]

    @property
    def rng_after(self) -> np.random.Generator:
        """The generator state after the reference's samples."""
        if self._rng_after is None:
            self._sample()
        assert self._rng_after is not None
        return self._rng_after

    @property
    def index(self) -> SurfaceIndex:
        if self._index is None:
            self._index = SurfaceIndex(self.positions, self.faces)
        return self._index


def _resume(rng: np.random.Generator) -> np.random.Generator:
    """A new generator continuing ``rng``'s stream from its current state (``copy.deepcopy``'s
    stream, without its pickling round trip)."""
    bit_generator = type(rng.bit_generator)(0)
    bit_generator.state = rng.bit_generator.state
    return np.random.Generator(bit_generator)


def deviation(reference, positions: np.ndarray, faces: np.ndarray) -> float:
    """Symmetric sampled Hausdorff distance (metres) between ``reference`` (a :class:`Reference`
    or a ``(positions, faces)`` pair) and ``(positions, faces)``."""
    if not isinstance(reference, Reference):
        reference = Reference(*reference)
    if len(faces) == 0:
        return float("inf")
    rng = _resume(reference.rng_after)
    backward = np.vstack(
        [positions[np.unique(faces)], sample_surface(positions, faces, SAMPLES, rng)]
    )
    # Exact maxima: only the largest upper bounds are refined (same value as every exact distance).
    return max(
        SurfaceIndex(positions, faces).max_distance(reference.points),
        reference.index.max_distance(backward),
    )


def exceeds(
    reference: Reference, positions: np.ndarray, faces: np.ndarray, tolerance: float
) -> bool:
    """``deviation(reference, positions, faces) > tolerance`` (metres), decided with less work:
    each direction's maximum is taken with ``tolerance`` as its floor (points whose nearest probe
    is within it are not refined; :meth:`~exporter.quality.SurfaceIndex.max_distance` returns
    max(floor, exact maximum), so it exceeds the floor exactly when the exact maximum does), and
    the level's own surface index is built only when the level's points stay within it."""
    if len(faces) == 0:
        return True
    rng = _resume(reference.rng_after)
    corners = positions[np.unique(faces)]
    backward = np.vstack([corners, sample_surface(positions, faces, SAMPLES, rng)])
    # A point equal to a corner of the other side is on its surface (distance 0, never above the
    # floor): only the others are looked up (most vertices are kept from LOD0).
    if (
        reference.index.max_distance(backward[_off(backward, reference.corners)], floor=tolerance)
        > tolerance
    ):
        return True
    forward = reference.points[_off(reference.points, corners)]
    return (
        len(forward) > 0
        and SurfaceIndex(positions, faces).max_distance(forward, floor=tolerance) > tolerance
    )


def _off(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """(p,) bool: the points (p, 3) metres not bit for bit equal to any of ``corners`` (c, 3)."""
    row = np.dtype((np.void, 3 * points.dtype.itemsize))
    return ~np.isin(
        np.ascontiguousarray(points).view(row).reshape(-1),
        np.ascontiguousarray(corners, dtype=points.dtype).view(row).reshape(-1),
    )


def diagonal(positions: np.ndarray) -> float:
    """Bounding-box diagonal, metres."""
    return (
        float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0)))
        if len(positions)
        else 0.0
    )
