"""The problem the solve layer solves: a sparse least-squares system with dense constraints.

:class:`LinearSystem` is what :func:`cortex_ti.physics.assembly.assemble` produces and
:class:`cortex_ti.solve.constrained.ConstrainedLeastSquares` solves; :func:`rigid_motion_rows`
gives the rows of zero total velocity and angular momentum (the gauge of the force balance,
also used to pin the factorised matrix).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

__all__ = ["LinearSystem", "rigid_motion_rows"]


@dataclass
class LinearSystem:
    """``min |M x + p P - r|^2`` subject to ``G x = 0`` (see module docstring)."""

    matrix: sp.csr_matrix             # M, (rows, unknowns)
    rhs: np.ndarray                   # r
    pressure_column: np.ndarray | None  # p, or None without the pressure unknown
    constraints: np.ndarray           # G, (m, unknowns), dense
    constraint_names: list[str]
    basis: np.ndarray                 # (N, nb, 3): v_i = sum_b x[nb i + b] basis[i, b]
    terms: list[str] = field(default_factory=list)

    @property
    def n_unknowns(self) -> int:
        return self.matrix.shape[1]

    def velocity(self, x: np.ndarray) -> np.ndarray:
        """Cartesian nodal velocities ``(N, 3)`` from the unknowns."""
        nb = self.basis.shape[1]
        return np.einsum("nb,nbc->nc", x.reshape(-1, nb), self.basis)

    def unknowns(self, velocity: np.ndarray) -> np.ndarray:
        """Project Cartesian velocities onto the unknowns (inverse of :meth:`velocity`)."""
        return np.einsum("nc,nbc->nb", velocity, self.basis).ravel()

    def residual(self, x: np.ndarray, pressure: float = 0.0) -> np.ndarray:
        res = self.matrix @ x - self.rhs
        if self.pressure_column is not None:
            res += self.pressure_column * pressure
        return res


def rigid_motion_rows(points: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Rows (6, N, 3): total velocity (3) and angular momentum (3), weighted per node.

    ``sum_i w_i v_i = 0`` and ``sum_i w_i (x_i - x_c) x v_i = 0`` with ``x_c`` the weighted
    centroid (with zero total velocity the reference point drops out).
    """
    n = points.shape[0]
    rows = np.zeros((6, n, 3))
    centroid = (weight[:, None] * points).sum(0) / weight.sum()
    r = points - centroid
    eye = np.eye(3)
    for k in range(3):
        rows[k, :, k] = weight
        rows[3 + k] = weight[:, None] * np.cross(eye[k], r)
    return rows
