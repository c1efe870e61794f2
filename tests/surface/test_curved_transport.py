"""A density on the curved cells of ``rayleigh_p2`` (cortex_ti.surface.curved_transport, and the state
and run that use it) against independent truths, derived in docs/derivations/curved_transport.md:

* the exact sphere flow of a tension ``1 + eps Y_l0`` (eta_s = eta_b = 1) dilutes a uniform density at
  ``-div v = eps Y_l0`` exactly; through the curved transport (the flow relative to the mesh carried,
  the rest by the normal motion of the cells) the rate, projected on ``Y_l0`` in the cells' mass,
  converges at order 4 (l = 1: mostly carried, tangential flow; l = 2: a normal flow, the area change);
* the curved Laplacian's Rayleigh quotient on ``Y_l0`` converges to ``l (l + 1)`` at order 4;
* ``dM/dt`` is the derivative of the consistent mass along a node motion (central differences);
* a run keeps the amount ``int c_h dA`` to round-off, whatever the mesh motion.

The order bounds: the derivation's order 4, less what the coarsest level's pre-asymptotic terms take
(measured 3.78-3.98 from 162 to 642 nodes, 3.94-4.00 from 642 to 2562): 3.5 to 4.5.
"""

import numpy as np
import pytest

from cortex_ti.dynamics.state import FieldTransport, Rates, State
from cortex_ti.surface.curved_transport import (
    cell_quadrature,
    curved_advective_rate,
    curved_content,
    curved_mass,
    curved_mass_rate,
    curved_stiffness,
)
from cortex_ti.surface.mesh import icosphere
from cortex_ti.surface.transport import DENSITY, dual_areas, implicit_diffusion_reaction
from cortex_ti.truth.sphere_exact import real_sph_harm, sphere_flow

LEVELS = (162, 642, 2562)


def _errors(nodes: int, l: int, eps: float = 1e-3) -> tuple[float, float]:
    """The relative errors of the dilution rate of the exact sphere flow and of the Laplacian's
    Rayleigh quotient, both on ``Y_l0`` in the curved cells' mass inner product."""
    m = icosphere(nodes)
    x, f = m.points, m.faces
    y = real_sph_harm(l, 0, x)
    v, _, _ = sphere_flow(lambda p: 1.0 + eps * real_sph_harm(l, 0, p), x, eta_s=1.0, eta_b=1.0, lmax=8, axis=[0, 0, 1])
    w = np.einsum("nc,nc->n", v, x)[:, None] * x  # the normal motion of the nodes (unit sphere: n = x)
    one = np.ones(len(x))
    quad = cell_quadrature(x, f)
    mass = curved_mass(x, f, quad)
    rate = curved_advective_rate(one, x, f, v - w, quad) - curved_mass_rate(x, f, w, quad) @ one  # M dc/dt
    norm = y @ (mass @ y)
    dilution = (y @ rate) / norm / eps - 1.0
    laplacian = (y @ (curved_stiffness(x, f, quad) @ y)) / norm / (l * (l + 1)) - 1.0
    return dilution, laplacian


def test_the_exact_sphere_flow_and_the_laplacian_converge_at_fourth_order():
    """Measured (l = 1 / l = 2) at 162, 642, 2562 nodes: dilution -1.5e-3 / -9.9e-3, -1.1e-4 / -7.2e-4,
    -6.9e-6 / -4.7e-5; Laplacian +1.5e-3 / +2.7e-3, +9.6e-5 / +1.7e-4, +6.1e-6 / +1.1e-5 (the flat
    dual cells: -1.7e-3 / -5.7e-3 and 0 / -1.4e-3 at 2562, order 2). The bound at 2562 nodes: the
    642 error over 2^3.5 (the smallest order allowed), with the margin of that choice."""
    for l in (1, 2):
        errs = np.array([_errors(n, l) for n in LEVELS])  # (level, [dilution, laplacian])
        orders = np.log2(np.abs(errs[:-1] / errs[1:]))
        assert np.all((orders > 3.5) & (orders < 4.5)), (l, errs, orders)
        assert np.all(np.abs(errs[-1]) < np.abs(errs[-2]) / 2**3.5), (l, errs)


