"""Non-axisymmetric scenes (paper Secs. 4.3-4.4): the fold pattern and the sheared start."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from cortex_ti.analysis.diagnostics import orientation_angle
from cortex_ti.errors import SceneError
from cortex_ti.physics.patterns import evaluate_active_stress
from cortex_ti.scene import load_scene
from cortex_ti.simulation import Simulation

FOLD = {"type": "fold", "zeta0": 1.0, "amplitude": 3.5, "sigma": 1.5, "p": 4, "sigma_phi": 200.0}
MIRRORS = [np.diag([-1.0, 1, 1]), np.diag([1.0, -1, 1]), np.diag([1.0, 1, -1])]


def test_fold_pattern_against_its_closed_form():
    theta = np.array([np.pi / 2, np.pi / 2, np.pi / 2, 1.0, 2.3])
    phi = np.array([np.pi / 2, 3 * np.pi / 2, 1.5, 4.9, 0.2])
    pts = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], axis=1)
    d = np.minimum(np.abs(phi - np.pi / 2), np.abs(phi - 3 * np.pi / 2))
    want = 1.0 + 3.5 * np.exp(-1.5 * np.abs(theta - np.pi / 2) ** 4) * np.exp(-200.0 * d**4)
    np.testing.assert_allclose(evaluate_active_stress(pts, [FOLD]), want, rtol=1e-14)
    # the stripe: on the great circle x = 0 the full amplitude, a quarter turn away the background
    assert evaluate_active_stress(np.array([[0.0, 1, 0]]), [FOLD])[0] == pytest.approx(4.5, abs=1e-14)
    assert evaluate_active_stress(np.array([[1.0, 0, 0]]), [FOLD])[0] == pytest.approx(1.0, abs=1e-12)


def test_fold_pattern_rejects_a_negative_width():
    with pytest.raises(SceneError, match="sigma_phi"):
        evaluate_active_stress(np.array([[0.0, 1, 0]]), [dict(FOLD, sigma_phi=-1.0)])


@pytest.mark.parametrize("name", ["fold_narrow", "fold_broad"])
def test_fold_flow_keeps_the_mirror_planes(name):
    """The fold pattern and the icosphere share the three coordinate mirror planes; the
    computed flow must too (a reflected node's velocity is the reflected velocity)."""
    sim = Simulation(load_scene(name))
    sol = sim.solve()
    x, v = sim.mesh.points, sol.velocity
    scale = np.abs(v).max()
    for mirror in MIRRORS:
        image = x @ mirror
        dist, j = cKDTree(x).query(image)  # node j with x_j = R x_i
        assert dist.max() < 1e-9
        assert np.abs(v[j] - v @ mirror).max() < 1e-8 * scale
    # the stripe pulls inward (paper Fig. 9B,E: inward flow across the stripe, outward at the poles)
    vn = np.einsum("nc,nc->n", v, x / np.linalg.norm(x, axis=1, keepdims=True))
    stripe = np.argmax(sim.zeta)
    pole = np.argmax(x[:, 2])
    assert vn[stripe] < 0 < vn[pole]


@pytest.mark.parametrize("gamma", [0.35, 0.75])
def test_sheared_start_orientation_matches_the_sheared_ellipsoid(gamma):
    """x -> x + gamma z maps the unit sphere to an ellipsoid whose long axis is the top
    eigenvector of A A^T; the scene's initial orientation angle against +z must be its angle."""
    sim = Simulation(load_scene("shear_035", [f"mesh.shear={gamma}"]))
    a = np.array([[1.0, 0, gamma], [0, 1, 0], [0, 0, 1]])
    w, vecs = np.linalg.eigh(a @ a.T)
    want = np.degrees(np.arccos(abs(vecs[:, -1][2])))
    got = orientation_angle(sim.mesh.points, sim.mesh.faces, (0.0, 0.0, 1.0))
    assert got == pytest.approx(want, abs=0.05)
    # the active stress was assigned before the shear: equal to the ring on the undeformed sphere
    undeformed = load_scene("shear_035", ["mesh.shear=0"])
    assert np.array_equal(sim.zeta, Simulation(undeformed).zeta)
