r"""Isotropic active tension ``zeta^ab = zeta g^ab`` (paper Eq. 29), zeta > 0 contractile.

Formulation ``paper``: it enters only the right-hand side (conventions.md):

* tangential: ``nabla_a t_v^ab = -g^ab d_a zeta`` (the derivatives from the same fit
  as the velocity, paper Sec. 3.6 step 2),
* normal: ``C_ab t_v^ab - P = -zeta C``.

Formulation ``rayleigh_p1``: the power ``-sum_T A_T zeta_T tr U_T`` (``zeta_T`` the mean of the
corner values), exactly the rate of the discrete energy ``E(X) = sum_T zeta_T A_T(X)``, so the
active force is the exact gradient ``-dE/dX`` and the shape dynamics a gradient flow.
"""

from __future__ import annotations

import numpy as np

from .base import ROW_NORMAL, P1Context, PaperContext, Term, register


@register
class ActiveStress(Term):
    effect = "active_stress"
    name = "active tension"

    def paper(self, ctx: PaperContext) -> None:
        g = ctx.geometry
        dzeta = ctx.zeta_fit[:, :2]
        ctx.rhs[:, :2] -= np.einsum("nab,na->nb", g.metric_inv, dzeta)
        if ctx.physics.normal_balance:
            ctx.rhs[:, ROW_NORMAL] -= ctx.zeta * g.mean_curvature

    def rayleigh_p1(self, ctx: P1Context) -> None:
        # -A_T zeta_T grad tr U on the triangle's nine velocity components
        ctx.add_triangle_force(-(ctx.area * ctx.zeta[ctx.faces].mean(axis=1))[:, None] * ctx.grads.reshape(-1, 9))