def test_the_mass_rate_is_the_derivative_of_the_mass():
    """``dM/dt`` along a random motion of the nodes of a distorted shape against central differences of
    ``M`` (computed by the same quadrature, so the check is of the area element's derivative): the
    difference at h = 1e-4 is within its truncation error (h^2: a third of the change from 2e-4)."""
    rng = np.random.default_rng(4)
    m = icosphere(162)
    x = m.points * np.array([1.0, 1.1, 0.8]) + 0.05 * m.points[:, :1] ** 2
    w = rng.standard_normal(x.shape)
    exact = curved_mass_rate(x, m.faces, w).toarray()

    def central(h):
        return (curved_mass(x + h * w, m.faces) - curved_mass(x - h * w, m.faces)).toarray() / (2 * h)

    coarse, fine = central(2e-4), central(1e-4)
    truncation = np.abs(coarse - fine).max() / 3.0
    scale = np.abs(exact).max()
    assert np.abs(fine - exact).max() < 1.5 * truncation + 1e-9 * scale
    assert truncation < 1e-4 * scale  # resolved: the check is not void


def test_the_galerkin_transport_conserves_and_keeps_a_uniform_property_of_the_flow():
    """``sum_i dm_i/dt = 0`` for any velocity (``sum_i grad_h N_i = 0``), and a uniform density under a
    rigid rotation (divergence-free, tangent to the sphere) changes only at the geometric error of the
    cells: ``int u_h . grad_h N_i`` is ``-int N_i div_h u_h``, O(h^3) for a rotation of the curved cells.
    Bounds: round-off of ~N terms; the geometric error against the rate of a linear density: measured
    2.4e-3, 2.8e-4, 3.4e-5 at 162, 642, 2562 nodes (order 3), bounded by 1e-3 at 642."""
    rng = np.random.default_rng(5)
    m = icosphere(642)
    x = m.points * (1 + 0.05 * rng.standard_normal((642, 1)))
    u = rng.standard_normal((642, 3))
    c = 1 + rng.random(642)
    rate = curved_advective_rate(c, x, m.faces, u)
    assert abs(rate.sum()) < 1e-13 * np.abs(rate).sum()
    spin = np.cross([0.0, 0.0, 1.0], m.points)
    still = curved_advective_rate(np.ones(642), m.points, m.faces, spin)
    assert np.abs(still).max() < 1e-3 * np.abs(curved_advective_rate(m.points[:, 0], m.points, m.faces, spin)).max()


def test_the_flat_density_step_is_unchanged_regression():
    """Regression check (the code against its earlier self, not a truth): a density on the flat dual
    cells (rayleigh_p1, the default ``cells``) is still stepped as ``c A + dt r`` read back by
    ``implicit_diffusion_reaction``, bit for bit."""
    rng = np.random.default_rng(6)
    m = icosphere(162)
    x, f = m.points, m.faces
    c = 1.0 + 0.1 * rng.standard_normal(162)
    r = rng.standard_normal(162)
    r -= r.mean()
    speed = 0.1 * rng.standard_normal(x.shape)
    tr = FieldTransport(DENSITY, 0.05, 0.2, 1.0)
    new = State(x, {"c": c}, f).advanced(0.1, Rates(speed, {"c": r}), {"c": tr})
    stored = 1.0 * (c * dual_areas(x, f)) + 0.1 * r
    expect = implicit_diffusion_reaction(stored, DENSITY, 1.0 * x + 0.1 * speed, f, 0.1, 0.05, 0.2, 1.0)
    assert np.array_equal(new.fields["c"], expect)


@pytest.mark.parametrize("motion", ["ale", "lagrangian"])
def test_a_run_on_curved_cells_keeps_the_amount_of_myosin(tmp_path, motion):
    """A myosin run on rayleigh_p2 (diffusing, no turnover: the amount is conserved), its density carried
    by the flow relative to the moving nodes (ale) or glued to them (lagrangian: dilution alone): the
    amount ``int c_h dA`` on the curved cells of every frame equals the first to round-off (measured
    3.3e-16 relative over the 20 Heun steps, ale and lagrangian; the flat dual cells' amount of the same
    frames drifts by 7.1e-5 / 7.8e-5). Bound: 1e-13, a round-off of ~1e-16 per step with margin."""
    import h5py

    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    sets = [
        "mesh.nodes=162",
        "numerics.formulation=rayleigh_p2",
        f"mesh.motion={motion}",
        "fields.myosin.turnover=0",
        "fields.myosin.initial=[{type: harmonics, terms: [{l: 2, m: 0, coeff: -0.2}, {l: 1, m: 0, coeff: 0.1}]}]",
        "time.t_end=0.2",
        "time.save_every=0.1",
        "time.scheme=heun",
        "time.dt=0.01",
    ]
    out = tmp_path / "run.h5"
    Simulation(load_scene("myosin_ring", sets)).run(out, progress=False)
    with h5py.File(out) as h:
        pts, c, faces = h["points"][()], h["myosin"][()], h["triangles"][()]
    amount = np.array([curved_content(c[k], pts[k], faces).sum() for k in range(len(c))])
    assert len(amount) == 3 and np.ptp(pts[:, :, 2]) > 0  # frames written
    assert np.abs(amount / amount[0] - 1.0).max() < 1e-13, amount
    flat = np.array([(c[k] * dual_areas(pts[k], faces)).sum() for k in range(len(c))])
    assert np.abs(flat / flat[0] - 1.0).max() > 1e-8  # the frames do move and dilute: the check is not void


