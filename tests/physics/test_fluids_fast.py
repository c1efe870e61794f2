"""The fluids matrix-free (``fluid.solver: direct | fmm``, :mod:`cortex_ti.physics.fluids_fast`,
:mod:`cortex_ti.solve.fluid_krylov`): against the closed forms (Boussinesq-Scriven, Faxén), against
the dense path (a consistency check: the same discrete operator, so they differ by the Krylov and
FMM tolerances only), and the refusals.

Bounds: the dense path's measured errors (docs/validation/fluids.md: sedimentation 3.24e-2 at 162
nodes, 8.50e-3 at 642, second order; tests/physics/test_fluids.py) hold for the fast path too,
because it solves the same discrete system to ``KRYLOV_RTOL`` = 1e-7 (relative), which moves the
velocity by about that (measured 8.1e-8 of max |v| at 162 nodes): the bounds are the dense path's
plus ~15 %, and the two node counts must give a ratio above 3 (order > 1.6).
"""

import math
import sys

import numpy as np
import pytest

from cortex_ti.errors import SceneError, SolverError
from cortex_ti.physics import fluids_fast
from cortex_ti.physics.fluids_fast import FMM_MISSING, fmm_fluid, require_fmm
from cortex_ti.physics.stokes_bie import node_areas, single_layer_matrix
from cortex_ti.scene import load_scene
from cortex_ti.simulation import Simulation
from cortex_ti.solve.fluid_krylov import KRYLOV_RTOL
from cortex_ti.truth import fluid_sphere as fs

pytestmark = pytest.mark.usefixtures("taichi_runtime")


def solve(scene: str, nodes: int, solver: str):
    sim = Simulation(load_scene(scene, [f"mesh.nodes={nodes}", f"fluid.solver={solver}"]))
    x = sim.mesh.points
    sol = sim.solve(x)
    return sim, x, sol


def sediment_error(sim, x, sol) -> float:
    """The centroid velocity of the normal flow (quadrature-weighted, as test_fluids.sediment)
    against Boussinesq-Scriven (the body force is -e_z: the cell sinks)."""
    geo = sim.shape_geometry(x)
    vn = np.einsum("nc,nc->n", sol.velocity, geo.normal)
    c = (geo.area[:, None] * x).sum(0) / geo.area.sum()
    vol = (geo.area * np.einsum("nc,nc->n", x - c, geo.normal)).sum() / 3.0
    u = -(geo.area * (x[:, 2] - c[2]) * vn).sum() / vol
    return u / fs.sedimentation_velocity(1.0, mu_in=1.0, mu_out=1.0, eta_s=1.0, eta_b=1.0) - 1.0


@pytest.fixture(scope="module")
def sediment162():
    """The dense solve, the direct one as it runs (lumped far field) and with every pair exact
    (``LUMP_RADIUS`` infinite: the dense path's operator)."""
    out = {s: solve("sedimenting_cell", 162, s) for s in ("dense", "direct")}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fluids_fast, "LUMP_RADIUS", math.inf)
        out["exact"] = solve("sedimenting_cell", 162, "direct")
    return out


def test_direct_with_every_pair_exact_agrees_with_dense_to_the_krylov_tolerance_regression(sediment162):
    """Consistency (not a truth): with every pair exact the same discrete operator, so the
    velocities differ by the GMRES tolerance; measured 8.1e-8 of max |v| (furrow_in_fluid, 162 nodes)
    at rtol 1e-7."""
    vd = sediment162["dense"][2].velocity
    sim, _, sol = sediment162["exact"]
    assert sol.info.backend == "gmres-direct" == sim.settings.solver_name
    assert np.abs(sol.velocity - vd).max() < 10 * KRYLOV_RTOL * np.abs(vd).max()


def test_direct_sediments_at_the_boussinesq_scriven_velocity_162(sediment162):
    """The dense path's 3.24e-2 at 162 nodes (the triangulated volume is 3.4 % short)."""
    assert abs(sediment_error(*sediment162["direct"])) < 3.7e-2


