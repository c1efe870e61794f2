r"""The matrix-free solve of an energy system coupled to the fluids (``fluid.solver: fmm``, issue 36).

The dense path (:mod:`cortex_ti.solve.dense`) factorises ``K + D``, ``D = mu A V'^{-1} A`` the
fluids' dissipation (docs/method/fluids.md). Here neither ``V'^{-1}`` nor ``K + D`` is formed: the
traction density ``f = V'^{-1} A (v - u_inf)`` is carried as unknowns and the coupled system

.. math::
    \begin{pmatrix} K & \mu A & F^T \\ \mu A & -\mu V' & 0 \\ G & 0 & 0 \end{pmatrix}
    \begin{pmatrix} v \\ f \\ \lambda \end{pmatrix}
    = \begin{pmatrix} b \\ \mu A u_\infty \\ 0 \end{pmatrix}

(eliminating ``f`` gives the dense path's ``(K + D) v + F^T lambda = b + D u_inf``, ``G v = 0``; with a
viscosity contrast the traction row is ``mu (A M v / mu - V' f) = mu A u_inf``, ``M = mu_out (1/2 + Kd) +
mu_in (1/2 - Kd)`` applied by ``op.mix`` (:mod:`cortex_ti.physics.fluids_double`), ``mu = mu_out``) is
solved by GMRES, ``V'`` applied matrix-free by the fluid operator (``op.single``: the FMM and the
sparse near corrections, :mod:`cortex_ti.physics.fluids_fast`). Preconditioner: the same block matrix
with ``V'`` replaced by its local part ``op.local`` (the self-interactions, a diagonal ``L``): the
cortex operator exact, the fluids' DtN map by its local part. ``f`` is eliminated from it (``L``
is diagonal), leaving ``[[K + mu A L^-1 A, F^T], [G, 0]]``, half the unknowns, factorised by
``scipy.sparse.linalg.splu`` with the COLAMD ordering (0.12 CPU s at 2562 nodes against 0.39 for the
whole block matrix with minimum degree on ``A + A^T``; the same preconditioner, so the same
iterations). An approximation of the fluids' single layer by the sphere's translation coefficient
``2 R / 3`` instead took 42-50 iterations at 642 nodes for ``mu`` = 0.1, 1, 10
(docs/validation/fluids.md). The factorisation is redone every :data:`REFACTOR_EVERY` solves (the
operator moves little from a step to the next: the stale LU costs a few iterations in a hundred).

The initial guess extrapolates the last three solutions to this solve's shape. The solves of an
adaptive scheme are not equally spaced in time (bdf2's step doubles at the start of
furrow_in_fluid, shrinks after a rejected step), and the solver is not told their times: it reads
the step ratios off the shapes the operators were built on, ``r = <x_(k+1) - x_k, x_k - x_(k-1)> /
|x_k - x_(k-1)|^2`` (:func:`step_ratio`, exact for nodes moving on straight lines at fixed speeds),
and extrapolates the solutions in that pseudo-time (:func:`lagrange_extrapolate`) by the degree
(0-2) whose guess came nearest the previous solution: the quadratic's truncation error is the
smallest, but it multiplies the solutions' own errors (~``rtol``) by 4.4 (equal steps; 2.2 linear, 1
the last solution), which wins when the steps are short (Euler's fixed ``dt``). Without motion,
after a new mesh or with a ratio outside :data:`RATIO_RANGE`, fewer solutions. Measured on
furrow_in_fluid to t = 3 (GMRES iterations, one product each; the LU every solve): 173 / 148 / 135 at
642 nodes and 234 / 224 / 186 at 2562 with the guess ``2 z_n - z_(n-1)`` (the former), linear in the
ratio, quadratic; with the degree chosen and the LU every fourth solve 128 and 182. To t = 0.5 at 642
nodes with ``euler`` (501 solves) the quadratic alone took 1384 iterations, the former guess 748, the
chosen degree 560.
The GMRES is :func:`~cortex_ti.solve.krylov.gmres_left` (SciPy's iterates with one product an
iteration: SciPy's dtype probe, its closing true residual and the caller's were three more a
solve, a quarter of the cost at 10242 nodes).

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

__all__ = ["FluidKrylov", "KRYLOV_RTOL", "REFACTOR_EVERY", "STALE_ITERATIONS", "lagrange_extrapolate", "step_ratio"]

#: GMRES's relative tolerance on the coupled system's residual
KRYLOV_RTOL = 1e-6

#: the preconditioner's LU is redone every this many solves (and on a new mesh): measured on
#: furrow_in_fluid at 2562 nodes, 186 GMRES iterations over 35 solves refactorising every solve, 186
#: every second, 188 every fourth, 202 never (docs/validation/fluids.md); at 10242 nodes the LU costs
#: 0.84 CPU s, two thirds of a product
REFACTOR_EVERY = 4

#: the step ratios the guess extrapolates over (an adaptive scheme's steps change by 0.2-2 times; outside,
#: e.g. Heun's predictor and corrector shapes, which are not one path, or no motion: fewer solutions)
RATIO_RANGE = (1.0 / 16.0, 4.0)

#: a solve with a reused LU that has not converged in this many iterations factorises its own operator
#: and continues from there (a solve takes 3-8 with the guess, ~20 cold at 10242 nodes)
STALE_ITERATIONS = 40


class FluidKrylov:
    """The coupled GMRES solve with what it reuses from one solve to the next (module docstring)."""

    def __init__(self, rtol: float = KRYLOV_RTOL, max_iterations: int = 600, refactor_every: int = REFACTOR_EVERY):
        self.rtol = rtol
        self.max_iterations = max_iterations
        self.refactor_every = refactor_every
        self.n_factorizations = 0
        self.n_iterations = 0
        self.new_mesh()

    def new_mesh(self) -> None:
        """Forget the preconditioner and the earlier solutions (a new mesh, or the start)."""
        self._lu, self._lu_size, self._age = None, -1, 0
        self._solutions: list[np.ndarray] = []  # the last three solutions, oldest first
        self._shapes: list[np.ndarray | None] = []  # the shapes of their solves and of this one
        self._candidates: dict[int, np.ndarray] = {}  # this solve's guesses by degree
        self._degree = 2  # the degree of the next guess (:meth:`_score`)

    def solve(self, system: EnergySystem, op):
        """``(x, pressure, multipliers, info)`` of ``system`` with the fluid operator ``op``."""
        t0 = time.perf_counter()
        k = system.stiffness.tocsr()
        g = np.asarray(system.constraints)
        fr = g if system.force_rows is None else np.asarray(system.force_rows)
        n3, m = k.shape[0], g.shape[0]
        mu, a3 = op.mu, op.areas3
        nt = 2 * n3 + m
        mix = getattr(op, "double", None) is not None  # a viscosity contrast: V' f = A (M v / mu - u_inf)

        def apply(z):
            v, f, lam = z[:n3], z[n3 : 2 * n3], z[2 * n3 :]
            mv = op.mix(v) if mix else v
            return np.concatenate([k @ v + mu * (a3 * f) + fr.T @ lam, mu * (a3 * mv - op.single(f)), g @ v])

        rhs = np.zeros(nt)
        rhs[:n3] = system.rhs
        if op.far is not None:
            rhs[n3 : 2 * n3] = mu * a3 * op.far
        refactor = self._lu is None or self._lu_size != nt or self._age >= self.refactor_every
        if refactor:
            self._factor(k, g, fr, op)
            self._lu_size, self._age = nt, 0
        self._age += 1
        t1 = time.perf_counter()
        x0 = self._guess(nt, getattr(op, "points", None))
        z, res, its, ok = self._gmres(apply, rhs, x0, self.max_iterations if refactor else STALE_ITERATIONS)
        if not ok and not refactor:  # the reused LU is too stale: this operator's, from where it got to
            self._factor(k, g, fr, op)
            self._lu_size, self._age, refactor = nt, 1, True
            z, res, more, ok = self._gmres(apply, rhs, z, self.max_iterations)
            its += more
        if not ok and its >= self.max_iterations:  # (a breakdown returns what it has, as SciPy's)
            raise SolverError(
                f"the fluids' coupled GMRES did not converge in {its} iterations (tolerance {self.rtol:g}): "
                "use fluid.solver: dense on this mesh"
            )
        self._score(z)
        self._solutions = (self._solutions + [z])[-3:]
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
            refactored=refactor,
            seconds={"normal_equations": 0.0, "factor": t1 - t0, "iterate": t2 - t1, "factor_solve": t2 - t0},
        )
        return x, system.pressure(lam), lam, info

    def _guess(self, nt: int, points) -> np.ndarray | None:
        """The initial guess (module docstring): the last solutions extrapolated, in the solves'
        pseudo-time (the step ratios read off their shapes, :func:`step_ratio`), to this solve's shape
        ``points``, by the polynomial (degree 0, 1 or 2: from one, two or three solutions) that
        predicted the previous solution best (:meth:`_score`); None without a solution."""
        shape = None if points is None else np.array(points, float)
        self._shapes = (self._shapes + [shape])[-4:]
        zs = [z for z in self._solutions if z.size == nt]
        self._candidates = {}
        if len(zs) < len(self._solutions) or not zs:
            return None
        self._candidates[0] = zs[-1]
        for k in range(2, len(zs) + 1):  # k solutions: degree k - 1, if the shapes give the step ratios
            shapes = self._shapes[-k - 1 :]
            times = [0.0, 1.0]  # the pseudo-times of the shapes, the first step of length 1
            for a, b, c in zip(shapes[:-2], shapes[1:-1], shapes[2:], strict=True):
                ratio = step_ratio(a, b, c)
                if not (RATIO_RANGE[0] <= abs(ratio) <= RATIO_RANGE[1]):  # no motion, or not one path
                    break
                times.append(times[-1] + ratio * (times[-1] - times[-2]))
            if len(times) < k + 1:
                break
            self._candidates[k - 1] = lagrange_extrapolate(times[:k], zs[-k:], times[k])
        return self._candidates[min(self._degree, max(self._candidates))]

    def _score(self, z: np.ndarray) -> None:
        """After a solve: the degree whose guess was nearest its solution ``z`` guesses next (the
        highest has the smallest truncation error, a lower one amplifies the solutions' own errors,
        ~``rtol``, less: 1, 2.2, 4.4 times for degrees 0, 1, 2 at equal steps, which wins when the
        steps are short)."""
        if self._candidates:
            errors = {d: float(np.linalg.norm(c - z)) for d, c in self._candidates.items()}
            self._degree = min(errors, key=errors.get)

    def _factor(self, k, g, fr, op) -> None:
        """The preconditioner: the block matrix with ``V'`` replaced by its local part ``L`` (a
        diagonal) and, with a viscosity contrast, ``M / mu`` by its diagonal ``m`` (``op.mix_diagonal``),
        ``f`` eliminated (``f = (A m v) / L - r_f / (mu L)``): the sparse LU of the reduced
        ``[[K + mu A L^-1 A m, F^T], [G, 0]]`` (half the unknowns)."""
        mu, a3 = op.mu, op.areas3
        local = op.local.diagonal()
        md = getattr(op, "mix_diagonal", 1.0)  # the diagonal of M / mu (a viscosity contrast), else 1
        n3 = a3.size
        mat = sp.bmat(
            [[k + sp.diags(mu * a3 * a3 * md / local), sp.csr_matrix(fr).T], [sp.csr_matrix(g), None]], format="csc"
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
            return np.concatenate([v, (a3 * md * v) / local - rf / (mu * local), z[n3:]])

        self._lu = solve
        self.n_factorizations += 1

    def _gmres(self, apply, rhs, x0, limit: int) -> tuple[np.ndarray, np.ndarray, int, bool]:
        """``(z, A z - rhs, iterations, converged)`` by :func:`~cortex_ti.solve.krylov.gmres_left`
        (SciPy's left-preconditioned iterates, one product an iteration; the residual from its kept
        products), at most ``limit`` iterations."""
        z, r, its, ok = gmres_left(apply, self._lu, rhs, x0, self.rtol, limit)
        return z, -r, its, ok


def step_ratio(a, b, c) -> float:
    """The ratio of the step ``b -> c`` to the step ``a -> b`` of three shapes (N, 3) along one
    path: the projection ``<c - b, b - a> / |b - a|^2`` (exact for points moving on straight lines at
    speeds fixed in time; nan without motion or with another mesh)."""
    if a is None or b is None or c is None or not a.shape == b.shape == c.shape:
        return float("nan")
    d = b - a
    dd = float(np.vdot(d, d))
    return float(np.vdot(c - b, d)) / dd if dd > 0.0 else float("nan")


def lagrange_extrapolate(times, values, t: float) -> np.ndarray:
    """The polynomial through ``(times[i], values[i])`` at ``t`` (Lagrange's form).

    >>> import numpy as np
    >>> lagrange_extrapolate([0.0, 1.0, 3.0], [np.array([0.0]), np.array([1.0]), np.array([9.0])], 4.0)
    array([16.])
    """
    out = np.zeros_like(values[0])
    for i, (ti, vi) in enumerate(zip(times, values, strict=True)):
        w = 1.0
        for j, tj in enumerate(times):
            if j != i:
                w *= (t - tj) / (ti - tj)
        out += w * vi
    return out
