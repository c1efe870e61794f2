"""StabilityGuard: the checks that stop a run going unstable or losing its meaning."""

from types import SimpleNamespace

import numpy as np
import pytest

from cortex_ti.dynamics.guard import StabilityGuard
from cortex_ti.dynamics.schemes import Evaluation
from cortex_ti.errors import StabilityError
from cortex_ti.surface.mesh import icosphere


def _evaluation(points, normal, residual=1e-6):
    """A solve at ``points`` with no flow, these normals and this relative residual."""
    return Evaluation(
        points=points,
        velocity=np.zeros_like(points),
        normal=normal,
        pressure=0.0,
        solution=SimpleNamespace(info=SimpleNamespace(relative_residual=residual)),
    )


def test_guard_stops_a_collapsing_mesh_and_an_unsatisfied_balance():
    """StabilityGuard's resolution checks, on hand-made steps: a triangle squashed below 0.2 of the
    starting smallest angle, and a solve whose relative residual exceeds 0.05."""
    mesh = icosphere(42)
    x0 = mesh.points
    edge = np.full(len(x0), 10.0)  # large: only the resolution checks can fire

    def ev(points, residual):
        return _evaluation(points, points, residual)

    guard = StabilityGuard(faces=mesh.faces)
    guard.check(0.01, 0.01, x0, x0.copy(), ev(x0, 1e-3), edge)  # a healthy step passes
    a, b, c = mesh.faces[0]
    squashed = x0.copy()
    squashed[a] = 0.5 * (x0[b] + x0[c]) + 0.01 * (x0[a] - 0.5 * (x0[b] + x0[c]))  # corner a onto edge bc
    with pytest.raises(StabilityError, match="mesh is collapsing") as exc:
        guard.check(0.02, 0.01, x0, squashed, ev(x0, 1e-3), edge)
    assert "the mesh is distorted: remesh" in str(exc.value)  # the flow does not blow up
    with pytest.raises(StabilityError, match="no longer satisfied"):
        StabilityGuard(faces=mesh.faces).check(0.01, 0.01, x0, x0.copy(), ev(x0, 0.2), edge)


def test_guard_names_an_extensile_tension_as_a_physical_instability():
    """A blow-up under zeta < 0 is the physics (a negative tension does work on any wrinkle that adds
    area): the guard says so instead of asking for a smaller step; under zeta >= 0 it asks for one."""
    from cortex_ti.dynamics.guard import extensile_tension

    mesh = icosphere(42)
    x0 = mesh.points
    edge = np.full(len(x0), 1e-3)  # every node moves by far more than its edge
    ev = _evaluation(x0, x0)
    moved = 1.1 * x0
    with pytest.raises(StabilityError, match="physically unstable") as exc:
        StabilityGuard(zeta=np.full(len(x0), -1.0)).check(0.01, 0.01, x0, moved, ev, edge)
    assert "zeta < 0 everywhere, down to -1" in str(exc.value) and "try time.dt" not in str(exc.value)
    with pytest.raises(StabilityError, match="try time.dt=0.0025") as exc:
        StabilityGuard(zeta=np.ones(len(x0))).check(0.01, 0.01, x0, moved, ev, edge)
    assert "physically" not in str(exc.value)
    zeta = np.ones(len(x0))
    zeta[:3] = -0.5
    assert f"zeta < 0 at 3 of {len(x0)} nodes, down to -0.5" in extensile_tension(zeta)
    assert extensile_tension(np.zeros(5)) is None


