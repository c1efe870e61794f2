r"""Constrained least squares for the discrete force balance (paper Eqs. 38-40).

We minimise ``|M x + p P - r|^2`` over the velocity unknowns ``x`` and the pressure
``P`` subject to ``G x = 0`` (Lagrange multipliers ``lambda``). The optimality
conditions are the bordered system

.. math::
    \begin{pmatrix} K & k & G^T \\ k^T & \kappa & 0 \\ G & 0 & 0 \end{pmatrix}
    \begin{pmatrix} x \\ P \\ \lambda \end{pmatrix} =
    \begin{pmatrix} M^T r \\ p^T r \\ 0 \end{pmatrix},
    \qquad K = M^T M,\ k = M^T p,\ \kappa = p^T p .

``K`` is sparse (two-ring stencil) but singular: rigid motions (and, with zero
bulk viscosity, the conformal motions of a sphere) cost nothing. The dense rows
and columns (``k``, ``G``) would make a factorisation of the whole matrix fill in
completely, so they are kept out of it:

1. ``K_s = K + Q^T Q`` with ``Q`` a *sparse* pin: the six rigid-body rows restricted
   to a dozen well-spread nodes. ``K_s`` is symmetric positive definite.
2. ``K = K_s - Q^T Q`` is undone exactly by treating ``w = -Q x`` as extra unknowns,
   so the system becomes ``K_s`` bordered by ``U = [k, G^T, Q^T]`` (1 + 7 + 6 columns).
3. Block elimination (Schur complement / capacitance matrix): one sparse
   factorisation of ``K_s``, solves with ``1 + q`` right-hand sides, and a dense
   ``q x q`` solve.

The factorisation is chosen by name from :data:`cortex_ti.solve.factorizations.FACTORIZATIONS` (SciPy's SuperLU
always; PARDISO through ``pypardiso`` when installed). With ``reuse=True`` a
factorisation of an earlier, nearby matrix is kept and the new bordered system is
solved by GMRES preconditioned with the old exact bordered inverse; it is
refactored when GMRES needs more than ``max_iter`` iterations.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError
from .factorizations import choose_factorization
from .system import LinearSystem, rigid_motion_rows

log = logging.getLogger(__name__)

__all__ = ["ConstrainedLeastSquares", "SolveInfo", "PIN_NODES", "pin_rows"]


@dataclass
class SolveInfo:
    """What the solve achieved; all values are measured, none assumed."""

    backend: str
    lsq_residual: float           # |M x + p P - r|
    rhs_norm: float               # |r|
    constraint_violation: float   # max_j |G_j x| / (|G_j| |x|)
    kkt_residual: float           # relative residual of the bordered normal equations
    iterations: int = 0           # GMRES iterations (0: direct solve)
    refactored: bool = True
    seconds: dict = field(default_factory=dict)

    @property
    def relative_residual(self) -> float:
        return self.lsq_residual / self.rhs_norm if self.rhs_norm > 0 else self.lsq_residual


def _farthest_points(points: np.ndarray, k: int) -> np.ndarray:
    """``k`` well-spread node indices (deterministic farthest-point sampling)."""
    chosen = [int(np.argmax(points[:, 2]))]
    dist = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(k - 1):
        nxt = int(np.argmax(dist))
        chosen.append(nxt)
        dist = np.minimum(dist, np.linalg.norm(points - points[nxt], axis=1))
    return np.array(sorted(set(chosen)))


#: Number of well-spread nodes the sparse pin acts on
PIN_NODES = 12


def pin_rows(points: np.ndarray, basis: np.ndarray, nodes: np.ndarray) -> sp.csr_matrix:
    """Sparse rows (6, unknowns) fixing the rigid/conformal kernel of ``K`` (step 1 above),
    acting on the pinned ``nodes`` only."""
    rows = rigid_motion_rows(points[nodes], np.ones(len(nodes)))    # (6, k, 3)
    local = np.einsum("mkc,kbc->mkb", rows, basis[nodes])            # (6, k, nb)
    nb = basis.shape[1]
    cols = (nodes[:, None] * nb + np.arange(nb)[None, :]).ravel()
    data = local.reshape(6, -1)
    data /= np.linalg.norm(data, axis=1, keepdims=True)
    return sp.csr_matrix((data.ravel(), (np.repeat(np.arange(6), cols.size), np.tile(cols, 6))),
                         shape=(6, basis.shape[0] * nb))


@dataclass
class _BorderedSystem:
    """The bordered normal equations ``[[K_s, U], [U^T, D]] z = rhs`` of one solve (steps 1-2).

    ``z = [x, P (if any), lambda (one per constraint), w (one per pin row)]``."""

    ks: sp.csr_matrix      # K + Q^T Q
    border: np.ndarray     # U = [k, G^T (scaled), Q^T]
    dblock: np.ndarray     # D = diag(kappa, 0, I)
    rhs: np.ndarray        # [M^T r, p^T r, 0, 0]
    n: int                 # number of velocity unknowns
    has_pressure: bool
    gscale: np.ndarray     # norms of the constraint rows (to measure their violation)

    def matvec(self, z: np.ndarray) -> np.ndarray:
        x, y = z[: self.n], z[self.n:]
        return np.concatenate([self.ks @ x + self.border @ y, self.border.T @ x + self.dblock @ y])


class _BorderedInverse:
    """Exact inverse of the bordered matrix ``[[K_s, U], [U^T, D]]`` from one factorisation.

    ``first_rhs`` (optional) is solved together with the border columns, in one call.
    """

    def __init__(self, factor, border: np.ndarray, dblock: np.ndarray, first_rhs: np.ndarray | None = None):
        self.factor = factor
        self.border = border
        self.n = border.shape[0]
        cols = border if first_rhs is None else np.column_stack([first_rhs, border])
        z = factor.solve(cols) if cols.shape[1] else np.zeros_like(cols)
        z = z.reshape(self.n, -1)
        self.z_first = None if first_rhs is None else z[:, 0]
        self.z_border = z if first_rhs is None else z[:, 1:]
        schur = dblock - border.T @ self.z_border
        self.schur = sla.lu_factor(schur)

    def solve_first(self, g: np.ndarray) -> np.ndarray:
        """:meth:`solve` for the right-hand side ``[first_rhs, g]`` given at construction."""
        y = sla.lu_solve(self.schur, g - self.border.T @ self.z_first)
        return np.concatenate([self.z_first - self.z_border @ y, y])

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        f, g = rhs[: self.n], rhs[self.n:]
        zf = self.factor.solve(f)
        y = sla.lu_solve(self.schur, g - self.border.T @ zf)
        return np.concatenate([zf - self.z_border @ y, y])


class ConstrainedLeastSquares:
    """Solve :class:`~cortex_ti.solve.system.LinearSystem` (see the module docstring).

    Parameters
    ----------
    backend : factorisation name (``auto``, ``superlu``, ``pardiso``).
    reuse : keep the factorisation and use it to precondition later, nearby systems.
    rtol : GMRES tolerance when reusing (relative to the right-hand side).
    max_iter : GMRES iterations above which the matrix is refactored.
    """

    def __init__(self, backend: str = "auto", reuse: bool = False, rtol: float = 1e-10, max_iter: int = 30):
        self.factor_cls = choose_factorization(backend)
        self._factor = self.factor_cls()
        self.reuse = reuse
        self.rtol = rtol
        self.max_iter = max_iter
        self._pre: _BorderedInverse | None = None
        self._pin_nodes = None  # (N, node indices) of the sparse pin, chosen once per mesh
        self.n_factorizations = 0

    @property
    def backend(self) -> str:
        return self.factor_cls.name

    def solve(self, system: LinearSystem, points: np.ndarray) -> tuple[np.ndarray, float, SolveInfo]:
        """Return velocity unknowns ``x``, pressure ``P`` (0 without it) and diagnostics."""
        t0 = time.perf_counter()
        bordered = self._bordered_system(system, points)
        t1 = time.perf_counter()
        sol, iterations = self._reuse(bordered) if self.reuse else (None, 0)
        t2 = time.perf_counter()
        refactored = sol is None
        if refactored:
            sol = self._factor_and_solve(bordered)
        t3 = time.perf_counter()
        if not np.all(np.isfinite(sol)):
            raise SolverError("the linear solve produced non-finite values (singular or badly scaled system)")
        x = sol[: bordered.n]
        pressure = float(sol[bordered.n]) if bordered.has_pressure else 0.0
        info = self._info(system, bordered, sol, x, pressure, iterations, refactored,
                          {"normal_equations": t1 - t0, "iterate": t2 - t1, "factor_solve": t3 - t2})
        return x, pressure, info

    def _bordered_system(self, system: LinearSystem, points: np.ndarray) -> _BorderedSystem:
        """Steps 1-2 of the module docstring: ``K = M^T M``, the pin and the border."""
        m = system.matrix
        mt = m.T.tocsr()
        kmat = (mt @ m).tocsr()
        f = mt @ system.rhs
        has_p = system.pressure_column is not None
        cols, g = [], []
        if has_p:
            p = system.pressure_column
            cols.append((mt @ p)[:, None])
            g.append(float(p @ system.rhs))
        gmat = system.constraints
        if self._pin_nodes is None or self._pin_nodes[0] != points.shape[0]:
            self._pin_nodes = (points.shape[0], _farthest_points(points, min(PIN_NODES, points.shape[0])))
        scale = float(np.mean(kmat.diagonal()))
        pin = pin_rows(points, system.basis, nodes=self._pin_nodes[1]) * np.sqrt(scale)
        gscale = np.linalg.norm(gmat, axis=1, keepdims=True)
        gscale[gscale == 0] = 1.0
        gn = gmat / gscale * np.sqrt(scale)   # scaled constraint rows, same magnitude as K
        border = np.hstack(cols + [gn.T, pin.T.toarray()])
        q = border.shape[1]
        dblock = np.zeros((q, q))
        if has_p:
            dblock[0, 0] = float(p @ p)
        npin = pin.shape[0]
        dblock[q - npin:, q - npin:] = np.eye(npin)
        rhs = np.concatenate([f, g, np.zeros(gmat.shape[0] + npin)])
        # the last block row is Q x + w = 0, so K_s x + Q^T w = K x
        return _BorderedSystem(ks=(kmat + pin.T @ pin).tocsr(), border=border, dblock=dblock, rhs=rhs,
                               n=f.size, has_pressure=has_p, gscale=gscale[:, 0])

    def _reuse(self, b: _BorderedSystem) -> tuple[np.ndarray | None, int]:
        """GMRES on the new bordered system, preconditioned by the last exact bordered inverse;
        ``(None, iterations)`` when there is none or it does not converge in ``max_iter``."""
        pre = self._pre
        if pre is None or pre.n != b.n or pre.border.shape != b.border.shape:
            return None, 0
        size = b.rhs.size
        op = spla.LinearOperator((size, size), matvec=b.matvec, dtype=float)
        prec = spla.LinearOperator((size, size), matvec=pre.solve, dtype=float)
        counter = [0]

        def count(_):
            counter[0] += 1

        z, status = spla.gmres(op, b.rhs, M=prec, x0=pre.solve(b.rhs), rtol=self.rtol, atol=0.0,
                               restart=self.max_iter, maxiter=1, callback=count, callback_type="pr_norm")
        return (z if status == 0 else None), counter[0]

    def _factor_and_solve(self, b: _BorderedSystem) -> np.ndarray:
        """Step 3: factorise ``K_s`` and solve the bordered system by its Schur complement."""
        try:
            self._factor.factorize(b.ks)
        except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
            raise SolverError(
                "the force balance has no unique solution (singular matrix): check that the scene has "
                f"shear viscosity and a closed, well-shaped mesh ({exc})"
            ) from None
        f = b.rhs[: b.n]
        self._pre = _BorderedInverse(self._factor, b.border, b.dblock, first_rhs=f)
        self.n_factorizations += 1
        return self._pre.solve_first(b.rhs[b.n:])

    def _info(self, system, b: _BorderedSystem, sol, x, pressure, iterations, refactored, seconds) -> SolveInfo:
        """What the solve achieved, measured on the solution."""
        res = system.residual(x, pressure)
        kkt = b.matvec(sol) - b.rhs
        viol = np.abs(system.constraints @ x) / (b.gscale * max(np.linalg.norm(x), 1e-300))
        return SolveInfo(
            backend=self.backend,
            lsq_residual=float(np.linalg.norm(res)),
            rhs_norm=float(np.linalg.norm(system.rhs)),
            constraint_violation=float(viol.max()) if viol.size else 0.0,
            kkt_residual=float(np.linalg.norm(kkt) / max(np.linalg.norm(b.rhs), 1e-300)),
            iterations=iterations,
            refactored=refactored,
            seconds=seconds,
        )
