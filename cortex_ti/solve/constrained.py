r"""The constrained solve of the discrete force balance: least squares (paper Eqs. 38-40) or energy.

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
always; PARDISO, CHOLMOD when installed); it keeps its symbolic analysis while the sparsity
pattern is unchanged. With ``reuse=True`` the factorisation of an earlier, nearby matrix is
kept and the new bordered system is solved by GMRES preconditioned on the right with the old
exact bordered inverse (:func:`cortex_ti.solve.krylov.gmres_right`), starting from the best of
the last solution and its linear and quadratic extrapolations. When to refactorise
is :class:`RefactorRule`'s call: a new factorisation once the last solve cost more
preconditioned iterations than the mean cost per solve since the last factorisation (that
factorisation's cost included), or at once when GMRES does not converge in ``max_iter``.
A least-squares system with ``refine`` is factorised at every solve: GMRES on its normal
equations meets ``rtol`` on ``M^T M``, whose condition is the square of ``M``'s, and left
velocity errors of 5e-9 to 1.5e-8 (relative, 2562-node furrow) where the direct solve refined
against ``M`` leaves 1e-15; an energy system (``K`` itself, no squaring) keeps 1e-11 to 2e-10.

An :class:`~cortex_ti.solve.system.EnergySystem` (a discrete Rayleighian) goes through the same
steps with its own ``K`` (already symmetric positive semidefinite, no ``M^T M``), no separate
pressure unknown (the pressure is the multiplier of the volume row), and possibly other rows
for the multipliers' forces than for the constraints (the border is then ``[[K_s, U], [V^T, D]]``).

After a fresh factorisation one step of iterative refinement (``refine=True``, the default)
corrects the solution with the residual of the *unsquared* problem, ``M^T (r - M x - p P)``
(corrected semi-normal equations): without it the rounding of ``M^T M`` (condition ~h^-4)
limits the quartic fit at >= 10242 nodes. A factorisation that fails (singular or indefinite
matrix, e.g. from an absurd time step or viscosity) is a one-line
:class:`~cortex_ti.errors.SolverError`, whatever the backend's exception.
"""

from __future__ import annotations

import logging
import re
import time
from dataclasses import dataclass
from functools import cached_property

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..errors import SolverError
from .dense import solve_dense
from .factorizations import choose_factorization
from .fluid_krylov import FluidKrylov
from .krylov import gmres_right
from .system import EnergySystem, LinearSystem, SolveInfo, rigid_motion_rows

System = LinearSystem | EnergySystem

log = logging.getLogger(__name__)

__all__ = ["ConstrainedSolver", "ConstrainedLeastSquares", "RefactorRule", "SolveInfo", "PIN_NODES", "pin_rows"]


