"""The plausibility rule for a building's vertices: what is refused rather than exported.

A vertex that is not a finite number, or that lies farther than ``readers.max_vertex_distance_m``
(metres, default 2000) from the coordinate-wise median of its building's vertices, refuses its
building (listed in the manifest's ``skipped`` with the reason); the file's other buildings go
on. The median is robust: a few stray vertices cannot drag it, so one vertex at 1e12 m is named
instead of moving the building's centre thousands of kilometres and stretching its mesh.
Points are in any Cartesian metre frame (the sphere's Earth-centred frame in the readers, the
building's local East/Up/North frame in the pipeline).
"""

from __future__ import annotations

import numpy as np

LIMIT_KEY = "readers.max_vertex_distance_m"


def vertex_problem(points: np.ndarray, limit_m: float) -> str | None:
    """Why the vertices ``points`` (n, 3) metres cannot be one building, or None when they can."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if not len(points):
        return None
    finite = np.isfinite(points).all(axis=1)
    if not finite.all():
        return (
            f"{int((~finite).sum())} of {len(points)} vertices are not finite numbers "
            "(NaN or infinite): building refused"
        )
    distance = np.linalg.norm(points - np.median(points, axis=0), axis=1)
    far = distance > limit_m
    if far.any():
        return (
            f"{int(far.sum())} of {len(points)} vertices lie more than {limit_m:g} m from the "
            f"median of the building's vertices (farthest {float(distance.max()):.4g} m; "
            f"{LIMIT_KEY}): building refused rather than moved"
        )
    return None
