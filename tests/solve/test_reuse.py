"""The solve that reuses work across steps: GMRES preconditioned on the right by an earlier
factorisation, the rule that decides when to refactorise, and the backends' registry.

Truths: a dense LAPACK solve of the same bordered equations (an independent method), with the
bound the GMRES tolerance gives (forward error <= condition number x relative residual); the
GMRES residual measured independently of its recurrence.
"""

from __future__ import annotations

import numpy as np
import pytest

from cortex_ti.errors import SolverError
from cortex_ti.scene import load_scene
from cortex_ti.simulation.core import Simulation
from cortex_ti.solve import factorizations
from cortex_ti.solve.constrained import ConstrainedSolver, RefactorRule
from cortex_ti.solve.factorizations import FACTORIZATIONS, choose_factorization
from cortex_ti.solve.krylov import gmres_right

pytestmark = pytest.mark.usefixtures("taichi_runtime")

RTOL = 1e-10


def test_gmres_right_meets_the_true_residual():
    """On a nonsymmetric system with a rough preconditioner: converged means the residual
    ``|b - A x|`` recomputed from scratch is within the tolerance (up to the recurrence's
    rounding, ~1e-15 |A| |x|), and the answer matches LAPACK's to the bound cond(A) x rtol."""
    rng = np.random.default_rng(3)
    n = 60
    a = np.eye(n) * 4.0 + rng.normal(size=(n, n)) / np.sqrt(n)
    b = rng.normal(size=n)
    diag = np.diag(a).copy()
    x, it, ok = gmres_right(lambda v: a @ v, lambda v: v / diag, b, np.zeros(n), RTOL, n)
    assert ok and 0 < it < n
    assert np.linalg.norm(b - a @ x) <= 1.01 * RTOL * np.linalg.norm(b)
    exact = np.linalg.solve(a, b)
    assert np.linalg.norm(x - exact) <= np.linalg.cond(a) * RTOL * 1.01 * np.linalg.norm(exact)
    # too few iterations: not converged, and it says so
    _, it, ok = gmres_right(lambda v: a @ v, lambda v: v / diag, b, np.zeros(n), RTOL, 3)
    assert it == 3 and not ok


def _drifting_systems(n_nodes=162, steps=8, dt=0.02, formulation="rayleigh_p1"):
    """The systems of the first Euler steps of a furrow (the shape moves with v_n n)."""
    sim = Simulation(load_scene("furrow_p4_a1", [f"mesh.nodes={n_nodes}", f"numerics.formulation={formulation}"]))
    x = sim.mesh.points.copy()
    out = []
    for _ in range(steps):
        geometry = sim.shape_geometry(x)
        system = sim.system(geometry, dt)
        out.append((system, x.copy()))
        sol = sim.solve(x, dt)
        x = x + dt * np.einsum("nc,nc->n", sol.velocity, sol.normal)[:, None] * sol.normal
    return out


@pytest.fixture(scope="module")
def drifting():
    return _drifting_systems()


def _dense_truth(solver, system, points):
    """The bordered equations the solver builds, solved densely (LAPACK), and their condition."""
    b = solver._bordered_system(system, points)
    size = b.rhs.size
    dense = np.column_stack([b.matvec(e) for e in np.eye(size)])
    z = np.linalg.solve(dense, b.rhs)
    return b, z, np.linalg.cond(dense)


def test_reused_factorisation_solves_to_the_tolerance(drifting):
    """Each solve of the drifting sequence, reusing or not: the bordered residual recomputed
    here is at most rtol (1.01: its own rounding), and the solution is the dense solve's to
    cond x rtol. The sequence is solved with reuse (most solves iterate on an earlier
    factorisation: at least half) and the rule, told that a factorisation costs 5 iterations
    (SuperLU's is 25: it would wait longer than 8 steps), refactorises at least once."""
    solver = ConstrainedSolver("superlu", reuse=True, rtol=RTOL)
    solver.rule = RefactorRule(5.0)
    reused = 0
    for system, points in drifting:
        b, z, cond = _dense_truth(solver, system, points)
        x, _, info = solver.solve(system, points)
        reused += not info.refactored
        assert info.kkt_residual <= 1.01 * RTOL
        xz = b.split(z)[0]
        assert np.linalg.norm(x - xz) <= cond * RTOL * 1.01 * np.linalg.norm(z)
    assert reused >= len(drifting) // 2
    assert 2 <= solver.n_factorizations < len(drifting)


