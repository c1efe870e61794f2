"""Formulation ``rayleigh_p2`` (curved six-node cells, :mod:`cortex_ti.physics.galerkin_p2`) against
independent truths: the exact sphere flows (closed forms and the spectral solution of
:mod:`cortex_ti.analysis.sphere_exact`) and their convergence order, the algebraic structure of its
matrix (symmetric, positive semidefinite, the rigid motions a near-kernel vanishing with the mesh),
the curved cells' own geometry (a sphere's area and volume), and the scene rules that refuse what it
cannot run.

Bounds: each order is asserted with a margin below the measured one (docs/validation/curved.md:
third order or better in h, i.e. a factor of at least 8 per refinement measured 6.4-14.8), so a loss
of one order fails; absolute values against the issue's bars with the measured margin.
"""

import numpy as np
import pytest

from cortex_ti.errors import SceneError
from cortex_ti.physics.patterns import evaluate_active_stress
from cortex_ti.scene import load_scene
from cortex_ti.simulation import Simulation
from cortex_ti.surface.curved import curved_surface, p2_cells
from cortex_ti.truth import analytic
from cortex_ti.truth.sphere_exact import sphere_flow

P2 = ["numerics.formulation=rayleigh_p2", "numerics.fit=quartic", "solver.reuse=false"]
NO_BENDING = [
    "viscosity.bending=0",
    "viscosity.bending_bulk=0",
    "effects=[active_stress,shear_viscosity,bulk_viscosity,normal_balance,incompressibility]",
]


def _ring_error(nodes: int) -> float:
    scene = load_scene("furrow_p8_a1", [f"mesh.nodes={nodes}", *P2, *NO_BENDING])
    sim = Simulation(scene)
    sol = sim.solve()
    pats = list(scene.settings.patterns)
    exact, _, _ = sphere_flow(lambda p: evaluate_active_stress(p, pats), sim.mesh.points, lmax="auto", tol=1e-8)
    return analytic.error_measures(sol.velocity, exact)[1]


def test_the_t0_ring_flow_converges_at_third_order():
    """The ring of paper Fig. 4 at t = 0 without bending viscosity, against the exact flow
    ``v = -(zeta - zeta_bar) n / 2`` (conventions): measured 2.0e-3 / 3.0e-4 at 642 / 2562 nodes
    (ratio 6.7; rayleigh_p1: 1.5e-2 at 2562, ratio 3.9)."""
    coarse, fine = _ring_error(642), _ring_error(2562)
    assert fine <= 3e-3  # the bar at 2562 velocity nodes
    assert coarse / fine > 5.0  # better than second order (4): third order gives 8


@pytest.mark.parametrize("name", ["sphere_y20_tangential", "sphere_y21_tangential"])
def test_tangential_sphere_flows_converge_at_third_order(name):
    """The tangential system's closed form ``v = R^2 grad zeta_l / (eta_s (l(l+1) - 2))``: measured
    4.5e-4 / 3.0e-5 (ratio 14.8, fourth order) at 642 / 2562 nodes."""
    errors = []
    for nodes in (642, 2562):
        scene = load_scene(name, [f"mesh.nodes={nodes}", *P2])
        sim = Simulation(scene)
        sol = sim.solve()
        errors.append(
            analytic.error_measures(sol.velocity, analytic.scene_solution(scene.settings, sim.mesh.points))[1]
        )
    assert errors[0] / errors[1] > 8.0, errors
    assert errors[1] < 1e-4, errors


def _stiffness(nodes: int, stretch=(1.0, 1.1, 0.8)):
    scene = load_scene("furrow_p4_a1", [f"mesh.nodes={nodes}", *P2, *NO_BENDING])
    sim = Simulation(scene)
    x = sim.mesh.points * np.asarray(stretch)
    return sim.system(sim.shape_geometry(x)).stiffness, x


