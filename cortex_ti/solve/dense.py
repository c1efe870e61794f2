r"""The dense solve of an energy system with a dense part (the fluids' dissipation, effect ``fluids``).

``(K + D) x + F^T lambda = f``, ``G x = 0``: ``K`` the sparse cortex dissipation (positive
semidefinite), ``D`` a dense symmetric positive definite block (the fluids'), so ``A = K + D`` is
definite without any gauge: one dense Cholesky factorisation of ``A`` (``3N`` unknowns), the ``m``
multipliers (the volume's: a handful) by the Schur complement ``G A^-1 F^T lambda = G A^-1 f``, then
one step of iterative refinement on the whole bordered system. The cost is ``(3N)^3 / 3`` flops and
``(3N)^2`` doubles, the same order as building ``D`` (docs/guide/fluids.md gives the measured cost
and the mesh size the scene rules allow). A matrix that is not positive definite (a dense part that
is not, or an absurd viscosity or step) is one :class:`~cortex_ti.errors.SolverError`.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as sla

from ..errors import SolverError
from .system import EnergySystem, SolveInfo

__all__ = ["DENSE_BACKEND", "solve_dense"]

#: the name :class:`~cortex_ti.solve.system.SolveInfo` reports for this solve
DENSE_BACKEND = "dense-cholesky"


def _kkt(chol, g: np.ndarray, fr: np.ndarray, f: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(x, lambda)`` of ``A x + F^T lambda = f``, ``G x = c`` from the Cholesky factor of ``A``."""
    z = sla.cho_solve(chol, np.column_stack([f, fr.T]), check_finite=False)
    zf, zb = z[:, 0], z[:, 1:]
    if g.shape[0] == 0:
        return zf, np.zeros(0)
    lam = np.linalg.solve(g @ zb, g @ zf - c)
    return zf - zb @ lam, lam


def solve_dense(system: EnergySystem):
    """``(x, pressure, multipliers, info)`` of ``system`` (module docstring); ``info`` a
    :class:`~cortex_ti.solve.system.SolveInfo`."""
    t0 = time.perf_counter()
    a = system.stiffness.toarray()
    a += system.dense
    g = system.constraints
    fr = g if system.force_rows is None else system.force_rows
    f = system.rhs
    t1 = time.perf_counter()
    try:
        chol = sla.cho_factor(a, lower=True, overwrite_a=True, check_finite=False)  # a is the factor now
    except np.linalg.LinAlgError as err:
        raise SolverError(
            f"the dense force balance with the fluids is not positive definite ({err}): check the fluids' "
            "viscosities (fluid.inner, fluid.outer), time.dt and the mesh"
        ) from None
    x, lam = _kkt(chol, g, fr, f, np.zeros(g.shape[0]))
    # one step of iterative refinement on the bordered system
    r1 = f - system.stiffness @ x - system.dense @ x - fr.T @ lam
    dx, dlam = _kkt(chol, g, fr, r1, -(g @ x))
    x, lam = x + dx, lam + dlam
    t2 = time.perf_counter()
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(lam))):
        raise SolverError("the dense solve with the fluids produced non-finite values: check the viscosities")
    res = system.stiffness @ x + system.dense @ x + fr.T @ lam - f
    gx = g @ x
    fnorm = float(np.linalg.norm(f))
    xnorm = max(float(np.linalg.norm(x)), 1e-300)
    gscale = np.linalg.norm(g, axis=1)
    gscale[gscale == 0] = 1.0
    info = SolveInfo(
        backend=DENSE_BACKEND,
        force_residual=float(np.linalg.norm(res)),
        rhs_norm=fnorm,
        constraint_violation=float((np.abs(gx) / (gscale * xnorm)).max()) if gx.size else 0.0,
        kkt_residual=float(np.sqrt(res @ res + gx @ gx) / max(fnorm, 1e-300)),
        seconds={"normal_equations": t1 - t0, "iterate": 0.0, "factor_solve": t2 - t1},
    )
    return x, system.pressure(lam), lam, info
