"""An :class:`~cortex_ti.solve.system.EnergySystem` with a low-rank part ``K + U V^T`` (the dissipation
of the non-rigid part of formulation ``rayleigh_p2``'s centroid gauge) against the dense solve of the
same optimality conditions (numpy), also Petrov-Galerkin and with the iterative refinement and the
reuse of the last factorisation. Bound: the dense solve's own error, ``cond * eps`` (conditions
below 1e4 here)."""

import numpy as np
import pytest
import scipy.sparse as sp

from cortex_ti.solve.constrained import ConstrainedSolver
from cortex_ti.solve.system import EnergySystem


def _problem(seed: int, petrov: bool):
    rng = np.random.default_rng(seed)
    n = 20
    a = rng.standard_normal((3 * n, 3 * n))
    k = a @ a.T / (3 * n) + np.eye(3 * n)
    u, v = rng.standard_normal((3 * n, 3)), rng.standard_normal((3 * n, 3))
    u = u - 0.2 * (k @ v)  # K + U V^T not symmetric, still invertible on the constraints
    g = rng.standard_normal((2, 3 * n))
    f = rng.standard_normal(3 * n)
    frows = g + 0.3 * rng.standard_normal(g.shape) if petrov else None
    system = EnergySystem(
        stiffness=sp.csr_matrix(k),
        rhs=f,
        constraints=g,
        constraint_names=["a", "b"],
        basis=np.broadcast_to(np.eye(3), (n, 3, 3)).copy(),
        force_rows=frows,
        low_rank=(u, v),
    )
    f_rows = g if frows is None else frows
    kkt = np.block([[k + u @ v.T, f_rows.T], [g, np.zeros((2, 2))]])
    exact = np.linalg.solve(kkt, np.concatenate([f, [0.0, 0.0]]))
    points = rng.standard_normal((n, 3))
    return system, points, exact, np.linalg.cond(kkt)


@pytest.mark.parametrize("petrov", [False, True])
@pytest.mark.parametrize("refine", [False, True])
def test_a_low_rank_part_is_solved_exactly(petrov, refine):
    system, points, exact, cond = _problem(0, petrov)
    solver = ConstrainedSolver("superlu", reuse=True, rtol=1e-13, refine=refine)
    x, _, info = solver.solve(system, points)
    scale = np.abs(exact[: x.size]).max()
    assert np.abs(x - exact[: x.size]).max() < 1e3 * cond * np.finfo(float).eps * scale
    assert np.linalg.norm(system.residual(x, solver.last_solution)) < 1e-10 * np.linalg.norm(system.rhs)
    # the next solve of a nearby system reuses the factorisation (GMRES): the same answer
    system.rhs = system.rhs * 1.01
    x2, _, _ = solver.solve(system, points)
    assert np.abs(x2 - 1.01 * exact[: x.size]).max() < 1e-9 * scale
