r"""Isotropic active tension ``zeta^ab = zeta g^ab`` (paper Eq. 29), zeta > 0 contractile.

Formulation ``paper``: it enters only the right-hand side (conventions.md):

* tangential: ``nabla_a t_v^ab = -g^ab d_a zeta`` (the derivatives from the same fit
  as the velocity, paper Sec. 3.6 step 2),
* normal: ``C_ab t_v^ab - P = -zeta C``.

Formulation ``rayleigh_p1``: the power ``-sum_T A_T zeta_T tr U_T`` (``zeta_T`` the mean of the
corner values), exactly the rate of the discrete energy ``E(X) = sum_T zeta_T A_T(X)``, so the
active force is the exact gradient ``-dE/dX`` and the shape dynamics a gradient flow.

Formulation ``rayleigh_p2``: with ``balanced`` the power ``-int zeta tr u dA`` on the curved cells
(the rate of strain of the formulation's velocity, the normal speed through the fitted curvature), the
tension interpolated quadratically from the cells' six nodes (:mod:`cortex_ti.physics.galerkin_p2`),
each node's force less ``zeta_i P_i int tr u_i dA``, the tangential part its own tension would push
with if it were uniform (as ``tangential_area_force`` for ``rayleigh_p1``); with ``gradient`` minus the
exact gradient of ``E_h = int zeta dA`` over the curved cells through the nodes
(:meth:`~cortex_ti.surface.curved.CurvedSurface.energy_gradient`), so again a gradient flow, at the
price of the t = 0 flows' third order (docs/validation/curved.md).
"""

from __future__ import annotations

import numpy as np

from .base import ROW_NORMAL, P1Context, P2Context, PaperContext, Term, register

#: The choices of ``numerics.active_force`` (formulations ``rayleigh_p1`` and ``rayleigh_p2``, module docstring).
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
                )
            )

    def rayleigh_p2(self, ctx: P2Context) -> None:
        if ctx.active_force == "gradient":
            # minus the exact gradient of E_h = int zeta dA over the curved cells
            ctx.add_energy_tension(ctx.zeta)
            return
        # the power int zeta tr u dA on the curved cells, zeta interpolated from all six nodes
        ctx.add_tension(ctx.zeta)
        if ctx.active_force == "balanced":
            ctx.balanced_tension = ctx.zeta


def tangential_area_force(points, faces, area, grads, zeta, normal) -> np.ndarray:
    r"""``zeta_k P_k dA/dx_k`` (N, 3): the tangential part of the area gradient at each node
    (``P_k = I - n_k n_k^T``) times the node's tension; local (node k and its triangles).

    Unlike ``-dE/dX`` it has a net force and torque, O(h^2) (zero on a mesh with the
    icosahedron's symmetry): the gauge's multipliers take them up as a uniform force density, the
    same in both translation gauges (:mod:`.constraints`), so the two gauges' flows still differ
    by a rigid translation exactly."""
    n = points.shape[0]
    grad_area = (area[:, None, None] * grads).reshape(-1, 3)  # dA_T/dx_k, (T*3, 3)
    idx = faces.ravel()
    ga = np.stack([np.bincount(idx, weights=grad_area[:, c], minlength=n) for c in range(3)], axis=1)
    return zeta[:, None] * (ga - np.einsum("nc,nc->n", ga, normal)[:, None] * normal)