@pytest.mark.slow
def test_direct_sedimentation_converges_642(sediment162):
    """8.50e-3 at 642 nodes with the dense path, a factor 3.8 below 162."""
    e642 = abs(sediment_error(*solve("sedimenting_cell", 642, "direct")))
    assert e642 < 1.0e-2
    assert abs(sediment_error(*sediment162["direct"])) / e642 > 3.0


def test_far_field_within_its_quadrature_bound_162():
    """The far field (vertices 1/4, centroid 3/4: exact for quadratics) against the exact pairs
    (docs/derivations/lumped_far_field.md): on a triangle ``T`` whose nearest point is ``r`` from the
    target, a rule exact for quadratics with positive weights is off by at most ``|T| rho^3 M3 / 3``
    (``rho`` the largest centroid-to-corner distance, ``M3 <= 156 |e| / r^4`` the third directional
    derivative of the Stokeslet times a constant density ``e``), ``/ 8 pi``. Summed over the far
    triangles: a bound at every node, at two radii; and the error shrinks as the radius grows. (The
    far sums themselves are checked against the corrections' own values of the rule by
    test_every_pair_exact_is_the_dense_single_layer_regression.)"""
    sim = Simulation(load_scene("sedimenting_cell", ["mesh.nodes=162"]))
    x, faces = sim.mesh.points, np.asarray(sim.mesh.faces)
    normal = sim.shape_geometry(x).normal
    f = np.tile([0.3, -0.5, 1.0], len(x))

    def apply(op):  # C f less the far sums (the same at every radius): the corrections
        return op.correction @ f

    exact = apply(fluids_fast.FmmFluid(x, faces, normal, 1.0, backend="direct", lump=math.inf))
    tri = x[faces]
    cen = tri.mean(1)
    rho = np.linalg.norm(tri - cen[:, None], axis=2).max(1)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    d = np.linalg.norm(x[:, None, :] - cen[None], axis=2)  # (N, F)
    errors = []
    for lump in (3.0, 5.0):
        op = fluids_fast.FmmFluid(x, faces, normal, 1.0, backend="direct", lump=lump)
        err = np.linalg.norm((apply(op) - exact).reshape(-1, 3), axis=1)
        r = np.where(d >= lump * rho[None], d - rho[None], np.inf)  # the nearest point of T is at least this far
        bound = (area * rho**3 * 52.0 / r**4).sum(1) * np.linalg.norm(f[:3]) / (8 * math.pi)
        assert (err <= bound).all()
        errors.append(err.max())
    assert errors[1] < errors[0]


def test_direct_turns_at_the_faxen_rate_162():
    """A rigid rotation with the far field's vorticity is exact on any mesh (derivation
    fluids_run.md): the rotation normalised by the mesh's own moment is -G/2 to the Krylov
    tolerance (the dense path: 1.1e-15), the mean velocity 0."""
    sim, x, sol = solve("cell_in_shear", 162, "direct")
    geo = sim.shape_geometry(x)
    a, v = geo.area, sol.velocity
    c = (a[:, None] * x).sum(0) / a.sum()
    r = x - c
    moment = (
        a[:, None, None] * (np.einsum("nc,nc->n", r, r)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :])
    ).sum(0)
    omega = np.linalg.solve(moment, (a[:, None] * np.cross(r, v)).sum(0))
    mean = (a[:, None] * v).sum(0) / a.sum()
    assert np.abs(omega - [0.0, 0.0, -0.5]).max() < 10 * KRYLOV_RTOL
    assert np.abs(mean).max() < 10 * KRYLOV_RTOL


