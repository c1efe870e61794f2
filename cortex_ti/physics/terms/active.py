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

from ...solve.system import rigid_motion_rows
from .base import ROW_NORMAL, P1Context, PaperContext, Term, register

#: The choices of ``numerics.active_force`` (formulation ``rayleigh_p1``, module docstring).
ACTIVE_FORCES = {
    "balanced": "the gradient of the discrete energy without the tangential part of zeta_k dA/dx_k at each node: "
    "a uniform tension pushes only normally",
    "gradient": "minus the exact gradient of the discrete energy sum_T zeta_T A_T",
}


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
        zeta = ctx.zeta[ctx.faces]  # (T, 3)
        ctx.add_triangle_force(-(ctx.area * zeta.mean(axis=1))[:, None] * ctx.grads.reshape(-1, 9))
        if ctx.active_force == "balanced":
            ctx.add_node_force(
                tangential_area_force(
                    ctx.geometry.points,
                    ctx.faces,
                    ctx.area,
                    ctx.grads,
                    ctx.zeta,
                    ctx.geometry.normal,
                    ctx.geometry.area,
                )
            )


def tangential_area_force(points, faces, area, grads, zeta, normal, node_area) -> np.ndarray:
    r"""``zeta_k P_k dA/dx_k`` (N, 3), the tangential part of the area gradient at each node
    times the node's tension, less its net force and torque.

    The net force and torque of ``-dE/dX`` are zero (``E`` is invariant under rigid motions);
    those of ``zeta_k P_k dA/dx_k`` are O(h^2), not zero, so the resultant is removed along the
    rows of the mean-velocity gauge (``A_k e`` and ``A_k e x (x_k - x_c)``, ``A_k`` the node
    areas), which that gauge's multipliers take up anyway: the balanced force is then
    translation and rotation invariant like the gradient, and both translation gauges give
    flows that differ by a rigid translation. On a mesh with the icosahedron's symmetry the
    resultant is zero and nothing is removed."""
    n = points.shape[0]
    grad_area = (area[:, None, None] * grads).reshape(-1, 3)  # dA_T/dx_k, (T*3, 3)
    idx = faces.ravel()
    ga = np.stack([np.bincount(idx, weights=grad_area[:, c], minlength=n) for c in range(3)], axis=1)
    corr = zeta[:, None] * (ga - np.einsum("nc,nc->n", ga, normal)[:, None] * normal)
    pushes = rigid_motion_rows(points, node_area).reshape(6, -1)  # the gauge's force rows
    rigid = rigid_motion_rows(points, np.ones(n)).reshape(6, -1)  # translations, rotations
    alpha = np.linalg.solve(rigid @ pushes.T, rigid @ corr.ravel())
    return (corr.ravel() - pushes.T @ alpha).reshape(n, 3)
