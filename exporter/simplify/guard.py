"""The error guard: how far a simplified mesh strays from the source (symmetric, sampled).

Data form: meshes as ``(positions (k, 3) float64 metres, faces (m, 3) int64)`` in the
building-local East/Up/North frame. Distances are exact point-to-triangle distances
(:func:`exporter.quality.distance_to_surface`) from every vertex plus ``SAMPLES``
area-weighted points (fixed seed) of each side to the other side's surface.

Quadric collapse ranks collapses by error but has no error bound in pymeshlab; the guard adds
one: a level is accepted only when this deviation stays below ``max_error`` x the source's
bounding-box diagonal, otherwise the level's target is raised by bisection.
"""
from __future__ import annotations

import numpy as np

from ..quality import distance_to_surface, sample_surface

SAMPLES = 96
SEED = 7


def deviation(reference: tuple[np.ndarray, np.ndarray], positions: np.ndarray, faces: np.ndarray) -> float:
    """Symmetric sampled Hausdorff distance (metres) between ``reference`` and ``(positions, faces)``."""
    ref_pos, ref_faces = reference
    if len(faces) == 0:
        return float("inf")
    rng = np.random.default_rng(SEED)
    forward = np.vstack([ref_pos[np.unique(ref_faces)], sample_surface(ref_pos, ref_faces, SAMPLES, rng)])
    backward = np.vstack([positions[np.unique(faces)], sample_surface(positions, faces, SAMPLES, rng)])
    return max(float(distance_to_surface(forward, positions, faces).max(initial=0.0)),
               float(distance_to_surface(backward, ref_pos, ref_faces).max(initial=0.0)))


def diagonal(positions: np.ndarray) -> float:
    """Bounding-box diagonal, metres."""
    return float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0))) if len(positions) else 0.0