def test_least_squares_with_refinement_is_not_reused():
    """The paper's formulation (least squares, normal equations) with ``refine``: every solve
    factorises, so the refinement against the unsquared system keeps its accuracy (a GMRES solve
    of the normal equations would meet rtol on M^T M only). Without ``refine`` GMRES is tried and
    does not converge in 30 iterations at 162 nodes; the next solve then factorises without
    trying (backoff 1), the one after tries again, fails, and the backoff doubles."""
    seq = _drifting_systems(steps=4, formulation="paper")
    solver = ConstrainedSolver("superlu", reuse=True, refine=True)
    assert [solver.solve(system, x)[2].refactored for system, x in seq] == [True] * 4
    assert solver.n_iterations == 0
    solver = ConstrainedSolver("superlu", reuse=True, refine=False)
    infos = [solver.solve(system, x)[2] for system, x in seq]
    assert [i.iterations for i in infos] == [0, 30, 0, 30] and all(i.refactored for i in infos)


def test_refactor_rule_follows_the_mean_cost():
    """The rule on iteration counts that grow by one per solve from 4: with a factorisation
    costing F iterations the mean cost per solve of a cycle of m solves is
    (F + 2 + sum_{j<m} (4 + j)) / m; its minimum over m is where the rule refactorises."""
    for factor_cost in (5.0, 15.0, 60.0):
        rule = RefactorRule(factor_cost)
        rule.factorized()
        solves = 1
        while not rule.due:
            rule.iterated(3 + solves)
            solves += 1
        means = [(factor_cost + 2 + sum(4 + j for j in range(m - 1))) / m for m in range(1, 40)]
        best = int(np.argmin(means)) + 1
        # due after solve m means the last cost exceeded the mean: the cycle of m - 1 solves
        # was the cheapest one (or tied)
        assert abs((solves - 1) - best) <= 1


@pytest.mark.parametrize("name", [k for k in FACTORIZATIONS if k != "superlu"])
def test_backends_give_superlus_solution(drifting, name):
    """Each installed backend solves the furrow's first system as SuperLU does (direct solves,
    both backward stable: to cond x 1e-14)."""
    if not FACTORIZATIONS[name].available():
        pytest.skip(f"{name} is not installed")
    system, points = drifting[0]
    _, _, cond = _dense_truth(ConstrainedSolver("superlu"), system, points)
    x0, _, _ = ConstrainedSolver("superlu").solve(system, points)
    x1, _, info = ConstrainedSolver(name).solve(system, points)
    assert info.backend == name
    assert np.linalg.norm(x1 - x0) <= cond * 1e-14 * np.linalg.norm(x0)


def test_missing_backend_says_what_to_install(monkeypatch):
    monkeypatch.setattr(FACTORIZATIONS["cholmod"], "available", staticmethod(lambda: False))
    with pytest.raises(SolverError, match=r"'cholmod' is not installed here \(pip install scikit-sparse.*use auto"):
        choose_factorization("cholmod")
    assert choose_factorization("auto").name in factorizations.AUTO_ORDER