@pytest.mark.slow
def test_the_matrix_is_symmetric_positive_semidefinite_with_rigid_motions_a_near_kernel():
    """On an ellipsoid: symmetric to round-off, no eigenvalue below round-off, and the dissipation of
    a rigid translation and rotation (zero in the continuum) falling faster than h^4 (measured
    h^6: 5.7e-7 -> 8.7e-9 relative, a strain of O(h^3))."""
    import scipy.sparse.linalg as sla

    quotients = []
    for nodes in (642, 2562):
        k, x = _stiffness(nodes)
        scale = abs(k).max()
        assert abs(k - k.T).max() <= 1e-14 * scale
        lowest = sla.eigsh(k, k=3, sigma=-1e-3 * scale, which="LM", return_eigenvectors=False)
        assert lowest.min() > -1e-10 * scale
        moves = [np.tile([1.0, 0.0, 0.0], (len(x), 1)), np.cross([0.0, 0.0, 1.0], x)]
        quotients.append([float(v.ravel() @ k @ v.ravel()) / (scale * float(v.ravel() @ v.ravel())) for v in moves])
    for q0, q1 in zip(*quotients, strict=True):
        assert q1 < q0 / 16.0, quotients


def test_the_curved_cells_of_a_sphere_converge_at_fourth_order():
    """The curved icosphere's area against 4 pi: the midpoints on the sphere, the cells quadratic
    (measured -1.2e-3 / -7.6e-5 / -4.8e-6 at 642 / 2562 / 10242 nodes: ratio 16)."""
    from cortex_ti.surface.fits import StencilChooser
    from cortex_ti.surface.geometry import compute_geometry
    from cortex_ti.surface.mesh import icosphere
    from cortex_ti.surface.topology import build_topology

    errors = []
    for nodes in (642, 2562):
        m = icosphere(nodes)
        topo = build_topology(m)
        surf = curved_surface(compute_geometry(m.points, topo, StencilChooser(topo, "quartic")), m.faces)
        errors.append(abs(surf.area - 4 * np.pi))
        # the rows of the gauge and of the volume are exact integrals: int v dA = A for v = e_x
        assert abs(surf.rigid_motion_rows(False)[0, :, 0].sum() - surf.area) < 1e-12 * surf.area
    assert errors[0] / errors[1] > 12.0, errors


def test_a_mesh_file_is_split_into_curved_cells(tmp_path):
    """A user's triangulation (an icosphere of 642 nodes written with meshio) becomes the 1-to-4
    split whose new nodes lie on the fitted surface: 2562 nodes, the midpoints within the quartic
    fit's accuracy of the sphere, and the ring flow as accurate as on the built-in icosphere."""
    import meshio

    from cortex_ti.surface.mesh import icosphere

    m = icosphere(642)
    path = tmp_path / "sphere.vtk"
    meshio.write(path, meshio.Mesh(m.points, [("triangle", m.faces)]))
    scene = load_scene("furrow_p8_a1", [f"mesh.file={path}", *P2, *NO_BENDING])
    sim = Simulation(scene)
    x = sim.mesh.points
    assert x.shape == (2562, 3)
    assert np.abs(np.linalg.norm(x, axis=1) - 1.0).max() < 1e-5
    assert p2_cells(sim.mesh.faces).shape == (1280, 6)
    pats = list(scene.settings.patterns)
    sol = sim.solve()
    exact, _, _ = sphere_flow(lambda p: evaluate_active_stress(p, pats), x / np.linalg.norm(x, axis=1)[:, None])
    assert analytic.error_measures(sol.velocity, exact)[1] < 3e-3


@pytest.mark.parametrize(
    "overrides, match",
    [
        (["mesh.nodes=12"], "at least 42 nodes"),
    ],
)
def test_what_curved_cells_cannot_run_is_refused_by_name(overrides, match):
    with pytest.raises(SceneError, match=match):
        load_scene("furrow_p4_a1", ["numerics.formulation=rayleigh_p2", *overrides])


def test_a_mesh_not_in_the_split_layout_is_refused_in_one_line():
    from cortex_ti.errors import MeshError
    from cortex_ti.surface.mesh import icosphere

    faces = icosphere(162).faces[np.random.default_rng(0).permutation(320)]
    with pytest.raises(MeshError, match="split"):
        p2_cells(faces)