def test_the_numpy_cells_are_the_curved_surface_cells():
    """Two implementations of the same isoparametric cells agree (a cross-check, not a truth): the
    numpy quadrature here and the Taichi kernel of :func:`cortex_ti.surface.curved.curved_surface`
    (its area weights, and its gradients along the cell recovered by ``cell_grads``) on a distorted
    shape at 642 nodes; measured 1.7e-17 (weights up to 1.1e-2) and 7.4e-14 (gradients up to 18).
    Bounds: round-off of the area element and of the gradients' recovery through the smooth normal,
    with margin."""
    from cortex_ti.surface.curved import GAUSS_POINTS, curved_surface, triangle_rule
    from cortex_ti.surface.fits import StencilChooser
    from cortex_ti.surface.geometry import compute_geometry
    from cortex_ti.surface.mesh import Mesh
    from cortex_ti.surface.topology import build_topology

    m = icosphere(642)
    x = m.points * np.array([1.0, 1.1, 0.8]) + 0.05 * m.points[:, :1] ** 2
    topo = build_topology(Mesh(x, m.faces))
    geometry = compute_geometry(x, topo, StencilChooser(topo, "quartic"))
    surf = curved_surface(geometry, m.faces, rule=triangle_rule(GAUSS_POINTS))  # the transport's rule
    _, _, weight, grads = cell_quadrature(x, m.faces)
    assert np.abs(surf.weight - weight).max() < 1e-15
    assert np.abs(surf.cell_grads() - grads).max() < 1e-11 * np.abs(grads).max()


@pytest.mark.slow
def test_a_resumed_myosin_run_on_curved_cells_reproduces_the_whole_run_regression(tmp_path):
    """Regression check of the code against itself (as tests/surface/test_transport.py's resume test
    for the flat cells): a rayleigh_p2 myosin run (ale, carried, diffusing, turning over) resumed from a
    frame reproduces the uninterrupted run; each solve after the resume starts without the reused
    factorisation, so within solver.rtol times the steps times the field's scale."""
    import shutil

    import xarray as xr

    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    sets = ["mesh.nodes=162", "numerics.formulation=rayleigh_p2", "mesh.motion=ale", "time.save_every=0.04"]
    sets += ["time.scheme=euler", "time.dt=2e-2"]
    Simulation(load_scene("myosin_ring", sets + ["time.t_end=0.08"])).run(tmp_path / "a.h5", progress=False)
    shutil.copy(tmp_path / "a.h5", tmp_path / "b.h5.partial")
    whole = Simulation(load_scene("myosin_ring", sets + ["time.t_end=0.16"]))
    whole.run(tmp_path / "c.h5", progress=False)
    Simulation(load_scene("myosin_ring", sets + ["time.t_end=0.16"])).run(
        tmp_path / "b.h5", resume=True, progress=False
    )
    b = xr.load_dataset(tmp_path / "b.h5", engine="h5netcdf")
    c = xr.load_dataset(tmp_path / "c.h5", engine="h5netcdf")
    assert b.sizes["time"] == c.sizes["time"] == 5, (b.time.values, c.time.values)
    steps = round(0.08 / whole.settings.time.dt)
    for var in ("points", "myosin"):
        scale = np.abs(c[var].values).max()
        np.testing.assert_allclose(
            b[var].values, c[var].values, rtol=0, atol=whole.settings.solver.rtol * steps * scale
        )
    assert np.ptp(b.myosin.values[-1] - b.myosin.values[0]) > 0  # the myosin moved
