"""When a run remeshes (cortex_ti.dynamics.remesh_policy): the angle trigger, the trigger of a mesh
that misses it itself, and the resolution trigger's period. The truths are the triangles' angles,
computed here from the law of cosines, not by the module's own measure."""

import numpy as np
import pytest

from cortex_ti.dynamics.remesh_policy import COARSE_EVERY, RETRIGGER, RemeshPolicy
from cortex_ti.surface.mesh import icosphere
from cortex_ti.surface.remesh import RemeshOptions


def smallest_angle(points, faces) -> float:
    """The smallest interior angle (deg), by the law of cosines."""
    p = points[faces]
    a, b, c = (np.linalg.norm(p[:, (k + 1) % 3] - p[:, (k + 2) % 3], axis=1) for k in range(3))
    angles = [np.arccos((y**2 + z**2 - x**2) / (2 * y * z)) for x, y, z in ((a, b, c), (b, c, a), (c, a, b))]
    return float(np.degrees(np.min(angles)))


@pytest.fixture(scope="module")
def sphere():
    mesh = icosphere(162, 1.0)
    return mesh.points, mesh.faces


def test_angle_trigger(sphere):
    points, faces = sphere
    worst = smallest_angle(points, faces)
    assert RemeshPolicy(worst - 1.0, RemeshOptions()).due(points, faces) is None
    why = RemeshPolicy(worst + 1.0, RemeshOptions()).due(points, faces)
    assert why is not None and why.startswith("smallest angle")


def test_a_new_mesh_below_the_trigger_gets_its_own(sphere):
    points, faces = sphere
    worst = smallest_angle(points, faces)
    policy = RemeshPolicy(worst + 5.0, RemeshOptions())
    assert policy.judge(points, faces) == pytest.approx(worst, abs=1e-9)
    assert policy.below == pytest.approx(RETRIGGER * worst, abs=1e-9)
    assert policy.due(points, faces) is None  # not remeshed again at once
    above = RemeshPolicy(worst - 5.0, RemeshOptions())
    above.judge(points, faces)
    assert above.below == worst - 5.0  # a mesh above min_angle keeps it


def test_resolution_trigger_is_checked_every_few_steps(sphere):
    points, faces = sphere
    options = RemeshOptions(h_min=0.01, h_max=0.02)  # every edge (~0.3) far coarser than its target
    policy = RemeshPolicy(1.0, options, coarser=1.5)
    answers = [policy.due(points, faces) for _ in range(COARSE_EVERY)]
    assert answers[:-1] == [None] * (COARSE_EVERY - 1)
    assert answers[-1] is not None and "coarser" in answers[-1]
    off = RemeshPolicy(1.0, options)
    assert all(off.due(points, faces) is None for _ in range(2 * COARSE_EVERY))
