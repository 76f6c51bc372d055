"""The error guard: how far a simplified mesh strays from the source (symmetric Hausdorff
distance, certified).

Data form: meshes as ``(positions (k, 3) float64 metres, faces (m, 3) int64)`` in the
building-local East/Up/North frame.

Quadric collapse ranks collapses by error but has no error bound; the guard adds one: a level is
accepted only when its symmetric Hausdorff distance to LOD0 stays below the level's budget in
metres (``simplify.max_screen_error_px`` converted per building and level), otherwise the level
keeps more triangles. The distance is
certified (:mod:`exporter.hausdorff`): :func:`exceeds` never accepts a level whose true distance
is above the tolerance (it may refuse one whose bound it cannot bring below the tolerance), and
:func:`deviation` is an upper bound of the true distance, within ``hausdorff.RTOL`` of it (plus
``hausdorff.ATOL`` x the diagonal) unless the refinement depth ran out first. :func:`certify`
(what the search runs, and whose bounds the manifest reports) refines no finer than
``BUDGET_SHARE`` of the level's budget, and never stops above the budget while the bound may
still come under it.

The reference side (LOD0: its surface index, planar regions and straight edge chains) is
prepared once per building (:class:`Reference`) and shared by every level and every search step.
"""

from __future__ import annotations

import numpy as np

from .. import hausdorff, quality

BUDGET_SHARE = 0.05  # certified bounds are refined to within this share of the budget at least


class Reference:
    """The guard's reference mesh ``(positions (k, 3) metres, faces (m, 3))``, prepared once
    (lazily: most buildings never run the guard)."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray) -> None:
        self.positions, self.faces = positions, faces
        self._surface: hausdorff.Surface | None = None
        self._silhouettes: np.ndarray | None = None

    @property
    def surface(self) -> hausdorff.Surface:
        if self._surface is None:
            self._surface = hausdorff.Surface(self.positions, self.faces)
        return self._surface

    @property
    def index(self):
        """The reference's exact point-distance index (:class:`~exporter.quality.SurfaceIndex`)."""
        return self.surface.index

    @property
    def silhouettes(self) -> np.ndarray:
        """(3, RESOLUTION, RESOLUTION) bool: the reference's top, front and side silhouettes on
        its own box (:func:`exporter.quality.silhouettes`)."""
        if self._silhouettes is None:
            self._silhouettes = quality.silhouettes(self.positions, self.faces, *self.box)
        return self._silhouettes

    @property
    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """The reference's axis-aligned box ``(low (3,), high (3,))``, metres."""
        return self.positions.min(axis=0), self.positions.max(axis=0)


def _reference(reference) -> Reference:
    return reference if isinstance(reference, Reference) else Reference(*reference)


def deviation_bounds(reference, positions: np.ndarray, faces: np.ndarray) -> tuple[float, float]:
    """``(lower, upper)`` metres of the symmetric Hausdorff distance between ``reference`` (a
    :class:`Reference` or a ``(positions, faces)`` pair) and ``(positions, faces)``; (inf, inf)
    for an empty level."""
    if len(faces) == 0:
        return float("inf"), float("inf")
    return hausdorff.hausdorff_bounds(_reference(reference).surface, (positions, faces))


def deviation(reference, positions: np.ndarray, faces: np.ndarray) -> float:
    """Certified upper bound (metres) of the symmetric Hausdorff distance between ``reference``
    (a :class:`Reference` or a ``(positions, faces)`` pair) and ``(positions, faces)`` (inf for
    an empty level)."""
    return deviation_bounds(reference, positions, faces)[1]


def certify(
    reference: Reference, positions: np.ndarray, faces: np.ndarray, tolerance: float
) -> tuple[float, float] | None:
    """``(lower, upper)`` metres of the symmetric Hausdorff distance between ``reference`` and
    the level ``(positions, faces)`` (as :func:`deviation_bounds`) when the level certainly stays
    within ``tolerance`` metres, else None (also for an empty level). Costs about what
    :func:`deviation_bounds` costs when it passes and stops early when it cannot."""
    if len(faces) == 0:
        return None
    reference = _reference(reference)
    # The manifest's tightness (exporter.quality), so these bounds are what it would report, but
    # no finer than BUDGET_SHARE of the level's budget: the last digits of an error far under
    # the budget cost refinement rounds and tell the user nothing.
    atol = quality.HAUSDORFF_ATOL * diagonal(np.concatenate([reference.positions, positions]))
    atol = max(atol, BUDGET_SHARE * tolerance)
    return hausdorff.bounds_within(
        reference.surface, (positions, faces), tolerance, rtol=quality.HAUSDORFF_RTOL, atol=atol
    )


def exceeds(
    reference: Reference, positions: np.ndarray, faces: np.ndarray, tolerance: float
) -> bool:
    """Whether the level ``(positions, faces)`` may be farther than ``tolerance`` (metres) from
    ``reference`` (symmetric Hausdorff distance): False only when it certainly is not; True for
    an empty level. Decided with early exits (:func:`exporter.hausdorff.exceeds`), much cheaper
    than :func:`deviation`."""
    if len(faces) == 0:
        return True
    return hausdorff.exceeds(_reference(reference).surface, (positions, faces), tolerance)


def diagonal(positions: np.ndarray) -> float:
    """Bounding-box diagonal, metres."""
    return (
        float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0)))
        if len(positions)
        else 0.0
    )


def silhouette_iou(reference: Reference, positions: np.ndarray, faces: np.ndarray) -> float:
    """The smallest IoU of the level's top, front and side silhouettes with the reference's, on
    a raster of the reference's box (``quality.RESOLUTION`` pixels a side; what the manifest's
    ``silhouette_iou`` measures, there on LOD0 as given rather than welded)."""
    if len(reference.faces) == 0:
        return 1.0
    low, high = reference.box
    return quality.min_iou(reference.silhouettes, quality.silhouettes(positions, faces, low, high))
