"""The error guard: how far a simplified mesh strays from the source (symmetric, sampled).

Data form: meshes as ``(positions (k, 3) float64 metres, faces (m, 3) int64)`` in the
building-local East/Up/North frame. Distances are exact point-to-triangle distances
(:class:`exporter.quality.SurfaceIndex`) from every vertex plus ``SAMPLES`` area-weighted points
(fixed seed) of each side to the other side's surface.

Quadric collapse ranks collapses by error but has no error bound in pymeshlab; the guard adds
one: a level is accepted only when this deviation stays below ``max_error`` x the source's
bounding-box diagonal, otherwise the level's target is raised by bisection.

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
        self._points = self._rng_after = self._index = None

    def _sample(self) -> None:
        # Lazily: most buildings never run the guard (the planar pass alone meets the targets).
        rng = np.random.default_rng(SEED)
        self._points = np.vstack([self.positions[np.unique(self.faces)],
                                  sample_surface(self.positions, self.faces, SAMPLES, rng)])
        self._rng_after = rng  # the level's samples continue this stream

    @property
    def points(self) -> np.ndarray:
        """(p, 3) metres: the reference's vertices and its ``SAMPLES`` surface samples."""
        if self._points is None:
            self._sample()
        return self._points

    @property
    def rng_after(self) -> np.random.Generator:
        """The generator state after the reference's samples."""
        if self._rng_after is None:
            self._sample()
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
    backward = np.vstack([positions[np.unique(faces)], sample_surface(positions, faces, SAMPLES, rng)])
    # Exact maxima: only the largest upper bounds are refined (same value as every exact distance).
    return max(SurfaceIndex(positions, faces).max_distance(reference.points),
               reference.index.max_distance(backward))


def diagonal(positions: np.ndarray) -> float:
    """Bounding-box diagonal, metres."""
    return float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0))) if len(positions) else 0.0