def test_every_pair_exact_is_the_dense_single_layer_regression():
    """Consistency (not a truth): with an infinite radius every (node, triangle) pair is integrated
    exactly and the lumped far field is subtracted again, so ``V' f`` is the dense path's
    ``(A C f + C^T A f) / 2 + c w (w . f)`` to round-off."""
    sim = Simulation(load_scene("sedimenting_cell", ["mesh.nodes=162"]))
    x, faces = sim.mesh.points, sim.mesh.faces
    normal = sim.shape_geometry(x).normal
    op = fluids_fast.FmmFluid(x, faces, normal, 1.0, backend="direct", lump=math.inf)
    c, a3 = single_layer_matrix(x, faces), np.repeat(node_areas(x, faces), 3)
    f = np.random.default_rng(1).standard_normal(3 * len(x))
    dense = 0.5 * (a3 * (c @ f) + c.T @ (a3 * f)) + op._c * op._w * (op._w @ f)
    assert np.abs(op.single(f) - dense).max() < 1e-12 * np.abs(dense).max()


def test_fmm_applies_the_same_single_layer_as_the_direct_sums():
    """fmm3dpy at its precision 1e-9 against the Taichi kernel's direct sums (same quadrature, same
    corrections): the products agree to 1e-8 of their size (a consistency check)."""
    pytest.importorskip("fmm3dpy")
    sim = Simulation(load_scene("sedimenting_cell", ["mesh.nodes=162"]))
    x, faces = sim.mesh.points, sim.mesh.faces
    normal = sim.shape_geometry(x).normal
    f = np.random.default_rng(1).standard_normal(3 * len(x))
    out = {b: fmm_fluid(x, faces, normal, mu_in=1.0, mu_out=1.0, backend=b).single(f) for b in ("direct", "fmm")}
    assert np.abs(out["fmm"] - out["direct"]).max() < 1e-8 * np.abs(out["direct"]).max()


def test_without_fmm3dpy_one_line_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "fmm3dpy", None)  # import fmm3dpy then raises ImportError
    with pytest.raises(SolverError) as err:
        require_fmm()
    assert str(err.value) == FMM_MISSING and "cortex-ti[fluids]" in FMM_MISSING and "\n" not in FMM_MISSING
    import importlib.util

    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "fmm3dpy" else object())
    with pytest.raises(SceneError, match="install the extra fluids"):
        load_scene("sedimenting_cell", ["fluid.solver=fmm"])
    # auto never picks fmm: it runs without the extra
    assert load_scene("sedimenting_cell", ["mesh.nodes=2562"]).settings.fluid.solver == "direct"


def test_a_too_stale_preconditioner_is_refactorised_and_the_solve_still_meets_the_tolerance(monkeypatch):
    """The coupled GMRES reuses its LU for ``REFACTOR_EVERY`` solves; a solve that the old LU does not
    bring to the tolerance in ``STALE_ITERATIONS`` (here 1, to force it) factorises its own operator
    and continues. Its velocity is then a solution to the tolerance: within ``10 KRYLOV_RTOL`` of a
    fresh solver's on the same deformed shape (both solve the same discrete system to 1e-6)."""
    from cortex_ti.solve import fluid_krylov

    monkeypatch.setattr(fluid_krylov, "STALE_ITERATIONS", 1)
    sim = Simulation(load_scene("furrow_in_fluid", ["mesh.nodes=162", "fluid.solver=direct"]))
    x = sim.mesh.points
    sim.solve(x)
    bent = x * (1.0 + 0.05 * x[:, 2:] ** 2)
    stale = sim.solve(bent)
    krylov = sim.solver._fluid_krylov
    assert stale.info.refactored and krylov.n_factorizations == 2 and stale.info.iterations > 1
    assert stale.info.kkt_residual <= KRYLOV_RTOL
    fresh = Simulation(load_scene("furrow_in_fluid", ["mesh.nodes=162", "fluid.solver=direct"])).solve(bent)
    v = fresh.velocity
    assert np.abs(stale.velocity - v).max() < 10 * KRYLOV_RTOL * np.abs(v).max()
