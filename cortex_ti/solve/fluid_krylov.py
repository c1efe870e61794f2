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
sparse near corrections, :mod:`cortex_ti.physics.fluids_fast`). Preconditioner: the sparse LU
(``scipy.sparse.linalg.splu``, minimum-degree ordering of ``A + A^T``) of the same block matrix with
``V'`` replaced by its local part ``op.local`` (the self-interactions, a diagonal): the cortex
operator exact, the fluids' DtN map by its local part; an approximation of the fluids' single layer
by the sphere's translation coefficient ``2 R / 3`` instead took 42-50 iterations at 642 nodes for
``mu`` = 0.1, 1, 10 (docs/validation/fluids.md). The factorisation is redone on every solve (it
costs 0.35 CPU s at 2562 nodes: little beside one product), the previous solution ``(v, f,
lambda)`` is the initial guess (:class:`FluidKrylov`).

Tolerance :data:`KRYLOV_RTOL` on the coupled residual: the velocities then agree with the dense
solve's to about that (1e-9 measured at rtol 1e-9, 162 and 642 nodes), far below the
discretisation's error (1e-3 at 2562 nodes).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError
from .system import EnergySystem, SolveInfo

__all__ = ["FluidKrylov", "KRYLOV_RTOL"]

#: GMRES's relative tolerance on the coupled system's residual
KRYLOV_RTOL = 1e-7


class FluidKrylov:
    """The coupled GMRES solve with what it reuses from one solve to the next (module docstring)."""

    def __init__(self, rtol: float = KRYLOV_RTOL, max_iterations: int = 600):
        self.rtol = rtol
        self.max_iterations = max_iterations
        self._lu = None
        self._previous: np.ndarray | None = None
        self.n_factorizations = 0
        self.n_iterations = 0

    def new_mesh(self) -> None:
        self._lu, self._previous = None, None

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
        z, its = self._gmres(apply, rhs, x0, nt)
        self._previous = z
        self.n_iterations += its
        t2 = time.perf_counter()
        res = apply(z) - rhs
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

    def _gmres(self, apply, rhs, x0, nt) -> tuple[np.ndarray, int]:
        op = spla.LinearOperator((nt, nt), matvec=apply)
        pre = spla.LinearOperator((nt, nt), matvec=self._lu)
        count = [0]

        def step(_):
            count[0] += 1

        z, info = spla.gmres(
            op,
            rhs,
            x0=x0,
            M=pre,
            rtol=self.rtol,
            atol=0.0,
            restart=200,
            maxiter=self.max_iterations // 200 + 1,
            callback=step,
            callback_type="pr_norm",
        )
        if info > 0 and count[0] >= self.max_iterations:
            raise SolverError(
                f"the fluids' coupled GMRES did not converge in {count[0]} iterations (tolerance {self.rtol:g}): "
                "use fluid.solver: dense on this mesh"
            )
        return z, count[0]
