r"""Isotropic active tension ``zeta^ab = zeta g^ab`` (paper Eq. 29), zeta > 0 contractile.

It enters only the right-hand side (conventions.md):

* tangential: ``nabla_a t_v^ab = -g^ab d_a zeta`` (the derivatives from the same fit
  as the velocity, paper Sec. 3.6 step 2),
* normal: ``C_ab t_v^ab - P = -zeta C``.
"""

from __future__ import annotations

import numpy as np

from .base import ROW_NORMAL, AssemblyContext, Term, register


@register
class ActiveStress(Term):
    effect = "active_stress"
    name = "active tension"

    def apply(self, ctx: AssemblyContext) -> None:
        g = ctx.geometry
        dzeta = ctx.zeta_fit[:, :2]
        ctx.rhs[:, :2] -= np.einsum("nab,na->nb", g.metric_inv, dzeta)
        if ctx.physics.normal_balance:
            ctx.rhs[:, ROW_NORMAL] -= ctx.zeta * g.mean_curvature
