r"""Pressure and the constraints of paper Sec. 3.2, each with a Lagrange multiplier.

* Rigid-body gauge (always on: the force balance contains only derivatives of the
  velocity, so a rigid motion can be added to any solution): zero total velocity
  ``sum_i A_i v_i = 0`` (Eq. 36; or, with the scene's ``translation: centroid``, the enclosed
  volume's centroid held, ``sum_i A_i (x_i - x_c) v_n,i = 0``) and zero angular momentum
  ``sum_i A_i (x_i - x_c) x v_i = 0`` (Eq. 37), ``A_i`` the Meyer mixed area, ``x_c``
  the area-weighted centroid (with zero total velocity the reference point drops out).
* Incompressibility (effect ``incompressibility``): the pressure difference ``P``
  becomes an unknown of the normal balance and the enclosed volume is kept,
  ``sum_i v_n,i W_i = 0`` (Eq. 35). We take ``W_i = n_i . dV/dx_i``, the derivative
  of the *triangulated* volume along the direction the node is advected in
  (Eq. 60), rather than the mixed area ``A_i``: both converge to the same
  ``integral of v_n dS = 0``, but with this choice the discrete volume is exactly
  stationary under normal advection, so it is conserved to O(dt^2) per step.
"""

from __future__ import annotations

import numpy as np

from ...solve.system import rigid_motion_rows
from .base import AssemblyContext, Constraint, Term, register


def gauge_rows(geometry, physics) -> np.ndarray:
    """The six rigid-body rows (6, N, 3) of ``physics``'s gauge on ``geometry``: the translation
    fixed by zero mean velocity or, with ``translation: centroid``, by the centroid held (both
    formulations use these)."""
    normal = geometry.normal if physics.centroid_gauge else None
    return rigid_motion_rows(geometry.points, geometry.area, normal)


@register
class RigidBodyGauge(Term):
    effect = None
    name = "zero total velocity and angular momentum"

    def apply(self, ctx: AssemblyContext) -> None:
        ctx.constraints.append(Constraint("momentum", gauge_rows(ctx.geometry, ctx.physics)))


@register
class Incompressibility(Term):
    effect = "incompressibility"
    name = "pressure and volume conservation"

    def apply(self, ctx: AssemblyContext) -> None:
        g = ctx.geometry
        weight = np.einsum("nc,nc->n", g.normal, g.volume_gradient)
        ctx.pressure = True
        ctx.constraints.append(Constraint("volume", (weight[:, None] * g.normal)[None]))
