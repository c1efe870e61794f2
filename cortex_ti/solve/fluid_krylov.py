r"""The matrix-free solve of an energy system coupled to the fluids (``fluid.solver: fmm``, issue 36).

The dense path (:mod:`cortex_ti.solve.dense`) factorises ``K + D``, ``D = mu A V'^{-1} A`` the
fluids' dissipation (docs/method/fluids.md). Here neither ``V'^{-1}`` nor ``K + D`` is formed: the
traction density ``f = V'^{-1} A (v - u_inf)`` is carried as unknowns and the coupled system

.. math::
    \begin{pmatrix} K & \mu A & F^T \\ \mu A & -\mu V' & 0 \\ G & 0 & 0 \end{pmatrix}
    \begin{pmatrix} v \\ f \\ \lambda \end{pmatrix}
    = \begin{pmatrix} b \\ \mu A u_\infty \\ 0 \end{pmatrix}

(eliminating ``f`` gives the dense path's ``(K + D) v + F^T lambda = b + D u_inf``, ``G v = 0``) is
solved by GMRES, ``V'`` applied matrix-free by the fluid operator (``op.single``: the FMM and the
sparse near corrections, :mod:`cortex_ti.physics.fluids_fast`). Preconditioner: the same block matrix
with ``V'`` replaced by its local part ``op.local`` (the self-interactions, a diagonal ``L``): the
cortex operator exact, the fluids' DtN map by its local part. ``f`` is eliminated from it (``L``
is diagonal), leaving ``[[K + mu A L^-1 A, F^T], [G, 0]]``, half the unknowns, factorised by
``scipy.sparse.linalg.splu`` with the COLAMD ordering (0.12 CPU s at 2562 nodes against 0.39 for the
whole block matrix with minimum degree on ``A + A^T``; the same preconditioner, so the same
iterations). An approximation of the fluids' single layer by the sphere's translation coefficient
``2 R / 3`` instead took 42-50 iterations at 642 nodes for ``mu`` = 0.1, 1, 10
(docs/validation/fluids.md). The factorisation is redone on every solve; the initial guess is the
previous two solutions' linear extrapolation ``2 z_n - z_(n-1)`` (the previous one after a new
mesh: 268 iterations over furrow_in_fluid's 27 solves at 642 nodes against 286 with ``z_n``).

Tolerance :data:`KRYLOV_RTOL` on the coupled residual, tied to the time scheme's error: the velocity
is then off by about ``rtol |v|`` (measured 8.1e-8 of max |v| at 1e-7, 162 nodes), a step's
displacement by ``dt rtol |v|`` (< 2e-8 with ``dt`` < 0.2, ``|v|`` < 0.1 in furrow_in_fluid), two
hundred times below bdf2's local error target ``time.tol`` (4e-6 at 10242 nodes, 1.6e-5 at 2562).
Measured at 642 nodes over furrow_in_fluid to t = 3: rtol 1e-6 instead of 1e-7 moves every node by
at most 4.5e-8 and the furrow radius by 2.4e-8 (its discretisation error 8.9e-4), in 206 GMRES
iterations instead of 268.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError
from .krylov import gmres_left
from .system import EnergySystem, SolveInfo

__all__ = ["FluidKrylov", "KRYLOV_RTOL"]

#: GMRES's relative tolerance on the coupled system's residual
KRYLOV_RTOL = 1e-6


class FluidKrylov:
    """The coupled GMRES solve with what it reuses from one solve to the next (module docstring)."""

    def __init__(self, rtol: float = KRYLOV_RTOL, max_iterations: int = 600):
        self.rtol = rtol
        self.max_iterations = max_iterations
        self._lu = None
        self._previous: np.ndarray | None = None
        self._before: np.ndarray | None = None
        self.n_factorizations = 0
        self.n_iterations = 0

    def new_mesh(self) -> None:
        self._lu, self._previous, self._before = None, None, None

    def solve(self, system: EnergySystem, op):
        """``(x, pressure, multipliers, info)`` of ``system`` with the fluid operator ``op``."""
        t0 = time.perf_counter()
        k = system.stiffness.tocsr()
        g = np.asarray(system.constraints)
        fr = g if system.force_rows is None else np.asarray(system.force_rows)
        n3, m = k.shape[0], g.shape[0]
        mu, a3 = op.mu, op.areas3
        nt = 2 * n3 + m

        def apply(z):
            v, f, lam = z[:n3], z[n3 : 2 * n3], z[2 * n3 :]
            return np.concatenate([k @ v + mu * (a3 * f) + fr.T @ lam, mu * (a3 * v - op.single(f)), g @ v])

        rhs = np.zeros(nt)
        rhs[:n3] = system.rhs
        if op.far is not None:
            rhs[n3 : 2 * n3] = mu * a3 * op.far
        self._factor(k, g, fr, op)
        t1 = time.perf_counter()
        x0 = self._previous if self._previous is not None and self._previous.size == nt else None
        if x0 is not None and self._before is not None and self._before.size == nt:
            x0 = 2.0 * x0 - self._before
        z, res, its = self._gmres(apply, rhs, x0)
        self._before, self._previous = self._previous, z
        self.n_iterations += its
        t2 = time.perf_counter()
        if not np.all(np.isfinite(z)):
            raise SolverError("the fluids' coupled GMRES produced non-finite values: check the viscosities and time.dt")
        x, lam = z[:n3], z[2 * n3 :]
        fnorm = float(np.linalg.norm(rhs))
        gx = g @ x
        xnorm = max(float(np.linalg.norm(x)), 1e-300)
        gscale = np.linalg.norm(g, axis=1)
        gscale[gscale == 0] = 1.0
        info = SolveInfo(
            backend=op.name,
            force_residual=float(np.linalg.norm(res[:n3])),
            rhs_norm=float(np.linalg.norm(system.rhs)),
            constraint_violation=float((np.abs(gx) / (gscale * xnorm)).max()) if gx.size else 0.0,
            kkt_residual=float(np.linalg.norm(res) / max(fnorm, 1e-300)),
            iterations=its,
            refactored=True,
            seconds={"normal_equations": 0.0, "factor": t1 - t0, "iterate": t2 - t1, "factor_solve": t2 - t0},
        )
        return x, system.pressure(lam), lam, info

    def _factor(self, k, g, fr, op) -> None:
        """The preconditioner: the block matrix with ``V'`` replaced by its local part ``L`` (a
        diagonal), ``f`` eliminated (``f = (A v) / L - r_f / (mu L)``): the sparse LU of the reduced
        ``[[K + mu A L^-1 A, F^T], [G, 0]]`` (half the unknowns)."""
        mu, a3 = op.mu, op.areas3
        local = op.local.diagonal()
        n3 = a3.size
        mat = sp.bmat(
            [[k + sp.diags(mu * a3 * a3 / local), sp.csr_matrix(fr).T], [sp.csr_matrix(g), None]], format="csc"
        )
        try:
            lu = spla.splu(mat, permc_spec="COLAMD")
        except RuntimeError as err:
            raise SolverError(
                f"the fluids' preconditioner could not be factorised ({err}): check the viscosities"
            ) from None

        def solve(r):
            rf = r[n3 : 2 * n3]
            red = np.concatenate([r[:n3] + a3 * rf / local, r[2 * n3 :]])
            z = lu.solve(red)
            v = z[:n3]
            return np.concatenate([v, (a3 * v) / local - rf / (mu * local), z[n3:]])

        self._lu = solve
        self.n_factorizations += 1

    def _gmres(self, apply, rhs, x0) -> tuple[np.ndarray, np.ndarray, int]:
        """``(z, A z - rhs, iterations)`` by :func:`~cortex_ti.solve.krylov.gmres_left` (SciPy's
        left-preconditioned iterates, one product an iteration; the residual from its kept products)."""
        z, r, its, ok = gmres_left(apply, self._lu, rhs, x0, self.rtol, self.max_iterations)
        if not ok and its >= self.max_iterations:
            raise SolverError(
                f"the fluids' coupled GMRES did not converge in {its} iterations (tolerance {self.rtol:g}): "
                "use fluid.solver: dense on this mesh"
            )
        return z, -r, its