def test_gmres_left_is_scipys_with_the_residual_from_its_products():
    """:func:`gmres_left` against SciPy's left-preconditioned GMRES (an independent implementation):
    the same iterate to rounding (the same Krylov space and stopping test), the same iteration count,
    one product an iteration plus ``x0``'s, and the residual it returns is ``b - A x`` recomputed
    from scratch (to the recurrence's rounding, ~1e-15 |A| |x|); too few iterations: not converged."""
    from scipy.sparse.linalg import LinearOperator, gmres

    from cortex_ti.solve.krylov import gmres_left

    rng = np.random.default_rng(5)
    n = 80
    a = np.diag(rng.uniform(1.0, 1e3, n)) + rng.normal(size=(n, n))  # rows of unrelated scales
    b, x0 = rng.normal(size=n), rng.normal(size=n)
    diag = np.diag(a).copy()
    calls = [0]

    def product(v):
        calls[0] += 1
        return a @ v

    x, r, it, ok = gmres_left(product, lambda v: v / diag, b, x0, 1e-9, n)
    count = [0]
    ref, info = gmres(
        LinearOperator((n, n), matvec=lambda v: a @ v, dtype=float),
        b,
        x0=x0,
        M=LinearOperator((n, n), matvec=lambda v: v / diag, dtype=float),
        rtol=1e-9,
        atol=0.0,
        restart=200,
        callback=lambda _: count.__setitem__(0, count[0] + 1),
        callback_type="pr_norm",
    )
    assert ok and info == 0 and it == count[0] and calls[0] == it + 1
    assert np.linalg.norm(x - ref) <= 1e-12 * np.linalg.norm(ref)
    assert np.linalg.norm(r - (b - a @ x)) <= 1e-14 * np.linalg.norm(a) * np.linalg.norm(x)
    assert np.linalg.norm(r) <= 1e-9 * np.linalg.norm(b)
    _, _, it, ok = gmres_left(lambda v: a @ v, lambda v: v / diag, b, x0, 1e-9, 3)
    assert it == 3 and not ok


def test_fluid_guess_extrapolates_in_the_step_ratios_read_off_the_shapes():
    """The coupled fluid solve's initial guess (:mod:`cortex_ti.solve.fluid_krylov`): nodes moving on
    straight lines at fixed speeds, solves at unequally spaced times (a step doubled, then shrunk, as
    bdf2's), a solution quadratic in time: the guess from three solutions is that solution at the new
    time (to rounding), from two the linear extrapolation in the true time ratio, and without motion
    (the same shape twice) the last solution alone."""
    from cortex_ti.solve.fluid_krylov import FluidKrylov

    rng = np.random.default_rng(1)
    x0, speed = rng.normal(size=(40, 3)), rng.normal(size=(40, 3))
    a, b, c = rng.normal(size=(3, 25))

    def z(t):
        return a + b * t + c * t * t

    times = [0.3, 0.5, 0.9, 1.2]
    solver = FluidKrylov()
    guesses = []
    for t in times:
        guesses.append(solver._guess(25, x0 + t * speed))
        solver._solutions = (solver._solutions + [z(t)])[-3:]
    assert guesses[0] is None and np.array_equal(guesses[1], z(0.3))
    linear = z(0.5) + (0.9 - 0.5) / (0.5 - 0.3) * (z(0.5) - z(0.3))
    assert np.allclose(guesses[2], linear, rtol=0, atol=1e-12)
    assert np.allclose(guesses[3], z(1.2), rtol=0, atol=1e-12)
    assert not np.allclose(linear, z(0.9), atol=1e-3)  # the quadratic term is there to be missed
    solver.new_mesh()
    for _ in range(3):
        last = rng.normal(size=25)
        solver._guess(25, x0)
        solver._solutions = (solver._solutions + [last])[-3:]
    assert np.array_equal(solver._guess(25, x0), last)


def test_fluid_guess_keeps_the_degree_that_predicted_best():
    """The guess's degree follows the last prediction: solutions smooth in time (a quadratic) keep the
    quadratic; solutions that are a constant plus independent noise (short steps, where the solutions'
    own errors dominate) fall to the last solution alone, which amplifies the noise least."""
    from cortex_ti.solve.fluid_krylov import FluidKrylov

    rng = np.random.default_rng(2)
    x0, speed = rng.normal(size=(30, 3)), rng.normal(size=(30, 3))
    a, b, c = rng.normal(size=(3, 20))
    for noisy, degree in ((False, 2), (True, 0)):
        solver = FluidKrylov()
        for t in np.arange(6) * 0.1:
            solver._guess(20, x0 + t * speed)
            z = a + 1e-6 * rng.normal(size=20) if noisy else a + b * t + c * t * t
            solver._score(z)
            solver._solutions = (solver._solutions + [z])[-3:]
        assert solver._degree == degree