@dataclass
class RefactorRule:
    """When to refactorise instead of iterating on the last factorisation.

    A *cycle* is one factorisation and the solves it preconditions. Its cost, counted in
    preconditioned iterations (one back-substitution and one product with the matrix): the
    backend's ``refactor_cost`` plus 2 for the direct solve and its refinement, then each reused
    solve's iterations. The iterations grow along a cycle as the matrix drifts away from the
    factorised one, so the mean cost per solve of a cycle first falls (the factorisation is
    shared by more solves) and then rises; it is least where the last solve's cost crosses the
    mean. Hence: refactorise at the next solve once the last solve cost more than the cycle's
    mean so far. Counts, not clocks: the same run refactorises on the same steps on any machine.

    When even the first solve after a factorisation fails to converge (the matrices drift too
    fast for the tolerance: measured for the paper's least-squares formulation at 162 nodes),
    the next ``backoff`` solves factorise without trying; the backoff doubles with every such
    failure (up to 64 solves) and is forgotten at the first success.

    >>> rule = RefactorRule(factor_cost=10.0)
    >>> rule.factorized()
    >>> for iterations in (5, 6, 7, 8, 9):
    ...     rule.iterated(iterations)
    ...     print(iterations, round(rule.cost / rule.solves, 2), rule.due)
    5 8.5 False
    6 7.67 False
    7 7.5 False
    8 7.6 True
    9 7.83 True
    """

    factor_cost: float
    solves: int = 0
    cost: float = 0.0
    last: float = 0.0
    backoff: int = 0  # solves to factorise without trying GMRES
    skip: int = 0  # of which still to come

    def factorized(self, failed_attempt: bool = False) -> None:
        """A fresh factorisation; ``failed_attempt``: after GMRES failed on this system."""
        if failed_attempt and self.solves == 1:
            self.backoff = min(2 * self.backoff, 64) if self.backoff else 1
            self.skip = self.backoff
        elif self.skip:
            self.skip -= 1
        self.solves, self.cost, self.last = 1, self.factor_cost + 2.0, 0.0

    def iterated(self, iterations: int) -> None:
        self.backoff = 0
        self.solves += 1
        self.last = float(iterations)
        self.cost += self.last

    @property
    def due(self) -> bool:
        """Refactorise at the next solve."""
        return self.skip > 0 or (self.solves > 1 and self.last > self.cost / self.solves)


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
    rows = rigid_motion_rows(points[nodes], np.ones(len(nodes)))  # (6, k, 3)
    local = np.einsum("mkc,kbc->mkb", rows, basis[nodes])  # (6, k, nb)
    nb = basis.shape[1]
    cols = (nodes[:, None] * nb + np.arange(nb)[None, :]).ravel()
    data = local.reshape(6, -1)
    data /= np.linalg.norm(data, axis=1, keepdims=True)
    return sp.csr_matrix(
        (data.ravel(), (np.repeat(np.arange(6), cols.size), np.tile(cols, 6))), shape=(6, basis.shape[0] * nb)
    )


