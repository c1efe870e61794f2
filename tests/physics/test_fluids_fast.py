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

import sys

import numpy as np
import pytest

from cortex_ti.errors import SceneError, SolverError
from cortex_ti.physics.fluids_fast import FMM_MISSING, fmm_fluid, require_fmm
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
    return {s: solve("sedimenting_cell", 162, s) for s in ("dense", "direct")}


def test_direct_agrees_with_dense_to_the_krylov_tolerance_regression(sediment162):
    """Consistency (not a truth): the same discrete operator, so the velocities differ by the
    GMRES tolerance; measured 8.1e-8 of max |v| (furrow_in_fluid, 162 nodes) at rtol 1e-7."""
    vd = sediment162["dense"][2].velocity
    sim, _, sol = sediment162["direct"]
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


@pytest.mark.parametrize("solver", ["direct", "fmm"])
def test_the_matrix_free_solves_refuse_a_viscosity_contrast(solver):
    with pytest.raises(SceneError, match="equal viscosities"):
        load_scene("sedimenting_cell", [f"fluid.solver={solver}", "fluid.inner=0.5"])
    # auto keeps a contrast on the dense path
    assert load_scene("sedimenting_cell", ["mesh.nodes=162", "fluid.inner=0.5"]).settings.fluid.solver == "dense"
