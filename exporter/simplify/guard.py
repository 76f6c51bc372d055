"""The error guard: how far a simplified mesh strays from the source (symmetric Hausdorff
distance, certified).

Data form: meshes as ``(positions (k, 3) float64 metres, faces (m, 3) int64)`` in the
building-local East/Up/North frame.

Quadric collapse ranks collapses by error but has no error bound; the guard adds one: a level is
accepted only when its symmetric Hausdorff distance to LOD0 stays below the level's budget in
metres (``simplify.max_screen_error_px`` converted per building and level), otherwise the level
keeps more triangles. The distance is
certified (:mod:`exporter.mesh.hausdorff`): :func:`exceeds` never accepts a level whose true distance
is above the tolerance (it may refuse one whose bound it cannot bring below the tolerance), and
:func:`deviation` is an upper bound of the true distance, within ``hausdorff.RTOL`` of it (plus
``hausdorff.ATOL`` x the diagonal) unless the refinement depth ran out first. :func:`certify`
(what the search runs, and whose bounds the manifest reports) refines no finer than
``BUDGET_SHARE`` of the level's budget, and never stops above the budget while the bound may
still come under it.

The reference side (LOD0: its surface index, planar regions and straight edge chains) is
prepared once per building (:class:`Reference`) and shared by every level and every search step.
The bounds are taken against LOD0's *lossless twin* (:func:`lossless_twin`): its flat polygons
re-triangulated from their outlines, the same surface in fewer, larger triangles, certified
within ``delta`` metres of LOD0 (``coverage.region_certificate``). Since the Hausdorff distance
is a metric, ``|d(level, LOD0) - d(level, twin)| <= delta``: the twin's bounds widened by
``delta`` are LOD0's. Why: a level triangle across a tower's wall columns spans a few column
triangles of the twin instead of floors x bays of LOD0's, so the single-face and pair bounds
close it in fewer refinement rounds and tighter (measured: docs/simplification.md, "The certified
error").
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .. import quality
from ..mesh import coverage, hausdorff
from ..mesh.geometry import compact_vertices
from ..mesh.raster import min_iou, silhouettes
from ..mesh.slits import closed_surface

BUDGET_SHARE = 0.05  # certified bounds are refined to within this share of the budget at least
TWIN_SLACK = 1e-6  # the twin stands in for LOD0 only within this x LOD0's diagonal (metres)
TWIN_SHARE = 0.9  # ... and only with at most this share of LOD0's faces (else no gain)


def lossless_twin(
    positions: np.ndarray,
    faces: np.ndarray,
    twin_faces: np.ndarray,
    slack: float,
    surface: Callable[[], hausdorff.Surface] | None = None,
    made: list[hausdorff.Surface] | None = None,
) -> tuple[np.ndarray, np.ndarray, float] | None:
    """LOD0 ``(positions (k, 3) metres, faces (m, 3))`` and ``twin_faces`` (m', 3) on the same
    positions, LOD0's flat polygons re-triangulated from their outlines (the planar stage's
    output, :func:`~.planar.retriangulate_planar_checked`), as the twin ``(positions (k', 3),
    faces (m', 3), delta)`` on its own vertices: ``delta`` metres certifies the symmetric
    Hausdorff distance between LOD0 and the twin: :func:`exporter.mesh.coverage.region_certificate`
    against LOD0 with its slits closed (:func:`exporter.mesh.slits.closed_surface`, whose offset is
    added); faces it leaves open are bounded by the general method,
    :func:`exporter.mesh.hausdorff.directed_bounds`, when ``surface`` gives LOD0 as a
    :class:`~exporter.mesh.hausdorff.Surface`. None when the twin has more than ``TWIN_SHARE`` of
    LOD0's faces or is not certified within ``slack`` metres. ``made``: a list the twin's own
    :class:`~exporter.mesh.hausdorff.Surface` is appended to when one is prepared here (the caller
    reuses it rather than preparing the same surface again)."""
    if len(faces) == 0 or len(twin_faces) == 0 or len(twin_faces) > TWIN_SHARE * len(faces):
        return None
    used, twin = compact_vertices(twin_faces, len(positions))
    twin_positions = positions[used]
    # The planar stage re-triangulated LOD0 with its slits closed: the twin is certified against
    # that mesh, every point of which is within ``offset`` of LOD0 and back (a metric).
    closed, offset = closed_surface(positions, faces)
    settled = coverage.region_certificate(
        (twin_positions, twin), (positions, closed), max_bound=slack
    )
    delta = float(settled.bound)
    if delta + offset > slack:
        return None
    if settled.open_level.any() or settled.open_source.any():
        if surface is None:
            return None

        def twin_surface() -> hausdorff.Surface:
            prepared = hausdorff.Surface(twin_positions, twin)
            if made is not None:
                made.append(prepared)
            return prepared

        # Only the open faces, each against the whole other side, decided at the slack: the
        # closed mesh's against the twin, the twin's against LOD0 itself.
        for tri, target in (
            (positions[closed[settled.open_source]], twin_surface),
            (twin_positions[twin[settled.open_level]], surface),
        ):
            if len(tri):
                upper = hausdorff.directed_bounds(tri, target(), tolerance=slack - offset)[1]
                if upper + offset > slack:
                    return None
                delta = max(delta, upper)
    delta += offset
    return twin_positions, twin, delta


class Reference:
    """The guard's reference mesh ``(positions (k, 3) metres, faces (m, 3))``, prepared once
    (lazily: most buildings never run the guard)."""

    def __init__(self, positions: np.ndarray, faces: np.ndarray) -> None:
        self.positions, self.faces = positions, faces
        self._surface: hausdorff.Surface | None = None
        self._twin: tuple[hausdorff.Surface, float] | None = None
        self._twin_faces: np.ndarray | None = None
        self._silhouettes: np.ndarray | None = None

    @property
    def surface(self) -> hausdorff.Surface:
        if self._surface is None:
            self._surface = hausdorff.Surface(self.positions, self.faces)
        return self._surface

    def offer_twin(self, faces: np.ndarray) -> None:
        """Offer LOD0's planar-stage output ``faces`` (m', 3), on LOD0's own (welded) positions,
        as its :func:`lossless_twin` (taken only if certified, when the bounds first need it)."""
        if self._twin is None:
            self._twin_faces = faces

    @property
    def twin(self) -> tuple[hausdorff.Surface, float]:
        """``(surface, delta)``: the surface the bounds are taken against and ``delta`` metres
        to widen them by: LOD0's :func:`lossless_twin` when one was offered and certified, else
        LOD0 itself (0)."""
        if self._twin is None:
            found = None
            made: list[hausdorff.Surface] = []  # the twin's surface, when lossless_twin made it
            if self._twin_faces is not None:
                found = lossless_twin(
                    self.positions,
                    self.faces,
                    self._twin_faces,
                    TWIN_SLACK * diagonal(self.positions),
                    lambda: self.surface,
                    made,
                )
            self._twin = (
                (made[0] if made else hausdorff.Surface(found[0], found[1]), found[2])
                if found is not None
                else (self.surface, 0.0)
            )
        return self._twin

    @property
    def silhouettes(self) -> np.ndarray:
        """(3, RESOLUTION, RESOLUTION) bool: the reference's top, front and side silhouettes on
        its own box (:func:`exporter.mesh.raster.silhouettes`)."""
        if self._silhouettes is None:
            self._silhouettes = silhouettes(self.positions, self.faces, *self.box)
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
    surface, delta = _reference(reference).twin
    lower, upper = hausdorff.hausdorff_bounds(surface, (positions, faces))
    return max(lower - delta, 0.0), upper + delta


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
    surface, delta = reference.twin
    bounds = hausdorff.bounds_within(
        surface, (positions, faces), tolerance - delta, rtol=quality.HAUSDORFF_RTOL, atol=atol
    )
    return None if bounds is None else (max(bounds[0] - delta, 0.0), bounds[1] + delta)


def exceeds(
    reference: Reference, positions: np.ndarray, faces: np.ndarray, tolerance: float
) -> bool:
    """Whether the level ``(positions, faces)`` may be farther than ``tolerance`` (metres) from
    ``reference`` (symmetric Hausdorff distance): False only when it certainly is not; True for
    an empty level. Decided with early exits (:func:`exporter.mesh.hausdorff.exceeds`), much cheaper
    than :func:`deviation`."""
    if len(faces) == 0:
        return True
    surface, delta = _reference(reference).twin
    return hausdorff.exceeds(surface, (positions, faces), tolerance - delta)


def diagonal(positions: np.ndarray) -> float:
    """Bounding-box diagonal, metres."""
    return (
        float(np.linalg.norm(positions.max(axis=0) - positions.min(axis=0)))
        if len(positions)
        else 0.0
    )


def silhouette_iou(reference: Reference, positions: np.ndarray, faces: np.ndarray) -> float:
    """The smallest IoU of the level's top, front and side silhouettes with the reference's, on
    a raster of the reference's box (``exporter.mesh.raster.RESOLUTION`` pixels a side; what the manifest's
    ``silhouette_iou`` measures, there on LOD0 as given rather than welded)."""
    if len(reference.faces) == 0:
        return 1.0
    low, high = reference.box
    return min_iou(reference.silhouettes, silhouettes(positions, faces, low, high))
