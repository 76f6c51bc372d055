"""The compiled in-plane bound (:mod:`exporter.mesh.planar_bound_kernels` through
``hausdorff._planar_bound``) gives exactly what the former numpy form
(``reference_planar_bound`` of tests/test_perf_hausdorff.py) gives, float for float, on every call
the mesh chain makes over generated buildings (walls re-triangulated, towers, domes, roofs) and on
random near-planar pieces against a wall; a bad index is an error, not a crash. Metres."""

from __future__ import annotations

import numpy as np
import pytest

from exporter.mesh import hausdorff
from exporter.mesh.hausdorff import LOOSE, PLANE_SLACK_MAX, SHRINK, Surface
from exporter.mesh.planar_bound_kernels import planar_bound
from tests.test_perf_hausdorff import reference_planar_bound


def test_every_call_of_the_chain_on_generated_buildings_gives_the_former_bound(monkeypatch):
    import exporter.simplify as simplify
    from exporter import samplegen
    from exporter.config import Config

    compiled = hausdorff._planar_bound
    seen = []

    def spy(tri, target, row, face, cap):
        out = compiled(tri, target, row, face, cap)
        assert np.array_equal(out, reference_planar_bound(tri, target, row, face, cap))
        seen.append(int(np.isfinite(out).sum()))
        return out

    monkeypatch.setattr(hausdorff, "_planar_bound", spy)
    config = Config()
    for building in samplegen.generate_buildings(30, seed=11):
        simplify.build_mesh_chain(building.parts, config.lods, config.simplify)
    assert len(seen) > 10 and sum(seen) > 100  # the bound was asked for, and held


def test_pieces_near_a_wall_give_the_former_bound():
    rng = np.random.default_rng(2)
    x, y = np.meshgrid(np.linspace(0, 10, 6), np.linspace(0, 6, 4))
    positions = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    faces = []
    for j in range(3):
        for i in range(5):
            a, b, c, d = j * 6 + i, j * 6 + i + 1, (j + 1) * 6 + i, (j + 1) * 6 + i + 1
            faces += [[a, b, d], [a, d, c]]
    target = Surface(positions, np.array(faces))
    for _ in range(20):
        tri = rng.random((40, 3, 3)) * [12, 8, 0] - [1, 1, 0]
        tri[..., 2] = rng.normal(size=(40, 3)) * 10.0 ** rng.integers(-9, -2)
        k = int(rng.integers(1, 4))
        row = np.repeat(np.arange(40), k)
        face = rng.integers(0, len(faces), size=40 * k)
        cap = rng.random(40) * 0.01 if rng.random() < 0.3 else None
        got = hausdorff._planar_bound(tri, target, row, face, cap)
        assert np.array_equal(got, reference_planar_bound(tri, target, row, face, cap))


def test_an_index_out_of_range_is_an_error_not_a_crash():
    target = Surface(np.eye(3), np.array([[0, 1, 2]]))
    tri = np.eye(3)[None]
    with pytest.raises(ValueError, match="out of range"):
        planar_bound(
            tri,
            np.array([0]),
            np.array([4]),
            target.regions,
            None,
            (SHRINK, PLANE_SLACK_MAX, LOOSE),
        )


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"face": np.array([4])}, "face holds 4"),
        ({"region": np.array([3])}, "region holds 3"),
        ({"seg_start": np.array([0, 5])}, "seg_start"),
        ({"seg_start": np.array([-1, 0])}, "seg_start"),
        ({"tri2": np.zeros((2, 3, 2))}, "tri2"),
        ({"out": np.zeros(1, np.float32)}, "out must be"),
    ],
)
def test_the_compiled_kernel_checks_what_it_follows(change, message):
    """The C kernel called directly (past the wrapper's checks) refuses indices out of range."""
    from exporter.mesh._planar_bound import bound

    args = {
        "tri": np.eye(3)[None],
        "row": np.array([0]),
        "face": np.array([0]),
        "region": np.array([0]),
        "planes": np.zeros((12, 1)),
        "tri2": np.zeros((1, 3, 2)),
        "seg_start": np.array([0, 0]),
        "seg": np.zeros((4, 0)),
        "cap": None,
        "loose": np.array(LOOSE),
        "scale": 1.0,
        "shrink": SHRINK,
        "plane_slack_max": PLANE_SLACK_MAX,
        "out": np.full(1, np.inf),
    }
    bound(*args.values())  # the unchanged arguments are accepted
    with pytest.raises(ValueError, match=message):
        bound(*{**args, **change}.values())