@dataclass
class _BorderedSystem:
    """The bordered equations ``[[K_s, U], [V^T, D]] z = rhs`` of one solve (steps 1-2).

    ``z = [x, P (if a separate unknown), lambda (one per constraint), w (one per pin row)]``;
    ``V = U`` except for an energy system whose multipliers push along other rows than the
    constraints they enforce (Petrov-Galerkin: ``U`` holds those force rows, ``V`` the
    constraints)."""

    stiffness: sp.csr_matrix  # K
    pin: sp.csr_matrix  # Q (scaled), so that K_s = K + Q^T Q
    border: np.ndarray  # U = [k, F^T (scaled), Q^T]
    rows: np.ndarray  # V = [k, G^T (scaled), Q^T]
    dblock: np.ndarray  # D = diag(kappa, 0, I)
    rhs: np.ndarray  # [f, g, 0, 0]
    n: int  # number of velocity unknowns
    has_pressure: bool
    gscale: np.ndarray  # norms of the constraint rows (to measure their violation)
    fscale: np.ndarray  # norms of the force rows (to unscale the multipliers)
    scale: float  # mean diagonal of K (the border is scaled to it)
    npin: int

    @cached_property
    def ks(self) -> sp.csr_matrix:
        """``K_s = K + Q^T Q``, formed only for a factorisation (the products do without it)."""
        return (self.stiffness + self.pin.T @ self.pin).tocsr()

    def matvec(self, z: np.ndarray) -> np.ndarray:
        x, y = z[: self.n], z[self.n :]
        kx = self.stiffness @ x + self.pin.T @ (self.pin @ x)
        return np.concatenate([kx + self.border @ y, self.rows.T @ x + self.dblock @ y])

    def split(self, sol: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
        """``(x, P, lambda)`` of a solution, the multipliers those of the unscaled rows."""
        k = 1 if self.has_pressure else 0
        x = sol[: self.n]
        y = sol[self.n + k : self.n + k + self.gscale.size]
        return x, (float(sol[self.n]) if self.has_pressure else 0.0), np.sqrt(self.scale) / self.fscale * y


class _BorderedInverse:
    """Exact inverse of the bordered matrix ``[[K_s, U], [V^T, D]]`` from one factorisation.

    ``first_rhs`` (optional) is solved together with the border columns, in one call.
    """

    def __init__(
        self, factor, border: np.ndarray, rows: np.ndarray, dblock: np.ndarray, first_rhs: np.ndarray | None = None
    ):
        self.factor = factor
        self.border = border
        self.rows = rows
        self.n = border.shape[0]
        cols = border if first_rhs is None else np.column_stack([first_rhs, border])
        z = factor.solve(cols) if cols.shape[1] else np.zeros_like(cols)
        z = z.reshape(self.n, -1)
        self.z_first = None if first_rhs is None else z[:, 0]
        self.z_border = z if first_rhs is None else z[:, 1:]
        schur = dblock - rows.T @ self.z_border
        self.schur = sla.lu_factor(schur)

    def solve_first(self, g: np.ndarray) -> np.ndarray:
        """:meth:`solve` for the right-hand side ``[first_rhs, g]`` given at construction."""
        y = sla.lu_solve(self.schur, g - self.rows.T @ self.z_first)
        return np.concatenate([self.z_first - self.z_border @ y, y])

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """The solution for ``rhs`` (one column, or several as a 2-D array)."""
        f, g = rhs[: self.n], rhs[self.n :]
        zf = self.factor.solve(f).reshape(f.shape)
        y = sla.lu_solve(self.schur, g - self.rows.T @ zf)
        return np.concatenate([zf - self.z_border @ y, y])


class ConstrainedSolver:
    """Solve a :class:`~cortex_ti.solve.system.LinearSystem` or
    :class:`~cortex_ti.solve.system.EnergySystem` (see the module docstring).

    Parameters
    ----------
    backend : factorisation name (``auto`` or a name of :data:`~cortex_ti.solve.factorizations.FACTORIZATIONS`).
    reuse : keep the factorisation and use it to precondition later, nearby systems.
    rtol : GMRES tolerance when reusing (relative to the right-hand side).
    max_iter : GMRES iterations above which the matrix is refactored at once (otherwise
        :class:`RefactorRule` decides).
    refine : after each fresh factorisation, one step of iterative refinement whose residual
        is formed from the unsquared system (corrected semi-normal equations for the least
        squares): it removes the rounding floor of ``M^T M`` at fine meshes.
    """

    def __init__(
        self, backend: str = "auto", reuse: bool = False, rtol: float = 1e-10, max_iter: int = 30, refine: bool = True
    ):
        self.factor_cls = choose_factorization(backend)
        self._factor = self.factor_cls()
        self.reuse = reuse
        self.rtol = rtol
        self.max_iter = max_iter
        self.refine = refine
        self._pre: _BorderedInverse | None = None
        self._pin_nodes = None  # (N, node indices) of the sparse pin, chosen once per mesh
        self._last: tuple[_BorderedSystem, np.ndarray] | None = None  # the last exact solve (for kkt_solve)
        self._previous: list[np.ndarray] = []  # the last three solutions (initial guesses of the reuse)
        self.rule = RefactorRule(self.factor_cls.refactor_cost)
        self.n_factorizations = 0
        self.n_iterations = 0  # GMRES iterations over all solves
        self.dense_last = False  # whether the last solve was dense (solve/dense.py)
        self._fluid_krylov = None  # the fluids' coupled GMRES (solve/fluid_krylov.py), made at its first solve

    @property
    def backend(self) -> str:
        return self.factor_cls.name

    @property
    def n_analyses(self) -> int:
        """Symbolic analyses (orderings) the factorisation did: one per sparsity pattern met
        (None for a backend that does not keep its analysis)."""
        return getattr(self._factor, "analyses", None)

    def new_mesh(self) -> None:
        """The mesh changed (a remeshing): drop what belongs to the old one (the factorisation used
        as preconditioner, the pinned nodes, the earlier solutions). The factorisation object stays:
        it redoes its symbolic analysis because the sparsity pattern changed, and only then."""
        self._pre = None
        self._pin_nodes = None
        self._last = None
        self._previous = []
        self.rule = RefactorRule(self.factor_cls.refactor_cost)
        if self._fluid_krylov is not None:
            self._fluid_krylov.new_mesh()

    def solve(self, system: System, points: np.ndarray) -> tuple[np.ndarray, float, SolveInfo]:
        """Return velocity unknowns ``x``, pressure ``P`` (0 without it) and diagnostics; a system
        with a dense part (the fluids') is solved densely (:mod:`cortex_ti.solve.dense`)."""
        if getattr(system, "fluid_operator", None) is not None:
            if self._fluid_krylov is None:
                self._fluid_krylov = FluidKrylov()
            x, pressure, _, info = self._fluid_krylov.solve(system, system.fluid_operator)
            self._last, self._pre, self.dense_last = None, None, True
            self.n_factorizations += int(info.refactored)
            self.n_iterations += info.iterations
            return x, pressure, info
        if getattr(system, "dense", None) is not None:
            x, pressure, _, info = solve_dense(system)
            self._last, self._pre, self.dense_last = None, None, True
            self.n_factorizations += 1
            return x, pressure, info
        self.dense_last = False
        t0 = time.perf_counter()
        bordered = self._bordered_system(system, points)
        t1 = time.perf_counter()
        reuse = self.reuse and not self.rule.due and not (self.refine and isinstance(system, LinearSystem))
        sol, iterations = self._reuse(bordered) if reuse else (None, 0)
        t2 = time.perf_counter()
        refactored = sol is None
        self.n_iterations += iterations
        if refactored:
            sol = self._factor_and_solve(bordered)
            if self.refine:
                sol = sol + self._pre.solve(self._refinement_rhs(system, bordered, sol))
            self.rule.factorized(failed_attempt=iterations > 0)
        else:
            self.rule.iterated(iterations)
        self._previous = [*self._previous[-2:], sol]
        t3 = time.perf_counter()
        if not np.all(np.isfinite(sol)):
            raise SolverError(
                "the linear solve produced non-finite values (singular or badly scaled system): "
                "check the viscosities, the time step and the mesh"
            )
        x, pressure, multipliers = bordered.split(sol)
        if isinstance(system, EnergySystem):
            pressure = system.pressure(multipliers)
        self._last = (bordered, multipliers) if refactored else None
        info = self._info(
            system,
            bordered,
            sol,
            x,
            pressure,
            multipliers,
            iterations,
            refactored,
            {"normal_equations": t1 - t0, "iterate": t2 - t1, "factor_solve": t3 - t2},
        )
        return x, pressure, info

    def _bordered_system(self, system: System, points: np.ndarray) -> _BorderedSystem:
        """Steps 1-2 of the module docstring: ``K`` (``M^T M`` for the least squares), the pin
        and the border."""
        ne = system.normal_equations()
        kmat = ne.stiffness
        has_p = ne.pressure_column is not None
        cols = [ne.pressure_column[:, None]] if has_p else []
        gmat = system.constraints
        if self._pin_nodes is None or self._pin_nodes[0] != points.shape[0]:
            self._pin_nodes = (points.shape[0], _farthest_points(points, min(PIN_NODES, points.shape[0])))
        scale = float(np.mean(kmat.diagonal()))
        if not (np.isfinite(scale) and scale > 0.0):
            raise SolverError(
                f"the force-balance matrix is not usable (mean diagonal {scale:.3g}): check that the "
                "viscosities are positive and finite and that the mesh is well shaped"
            )
        pin = pin_rows(points, system.basis, nodes=self._pin_nodes[1]) * np.sqrt(scale)
        gscale = _row_norms(gmat)
        pin_cols = pin.T.toarray()
        rows = np.hstack(cols + [(gmat / gscale[:, None] * np.sqrt(scale)).T, pin_cols])
        frows = system.force_rows
        if frows is None:
            border, fscale = rows, gscale
        else:
            fscale = _row_norms(frows)
            border = np.hstack(cols + [(frows / fscale[:, None] * np.sqrt(scale)).T, pin_cols])
        low = getattr(system, "low_rank", None)
        nlow = 0
        if low is not None:  # K + U V^T: unknowns y = V^T x (scaled), bordered before the pins
            ucols, vcols = low
            nlow = ucols.shape[1]
            alpha = np.sqrt(scale) / _row_norms(ucols.T)
            beta = np.sqrt(scale) / _row_norms(vcols.T)
            cut = border.shape[1] - pin_cols.shape[1]
            border = np.hstack([border[:, :cut], ucols * alpha, pin_cols])
            rows = np.hstack([rows[:, :cut], vcols * beta, pin_cols])
        q = border.shape[1]
        dblock = np.zeros((q, q))
        if has_p:
            dblock[0, 0] = ne.pressure_diagonal
        npin = pin.shape[0]
        dblock[q - npin :, q - npin :] = np.eye(npin)
        if nlow:
            at = q - npin - nlow
            dblock[at : at + nlow, at : at + nlow] = -np.diag(alpha * beta)
        rhs = np.concatenate([ne.rhs, [ne.pressure_rhs] if has_p else [], np.zeros(gmat.shape[0] + nlow + npin)])
        # the last block row is Q x + w = 0, so K_s x + Q^T w = K x
        return _BorderedSystem(
            stiffness=kmat.tocsr(),
            pin=pin.tocsr(),
            border=border,
            rows=rows,
            dblock=dblock,
            rhs=rhs,
            n=ne.rhs.size,
            has_pressure=has_p,
            gscale=gscale,
            fscale=fscale,
            scale=scale,
            npin=npin,
        )

    def _reuse(self, b: _BorderedSystem) -> tuple[np.ndarray | None, int]:
        """GMRES on the new bordered system, preconditioned on the right by the last exact
        bordered inverse; ``(None, iterations)`` when there is none or it does not converge in
        ``max_iter``."""
        pre = self._pre
        if pre is None or pre.n != b.n or pre.border.shape != b.border.shape or pre.rows.shape != b.rows.shape:
            return None, 0
        z, iterations, converged = gmres_right(
            b.matvec, pre.solve, b.rhs, self._initial_guess(b, pre), self.rtol, self.max_iter
        )
        return (z if converged else None), iterations

    def _initial_guess(self, b: _BorderedSystem, pre: _BorderedInverse) -> np.ndarray:
        """The last solution or its linear or quadratic extrapolation from the last two or
        three, whichever leaves the smallest residual (measured at 2562 nodes: 3e-2, 1e-3 and
        1e-4 of |b|, against 5e-2 to 6e-1 for the preconditioner applied to b; the quadratic
        one saves 1-2 of ~10 iterations); the preconditioner applied to ``b`` when there is no
        earlier solution of this size or none beats ``|b|``."""
        prev = [p for p in self._previous if p.size == b.rhs.size]
        guesses = prev[-1:]
        if len(prev) >= 2:
            guesses.append(2.0 * prev[-1] - prev[-2])
        if len(prev) >= 3:
            guesses.append(3.0 * prev[-1] - 3.0 * prev[-2] + prev[-3])
        best, best_res = None, np.linalg.norm(b.rhs)
        for g in guesses:
            res = np.linalg.norm(b.matvec(g) - b.rhs)
            if res < best_res:
                best, best_res = g, res
        return pre.solve(b.rhs) if best is None else best

    def _factor_and_solve(self, b: _BorderedSystem) -> np.ndarray:
        """Step 3: factorise ``K_s`` and solve the bordered system by its Schur complement."""
        try:
            self._factor.factorize(b.ks)
        except Exception as exc:  # SuperLU: "Factor is exactly singular"; PARDISO: "error code -4" (zero pivot)
            raise SolverError(
                f"the sparse factorisation of the force balance failed ({_describe(exc)}): the matrix is singular "
                "or not positive definite; check that the viscosities are positive and finite (viscosity.*), "
                "that time.dt is not absurdly large and that the mesh is closed and well shaped"
            ) from None
        f = b.rhs[: b.n]
        self._pre = _BorderedInverse(self._factor, b.border, b.rows, b.dblock, first_rhs=f)
        self.n_factorizations += 1
        return self._pre.solve_first(b.rhs[b.n :])

    def _refinement_rhs(self, system: System, b: _BorderedSystem, sol: np.ndarray) -> np.ndarray:
        """The residual of the bordered system at ``sol``, its first block formed from the
        unsquared system (``M^T (r - M x - p P)``, not ``M^T r - (M^T M) x``)."""
        x, y = sol[: b.n], sol[b.n :]
        k = 1 if b.has_pressure else 0
        pressure = float(sol[b.n]) if b.has_pressure else 0.0
        first, prow = system.unsquared_residual(x, pressure)
        pin = b.border[:, -b.npin :]
        qxw = pin.T @ x + y[-b.npin :]  # Q x + w
        mid = slice(k, y.size - b.npin)
        out = [first - b.border[:, mid] @ y[mid] - pin @ qxw]
        if b.has_pressure:
            out.append([prow])
        out += [-(b.rows[:, mid].T @ x) - b.dblock[mid, mid] @ y[mid], -qxw]
        return np.concatenate(out)

    def kkt_solve(self, b_x: np.ndarray, b_scalar: np.ndarray) -> np.ndarray:
        """Velocity part of the solution of the last solve's optimality conditions (unscaled
        multipliers) for the right-hand side ``[b_x; b_scalar]``; ``b_scalar``: the pressure row
        (if the pressure is a separate unknown), then one entry per constraint row. ``b_x`` may
        have several columns. Needs the factorisation of that very system: the last solve must
        have factorised (``reuse=False``)."""
        if self._last is None and self.dense_last:
            raise SolverError("kkt_solve: the last solve was dense (the effect fluids), it keeps no factorisation")
        if self._last is None:
            raise SolverError("kkt_solve needs the factorisation of the last solve (solve with reuse=False)")
        b, _ = self._last
        bx = np.asarray(b_x, dtype=float)
        two = bx.ndim == 2
        bx = bx if two else bx[:, None]
        bs = np.asarray(b_scalar, dtype=float).reshape(-1, bx.shape[1])
        k = 1 if b.has_pressure else 0
        cscale = np.sqrt(b.scale) / b.gscale
        nlow = b.border.shape[1] - k - b.gscale.size - b.npin
        parts = [bx] + ([bs[:1]] if k else []) + [cscale[:, None] * bs[k:], np.zeros((nlow + b.npin, bx.shape[1]))]
        out = self._pre.solve(np.concatenate(parts, axis=0))[: b.n]
        return out if two else out[:, 0]

    @property
    def last_solution(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The multipliers of the last solve that factorised (None otherwise)."""
        return None if self._last is None else self._last[1]

    def _info(
        self, system, b: _BorderedSystem, sol, x, pressure, multipliers, iterations, refactored, seconds
    ) -> SolveInfo:
        """What the solve achieved, measured on the solution."""
        res, rhs_norm = system.measure(x, pressure, multipliers)
        kkt = b.matvec(sol) - b.rhs
        viol = np.abs(system.constraints @ x) / (b.gscale * max(np.linalg.norm(x), 1e-300))
        return SolveInfo(
            backend=self.backend,
            force_residual=res,
            rhs_norm=rhs_norm,
            constraint_violation=float(viol.max()) if viol.size else 0.0,
            kkt_residual=float(np.linalg.norm(kkt) / max(np.linalg.norm(b.rhs), 1e-300)),
            iterations=iterations,
            refactored=refactored,
            seconds=seconds,
        )


def _row_norms(rows: np.ndarray) -> np.ndarray:
    norms = np.linalg.norm(rows, axis=1)
    norms[norms == 0] = 1.0
    return norms


def _describe(exc: Exception) -> str:
    """One short phrase for a factorisation backend's exception (its first line, or its error code)."""
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else "no message"
    code = re.search(r"error code (-?\d+)", text)
    return f"{type(exc).__name__} {'error code ' + code.group(1) if code else text}"


#: The solver's name before it also solved energy systems (kept so that older callers still run)
ConstrainedLeastSquares = ConstrainedSolver
