"""The problems the solve layer solves: sparse systems with a few dense constraint rows.

Two kinds, one per family of formulations (:data:`cortex_ti.physics.formulations.FORMULATIONS`):

* :class:`LinearSystem`, the paper's strong form: ``min |M x + p P - r|^2`` subject to
  ``G x = 0`` (:func:`cortex_ti.physics.assembly.assemble`);
* :class:`EnergySystem`, a discrete Rayleighian: ``K x + F^T lambda = f``, ``G x = 0`` with
  ``K`` symmetric positive semidefinite given directly (:func:`cortex_ti.physics.galerkin.assemble_p1`);
  the multipliers act on the rows ``F`` (``G`` unless given: Petrov-Galerkin), the pressure is
  one of them.

Both give the solver (:class:`cortex_ti.solve.constrained.ConstrainedSolver`) the same
things: the symmetric block ``K``, its right-hand side, the pressure column if the pressure is a
separate unknown, the constraint rows, and the residual of the unsquared problem (for iterative
refinement); and, for :mod:`cortex_ti.dynamics.spectrum`, their optimality conditions split node
by node (``kkt_parts``). :func:`rigid_motion_rows` gives the rows of zero total velocity and
angular momentum (the gauge of the force balance, also used to pin the factorised matrix).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

__all__ = ["LinearSystem", "EnergySystem", "NormalEquations", "SolveInfo", "rigid_motion_rows"]


@dataclass
class SolveInfo:
    """What the solve achieved; all values are measured, none assumed."""

    backend: str
    force_residual: float  # the unbalanced force: |M x + p P - r| (least squares) or
    # |K x + F^T lambda - f| (energy system)
    rhs_norm: float  # |r| or |f|
    constraint_violation: float  # max_j |G_j x| / (|G_j| |x|)
    kkt_residual: float  # relative residual of the bordered normal equations
    iterations: int = 0  # GMRES iterations (0: direct solve)
    refactored: bool = True
    seconds: dict = field(default_factory=dict)

    @property
    def relative_residual(self) -> float:
        return self.force_residual / self.rhs_norm if self.rhs_norm > 0 else self.force_residual


@dataclass
class NormalEquations:
    """The symmetric part of a system as the solver borders it: ``[[K, k], [k^T, kappa]]
    [x; P] = [f; g]`` (``k``, ``kappa``, ``g`` only with a separate pressure unknown)."""

    stiffness: sp.csr_matrix  # K (unknowns, unknowns)
    rhs: np.ndarray  # f
    pressure_column: np.ndarray | None = None  # k = M^T p
    pressure_diagonal: float = 0.0  # kappa = p^T p
    pressure_rhs: float = 0.0  # g = p^T r


class _Unknowns:
    """Nodal velocities from the unknowns and back (``basis``: (N, nb, 3))."""

    basis: np.ndarray

    def velocity(self, x: np.ndarray) -> np.ndarray:
        """Cartesian nodal velocities ``(N, 3)`` from the unknowns."""
        nb = self.basis.shape[1]
        return np.einsum("nb,nbc->nc", x.reshape(-1, nb), self.basis)

    def unknowns(self, velocity: np.ndarray) -> np.ndarray:
        """Project Cartesian velocities onto the unknowns (inverse of :meth:`velocity`)."""
        return np.einsum("nc,nbc->nb", velocity, self.basis).ravel()

    def _constraint_parts(self, x: np.ndarray) -> np.ndarray:
        """``G x`` split per node: (m, N), row sums = ``G x``."""
        n, nb = self.basis.shape[0], self.basis.shape[1]
        return (self.constraints.reshape(-1, n, nb) * x.reshape(n, nb)[None]).sum(-1)


@dataclass
class LinearSystem(_Unknowns):
    """``min |M x + p P - r|^2`` subject to ``G x = 0`` (see module docstring)."""

    matrix: sp.csr_matrix  # M, (rows, unknowns)
    rhs: np.ndarray  # r
    pressure_column: np.ndarray | None  # p, or None without the pressure unknown
    constraints: np.ndarray  # G, (m, unknowns), dense
    constraint_names: list[str]
    basis: np.ndarray  # (N, nb, 3): v_i = sum_b x[nb i + b] basis[i, b]
    terms: list[str] = field(default_factory=list)
    row_node: np.ndarray | None = None  # (rows,) the node each row of M belongs to
    force_rows = None  # the multipliers act on the constraint rows themselves

    @property
    def n_unknowns(self) -> int:
        return self.matrix.shape[1]

    def normal_equations(self) -> NormalEquations:
        """``K = M^T M``, ``f = M^T r`` and the pressure's border ``M^T p``, ``p^T p``, ``p^T r``."""
        mt = self.matrix.T.tocsr()
        ne = NormalEquations(stiffness=(mt @ self.matrix).tocsr(), rhs=mt @ self.rhs)
        p = self.pressure_column
        if p is not None:
            ne.pressure_column = mt @ p
            ne.pressure_diagonal = float(p @ p)
            ne.pressure_rhs = float(p @ self.rhs)
        return ne

    def unsquared_residual(self, x: np.ndarray, pressure: float) -> tuple[np.ndarray, float]:
        """``(M^T rho, p^T rho)`` with ``rho = r - M x - p P`` formed from ``M`` itself, so that
        a correction step is not limited by the rounding of ``M^T M`` (corrected semi-normal
        equations)."""
        rho = -self.residual(x, pressure)
        prow = float(self.pressure_column @ rho) if self.pressure_column is not None else 0.0
        return self.matrix.T @ rho, prow

    def measure(self, x: np.ndarray, pressure: float, multipliers: np.ndarray) -> tuple[float, float]:
        """``(|M x + p P - r|, |r|)``: the least-squares residual the solve leaves."""
        return float(np.linalg.norm(self.residual(x, pressure))), float(np.linalg.norm(self.rhs))

    def kkt_parts(self, x: np.ndarray, pressure: float, multipliers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The optimality conditions at ``(x, P, lambda)`` split so that every entry belongs to
        one node (for :mod:`cortex_ti.dynamics.spectrum`): ``M^T rho + G^T lambda`` with
        ``rho = M x + p P - r`` (one entry per unknown), and the scalar rows per node, ``(1 + m, N)``
        (``p^T rho``, if there is a pressure unknown, then ``G x``) whose row sums are those rows."""
        rho = self.residual(x, pressure)
        vec = self.matrix.T @ rho + self.constraints.T @ multipliers
        per_node = self._constraint_parts(x)
        if self.pressure_column is not None:
            n = self.basis.shape[0]
            pp = np.bincount(self.row_node, weights=self.pressure_column * rho, minlength=n)
            per_node = np.vstack([pp[None], per_node])
        return vec, per_node

    def residual(self, x: np.ndarray, pressure: float = 0.0) -> np.ndarray:
        res = self.matrix @ x - self.rhs
        if self.pressure_column is not None:
            res += self.pressure_column * pressure
        return res


@dataclass
class EnergySystem(_Unknowns):
    """``K x + F^T lambda = f``, ``G x = 0`` (see module docstring): the stationary point of a
    discrete Rayleighian ``x^T K x / 2 - f^T x`` under the constraints ``G x = 0``, whose
    multipliers push along ``F`` (``G`` if ``force_rows`` is None). The pressure is
    ``pressure_sign * lambda[pressure_index]``."""

    stiffness: sp.csr_matrix  # K, symmetric positive semidefinite
    rhs: np.ndarray  # f
    constraints: np.ndarray  # G, (m, unknowns), dense
    constraint_names: list[str]
    basis: np.ndarray  # (N, nb, 3)
    pressure_index: int | None = None
    pressure_sign: float = -1.0
    terms: list[str] = field(default_factory=list)
    force_rows: np.ndarray | None = None  # F, if not G (Petrov-Galerkin)
    #: ``(U, V)`` (unknowns, k), a low-rank part of the matrix: ``K + U V^T`` (dense columns the
    #: solver borders with k extra unknowns ``y = V^T x``, so ``K`` stays sparse)
    low_rank: tuple[np.ndarray, np.ndarray] | None = None
    #: (unknowns, unknowns) a dense symmetric part of the matrix, ``K + D`` (the fluids'): the solver
    #: then factorises the whole matrix densely (:mod:`cortex_ti.solve.dense`)
    dense: np.ndarray | None = None
    #: the fluids applied matrix-free (``fluid.solver: fmm``, :mod:`cortex_ti.solve.fluid_krylov`): ``op @ v``
    #: is ``D v`` (a Krylov solve: diagnostics only), ``op.resistance(v)`` the fluids' force on the cortex
    #: with its sign reversed (``D v`` less the far field's), ``op.far`` the far field's velocity (3N,) or None
    fluid_operator: object | None = None
    pressure_column = None  # the pressure is a multiplier, not a separate unknown

    @property
    def n_unknowns(self) -> int:
        return self.stiffness.shape[0]

    def normal_equations(self) -> NormalEquations:
        return NormalEquations(stiffness=self.stiffness, rhs=self.rhs)

    def pressure(self, multipliers: np.ndarray) -> float:
        """The pressure from the multipliers (0 without a volume constraint)."""
        if self.pressure_index is None:
            return 0.0
        return float(self.pressure_sign * multipliers[self.pressure_index])

    def residual(self, x: np.ndarray, multipliers: np.ndarray) -> np.ndarray:
        """``K x + F^T lambda - f``."""
        rows = self.constraints if self.force_rows is None else self.force_rows
        out = self.stiffness @ x + rows.T @ multipliers - self.rhs
        if self.low_rank is not None:
            out = out + self.low_rank[0] @ (self.low_rank[1].T @ x)
        if self.dense is not None:
            out = out + self.dense @ x
        if self.fluid_operator is not None:
            out = out + self.fluid_operator.resistance(x)
        return out

    def unsquared_residual(self, x: np.ndarray, pressure: float) -> tuple[np.ndarray, float]:
        out = self.rhs - self.stiffness @ x
        if self.fluid_operator is not None:
            out = out - self.fluid_operator.resistance(x)
        return (out if self.dense is None else out - self.dense @ x), 0.0

    def measure(self, x: np.ndarray, pressure: float, multipliers: np.ndarray) -> tuple[float, float]:
        """``(|K x + F^T lambda - f|, |f|)``: the force balance the solve leaves unbalanced."""
        return float(np.linalg.norm(self.residual(x, multipliers))), float(np.linalg.norm(self.rhs))

    def kkt_parts(self, x: np.ndarray, pressure: float, multipliers: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`LinearSystem.kkt_parts`: ``K x + F^T lambda - f`` and ``G x`` per node."""
        return self.residual(x, multipliers), self._constraint_parts(x)


def rigid_motion_rows(points: np.ndarray, weight: np.ndarray, normal: np.ndarray | None = None) -> np.ndarray:
    """Rows (6, N, 3): the translation (3) and the rotation (3) fixed, weighted per node.

    ``sum_i w_i (x_i - x_c) x v_i = 0`` (angular momentum) with ``x_c`` the weighted centroid,
    and for the translation ``sum_i w_i v_i = 0`` (zero total velocity; the reference point of
    the rotation rows then drops out), or, given the ``normal``s, ``sum_i w_i (x_i - x_c) (n_i . v_i)
    = 0``: the velocity of the enclosed volume's centroid, which a rigid translation U moves at
    U (the integral of (x - x_c) n^T dA is V times the identity).
    """
    n = points.shape[0]
    rows = np.zeros((6, n, 3))
    centroid = (weight[:, None] * points).sum(0) / weight.sum()
    r = points - centroid
    eye = np.eye(3)
    for k in range(3):
        if normal is None:
            rows[k, :, k] = weight
        else:
            rows[k] = (weight * r[:, k])[:, None] * normal
        rows[3 + k] = weight[:, None] * np.cross(eye[k], r)
    return rows