def test_guard_tells_a_closing_neck_from_an_unstable_step():
    """An hourglass whose waist (radius 0.05 R0) is narrower than two edge lengths across: a node
    moving too far there is the neck closing (physical), not a step to shorten; on the sphere the
    same move asks for a shorter step."""
    from cortex_ti.dynamics.guard import closing_neck
    from cortex_ti.surface.mesh import vertex_normals

    mesh = icosphere(642)
    x = mesh.points.copy()
    x[:, :2] *= (1.0 - 0.95 * np.exp(-((x[:, 2] / 0.35) ** 2)))[:, None]
    normals = vertex_normals(x, mesh.faces)
    edge = np.full(len(x), 0.1)
    i, gap = closing_neck(x, mesh.faces, normals)
    assert abs(x[i, 2]) < 0.2 and gap < 0.3  # at the waist, across it
    moved = x + np.array([0.0, 0.0, 0.2])  # every node moves two edge lengths (the shape does not change)
    with pytest.raises(StabilityError, match="the neck is closing") as exc:
        StabilityGuard(faces=mesh.faces).check(0.01, 0.01, x, moved, _evaluation(x, normals), edge)
    assert "try time.dt" not in str(exc.value)
    sphere = mesh.points
    with pytest.raises(StabilityError, match="try time.dt=0.0025"):
        StabilityGuard(faces=mesh.faces).check(0.01, 0.01, sphere, 1.3 * sphere, _evaluation(sphere, sphere), edge)


def test_guard_says_a_hundredfold_shorter_adaptive_step_is_not_the_cure():
    """An adaptive scheme that has cut its step from 0.1 to 1e-4 and still blows up: the guard does
    not ask for a shorter step, it says one will not help."""
    mesh = icosphere(162)
    x = mesh.points
    guard = StabilityGuard(faces=mesh.faces)
    guard.check(0.1, 0.1, x, x.copy(), _evaluation(x, x), np.full(len(x), 1.0))
    with pytest.raises(StabilityError, match="already fallen from 0.1 to 0.0001") as exc:
        guard.check(0.1001, 1e-4, x, 1.3 * x, _evaluation(x, x), np.full(len(x), 0.01))
    assert "try time.dt" not in str(exc.value)


def test_guard_stops_a_myosin_spot_the_mesh_cannot_resolve():
    """A myosin density gathered into a spot narrower than two rings of nodes at half its height is a
    resolution problem, and the guard says so; a wide peak (a cap over many nodes) and a weak one pass."""
    from cortex_ti.dynamics.state import State

    mesh = icosphere(642)
    x0 = mesh.points
    edge = np.full(len(x0), 10.0)
    angle = np.arccos(np.clip(x0[:, 2], -1.0, 1.0))  # from the north pole, node 0's direction need not matter

    def ev(density):
        e = _evaluation(x0, x0)
        e.state = State(x0, {"myosin": density})
        return e

    guard = StabilityGuard(faces=mesh.faces)
    wide = 1.0 + 7.0 * np.exp(-((angle / 0.6) ** 2))  # half height at 0.5 rad, ~3 edges: 37 nodes
    guard.check(0.1, 0.01, x0, x0.copy(), ev(wide), edge)
    weak = 1.0 + 1.5 * (angle == angle.min())  # one node, but only 2.5 times the median
    guard.check(0.2, 0.01, x0, x0.copy(), ev(weak), edge)
    narrow = 1.0 + 7.0 * np.exp(-((angle / 0.05) ** 2))  # 0.05 rad, below the edge (~0.15 at 642 nodes)
    with pytest.raises(StabilityError, match="spot the mesh cannot resolve") as exc:
        guard.check(0.3, 0.01, x0, x0.copy(), ev(narrow), edge)
    # a band one node wide along half the equator has few nodes at half height too, but it is not a spot
    h = np.full(len(x0), 0.15)  # the edge length at 642 nodes
    band = 1.0 + 7.0 * ((np.abs(x0[:, 2]) < 0.02) & (x0[:, 0] > 0.0))
    assert 0 < np.count_nonzero(band > 1.0) < 19
    StabilityGuard(faces=mesh.faces).check(0.1, 0.01, x0, x0.copy(), ev(band), h)
    with pytest.raises(StabilityError, match="spot the mesh cannot resolve"):
        StabilityGuard(faces=mesh.faces).check(0.1, 0.01, x0, x0.copy(), ev(narrow), h)
    assert "not the time step" in str(exc.value) and "mesh.nodes" in str(exc.value)


