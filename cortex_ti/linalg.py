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

The factorisation is chosen by name from :data:`FACTORIZATIONS` (SciPy's SuperLU
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

from .assemble import LinearSystem
from .errors import SolverError

log = logging.getLogger(__name__)

FACTORIZATIONS: dict[str, type] = {}


def register_factorization(name: str):
    def deco(cls):
        cls.name = name
        FACTORIZATIONS[name] = cls
        return cls

    return deco


class Factorization:
    """A sparse SPD factorisation kept across solves.

    ``factorize(a)`` factors a new matrix; backends that can reuse the symbolic
    analysis (ordering, elimination tree) do so while the sparsity pattern is
    unchanged, which is the case over a whole run because the topology is fixed.
    """

    name = "base"

    @staticmethod
    def available() -> bool:  # pragma: no cover - interface
        return True

    def factorize(self, a: sp.spmatrix) -> None:  # pragma: no cover - interface
        raise NotImplementedError

    def solve(self, b: np.ndarray) -> np.ndarray:  # pragma: no cover - interface
        raise NotImplementedError


@register_factorization("superlu")
class SuperLUFactor(Factorization):
    """SciPy's SuperLU with a symmetric ordering (always available; no analysis reuse)."""

    def factorize(self, a):
        self._lu = spla.splu(a.tocsc(), permc_spec="MMD_AT_PLUS_A",
                             diag_pivot_thresh=0.0, options={"SymmetricMode": True})

    def solve(self, b):
        return self._lu.solve(b)


@register_factorization("pardiso")
class PardisoFactor(Factorization):
    """Intel MKL PARDISO through ``pypardiso``, real SPD (mtype 2), upper triangle.

    Phase 11 (analysis, METIS ordering) runs only when the sparsity pattern changes;
    each new matrix costs only phase 22 (numerical factorisation).
    """

    @staticmethod
    def available() -> bool:
        try:
            import pypardiso  # noqa: F401
        except Exception:
            return False
        return True

    def __init__(self):
        import pypardiso

        self._solver = pypardiso.PyPardisoSolver(mtype=2)
        self._pattern = None
        self._a = None

    def factorize(self, a):
        upper = sp.triu(a, format="csr")
        upper.sort_indices()
        pattern = (upper.shape, upper.indptr.copy(), upper.indices.copy())
        same = (self._pattern is not None and self._pattern[0] == pattern[0]
                and np.array_equal(self._pattern[1], pattern[1]) and np.array_equal(self._pattern[2], pattern[2]))
        dummy = np.zeros(upper.shape[0])
        if not same:
            self._solver.set_phase(11)
            self._solver._call_pardiso(upper, dummy)
            self._pattern = pattern
        self._solver.set_phase(22)
        self._solver._call_pardiso(upper, dummy)
        self._a = upper

    def solve(self, b):
        self._solver.set_phase(33)
        out = self._solver._call_pardiso(self._a, np.asfortranarray(b))
        return out.reshape(b.shape)

    def __del__(self):
        try:
            self._solver.free_memory(everything=True)
        except Exception:
            pass


def choose_factorization(name: str = "auto") -> type:
    """The factorisation class for ``name``; ``auto`` takes the fastest installed."""
    if name == "auto":
        for candidate in ("pardiso", "superlu"):
            if FACTORIZATIONS[candidate].available():
                return FACTORIZATIONS[candidate]
    if name not in FACTORIZATIONS:
        raise SolverError(f"unknown solver backend {name!r}; choose one of auto, {', '.join(FACTORIZATIONS)}")
    cls = FACTORIZATIONS[name]
    if not cls.available():
        raise SolverError(f"solver backend {name!r} is not installed here")
    return cls


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
    from .terms.constraints import rigid_body_rows

    rows = rigid_body_rows(points[nodes], np.ones(len(nodes)))      # (6, k, 3)
    local = np.einsum("mkc,kbc->mkb", rows, basis[nodes])            # (6, k, nb)
    nb = basis.shape[1]
    cols = (nodes[:, None] * nb + np.arange(nb)[None, :]).ravel()
    data = local.reshape(6, -1)
    data /= np.linalg.norm(data, axis=1, keepdims=True)
    return sp.csr_matrix((data.ravel(), (np.repeat(np.arange(6), cols.size), np.tile(cols, 6))),
                         shape=(6, basis.shape[0] * nb))


class _Bordered:
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
    """Solve :class:`~cortex_ti.assemble.LinearSystem` (see the module docstring).

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
        self._pre: _Bordered | None = None
        self._pin_nodes = None  # (N, node indices) of the sparse pin, chosen once per mesh
        self.n_factorizations = 0

    @property
    def backend(self) -> str:
        return self.factor_cls.name

    def solve(self, system: LinearSystem, points: np.ndarray) -> tuple[np.ndarray, float, SolveInfo]:
        """Return velocity unknowns ``x``, pressure ``P`` (0 without it) and diagnostics."""
        t0 = time.perf_counter()
        m = system.matrix
        mt = m.T.tocsr()
        kmat = (mt @ m).tocsr()
        f = mt @ system.rhs
        has_p = system.pressure_column is not None
        cols, g = [], []
        if has_p:
            p = system.pressure_column
            cols.append((mt @ p)[:, None])
            kappa = float(p @ p)
            g.append(float(p @ system.rhs))
        gmat = system.constraints
        n_con = gmat.shape[0]
        if self._pin_nodes is None or self._pin_nodes[0] != points.shape[0]:
            self._pin_nodes = (points.shape[0], _farthest_points(points, min(PIN_NODES, points.shape[0])))
        pin = pin_rows(points, system.basis, nodes=self._pin_nodes[1])
        scale = float(np.mean(kmat.diagonal()))
        pin = pin * np.sqrt(scale)
        gscale = np.linalg.norm(gmat, axis=1, keepdims=True)
        gscale[gscale == 0] = 1.0
        gn = gmat / gscale * np.sqrt(scale)   # scaled constraint rows, same magnitude as K
        border = np.hstack(cols + [gn.T, pin.T.toarray()])
        q = border.shape[1]
        dblock = np.zeros((q, q))
        if has_p:
            dblock[0, 0] = kappa
        npin = pin.shape[0]
        dblock[q - npin:, q - npin:] = np.eye(npin)
        rhs = np.concatenate([f, g, np.zeros(n_con + npin)])
        t1 = time.perf_counter()

        # [[K_s, U], [U^T, D]] with K_s = K + Q^T Q, U = [k, G^T, Q^T], D = diag(kappa, 0, I):
        # the last block row is Q x + w = 0, so K_s x + Q^T w = K x.
        ks = (kmat + pin.T @ pin).tocsr()

        def bordered_matvec(z):
            x, y = z[: f.size], z[f.size:]
            return np.concatenate([ks @ x + border @ y, border.T @ x + dblock @ y])

        iterations, refactored = 0, False
        sol = None
        if self.reuse and self._pre is not None and self._pre.n == f.size and self._pre.border.shape == border.shape:
            op = spla.LinearOperator((rhs.size, rhs.size), matvec=bordered_matvec, dtype=float)
            pre = spla.LinearOperator((rhs.size, rhs.size), matvec=self._pre.solve, dtype=float)
            counter = [0]

            def cb(_):
                counter[0] += 1

            z, status = spla.gmres(op, rhs, M=pre, x0=self._pre.solve(rhs), rtol=self.rtol, atol=0.0,
                                   restart=self.max_iter, maxiter=1, callback=cb, callback_type="pr_norm")
            iterations = counter[0]
            if status == 0:
                sol = z
        t2 = time.perf_counter()
        if sol is None:
            try:
                self._factor.factorize(ks)
                factor = self._factor
            except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
                raise SolverError(
                    "the force balance has no unique solution (singular matrix): check that the scene has "
                    f"shear viscosity and a closed, well-shaped mesh ({exc})"
                ) from None
            self._pre = _Bordered(factor, border, dblock, first_rhs=f)
            self.n_factorizations += 1
            sol = self._pre.solve_first(rhs[f.size:])
            refactored = True
        t3 = time.perf_counter()
        if not np.all(np.isfinite(sol)):
            raise SolverError("the linear solve produced non-finite values (singular or badly scaled system)")
        x = sol[: f.size]
        pressure = float(sol[f.size]) if has_p else 0.0
        res = system.residual(x, pressure)
        kkt = bordered_matvec(sol) - rhs
        viol = np.abs(gmat @ x) / (gscale[:, 0] * max(np.linalg.norm(x), 1e-300))
        info = SolveInfo(
            backend=self.backend,
            lsq_residual=float(np.linalg.norm(res)),
            rhs_norm=float(np.linalg.norm(system.rhs)),
            constraint_violation=float(viol.max()) if viol.size else 0.0,
            kkt_residual=float(np.linalg.norm(kkt) / max(np.linalg.norm(rhs), 1e-300)),
            iterations=iterations,
            refactored=refactored,
            seconds={"normal_equations": t1 - t0, "iterate": t2 - t1, "factor_solve": t3 - t2},
        )
        return x, pressure, info
