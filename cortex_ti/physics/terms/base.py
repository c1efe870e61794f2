r"""How a physical term contributes to the discrete force balance.

The unknowns are the nodal velocities. At node ``i`` the force balance has
``R`` rows: the two tangential components (along ``e_xi``, ``e_eta``) and, when
the normal balance is solved, the normal one. Every row is linear in the fitted
velocity derivatives ``V_k = [A_v, B_v, C_v, D_v, E_v]`` (3-vectors, paper Eq. 18),
in the derivatives of the normal speed ``v_n`` (for the bending viscosity) and in
the node's own velocity. A term therefore only writes *weights*:

``W[i, r, k]``   3-vector multiplying ``V_k`` in row ``r``
``W0[i, r]``     3-vector multiplying ``v_i``
``Wn[i, r, k]``  scalar multiplying the k-th fitted derivative of ``v_n = n . v``
``Wn0[i, r]``    scalar multiplying ``v_n`` at node ``i``
``rhs[i, r]``    the velocity-independent right-hand side

and :mod:`cortex_ti.physics.assembly` turns the weights into matrix entries through the
fit operator once for all terms. Dense parts (the pressure column, the
constraint rows with their Lagrange multipliers) are collected separately so the
sparse solve never sees them.

A term is a class registered with :func:`register`; its ``effect`` names the
scene effect that switches it on (``None``: always on), one of
:data:`cortex_ti.physics.model.EFFECTS`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ...surface.geometry import Geometry
from ..model import Physics

#: Row indices within a node
ROW_XI, ROW_ETA, ROW_NORMAL = 0, 1, 2


@dataclass
class Constraint:
    """Dense constraint rows ``sum_i c[j, i] . v_i = 0`` (one Lagrange multiplier each)."""

    name: str
    rows: np.ndarray  # (m, N, 3)


@dataclass
class AssemblyContext:
    geometry: Geometry
    physics: Physics
    zeta: np.ndarray
    W: np.ndarray = field(init=False)
    W0: np.ndarray = field(init=False)
    Wn: np.ndarray = field(init=False)
    Wn0: np.ndarray = field(init=False)
    rhs: np.ndarray = field(init=False)
    implicit_dt: float = 0.0   # time step of the semi-implicit tension (0: explicit)
    pressure: bool = False
    constraints: list = field(default_factory=list)

    def __post_init__(self):
        n, r = self.geometry.n_nodes, self.physics.rows_per_node
        self.W = np.zeros((n, r, 5, 3))
        self.W0 = np.zeros((n, r, 3))
        self.Wn = np.zeros((n, r, 5))
        self.Wn0 = np.zeros((n, r))
        self.rhs = np.zeros((n, r))
        self._zeta_fit = None

    @property
    def zeta_fit(self) -> np.ndarray:
        """Fitted derivatives of the active tension (computed once, when a term asks)."""
        if self._zeta_fit is None:
            self._zeta_fit = self.geometry.fit_scalar(self.zeta)
        return self._zeta_fit


class Term:
    """A physical contribution to the force balance."""

    effect: str | None = None
    name: str = "term"

    def applies(self, ctx: AssemblyContext) -> bool:
        """Whether the term has anything to add on this solve (beyond its effect being on)."""
        return True

    def apply(self, ctx: AssemblyContext) -> None:  # pragma: no cover - interface
        raise NotImplementedError


TERMS: list[type[Term]] = []


def register(cls: type[Term]) -> type[Term]:
    TERMS.append(cls)
    return cls


def active_terms(physics: Physics) -> list[Term]:
    """The terms the effects call for, in registration order."""
    return [cls() for cls in TERMS if cls.effect is None or cls.effect in physics.effects]