def test_a_solve_failing_while_the_myosin_collapses_is_a_resolution_problem():
    """At 2562 nodes the noise scene's solve fails while its cap still spans ~90 nodes at half height:
    a failed solve from a state whose myosin has a strong peak (above 3 times the median) is said to
    be the collapse outrunning the mesh, with the solver's words; without one the error is unchanged."""
    from cortex_ti.dynamics.state import State
    from cortex_ti.errors import SolverError

    mesh = icosphere(642)
    x0 = mesh.points
    angle = np.arccos(np.clip(x0[:, 2], -1.0, 1.0))
    err = SolverError("the solve at t = 12.44 failed: PARDISO -4")
    guard = StabilityGuard(faces=mesh.faces)
    e = _evaluation(x0, x0)
    e.state = State(x0, {"myosin": 1.0 + 12.0 * np.exp(-((angle / 0.6) ** 2))})
    said = guard.failed_solve(err, e)
    assert isinstance(said, StabilityError) and "PARDISO -4" in str(said)
    assert "collapsing into a spot" in str(said) and "not the time step" in str(said)
    e.state = State(x0, {"myosin": 1.0 + 0.5 * np.exp(-((angle / 0.6) ** 2))})  # a weak pattern
    assert guard.failed_solve(err, e) is err
    assert guard.failed_solve(err, _evaluation(x0, x0)) is err  # no myosin


def test_guard_names_where_a_collapsed_step_meets_a_compressed_cortex():
    """A sphere contracting uniformly, v = -x: strain rate -P, tr U = -2, no shear, so the stress is
    zeta + eta_b tr U = 1 - 2 = -1 on every triangle (surface_stress's closed form): the guard that was
    given the viscosities says the stress is compressive there; without them it says what it said."""
    mesh = icosphere(162)
    x = mesh.points

    def ev(points):
        e = _evaluation(points, points)
        e.velocity = -points
        return e

    for viscosity, said in (((1.0, 1.0), "compressive on 320 triangles (down to -1 "), (None, "a mode of this")):
        guard = StabilityGuard(faces=mesh.faces, zeta=np.ones(len(x)), viscosity=viscosity)
        guard.check(0.1, 0.1, x, x.copy(), _evaluation(x, x), np.full(len(x), 1.0))
        with pytest.raises(StabilityError, match="already fallen") as exc:
            guard.check(0.1001, 1e-4, x, 1.3 * x, ev(x), np.full(len(x), 0.01))
        assert said in str(exc.value)


def test_the_run_names_compression_only_for_a_cortex_without_bending_resistance():
    """The run's guard is given the in-plane viscosities (so a stop names the compressed triangles, where a
    cortex wrinkles at the mesh scale) only without bending resistance: neither bending viscosity nor
    bending rigidity. A rigid cortex compressed after its cut (cytokinesis_rigid's daughters at a
    5124-node budget) was told it "has no bending resistance"."""
    from cortex_ti.simulation.run import _guard

    def sim(effects, eta_bar=0.0, kappa=0.0):
        ph = SimpleNamespace(effects=set(effects), eta_bar=eta_bar, eta_bar_b=0.0, eta_s=1.0, eta_b=2.0, kappa=kappa)
        return SimpleNamespace(physics=ph, mesh=SimpleNamespace(faces=np.zeros((1, 3), int)), zeta=None, settings=None)

    base = ["shear_viscosity", "bulk_viscosity"]
    assert _guard(sim(base)).viscosity == (1.0, 2.0)
    assert _guard(sim([*base, "bending_viscosity"], eta_bar=0.1)).viscosity is None
    assert _guard(sim([*base, "bending_rigidity"], kappa=0.1)).viscosity is None
    assert _guard(sim([*base, "bending_rigidity"], kappa=0.0)).viscosity == (1.0, 2.0)
