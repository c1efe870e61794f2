r"""Bending viscosity in the normal balance (paper Sec. 3.4, Eq. 45), a stabilising term.

With our curvature convention (``C_ab = -n . d_a d_b X``, a sphere has C = 2/R) the
Eulerian rate of curvature change under a normal velocity is
``D^a_b = d_t C^a_b = -nabla^a nabla_b v_n - v_n C^a_c C^c_b`` (trace
``-Lap v_n - v_n C~``; a sphere growing at speed v_n has ``d_t C = -2 v_n / R^2``).
The paper's bending stress is

.. math::
    t_b^{ab} = 2\bar\eta\,(D^{ab} + C\,v_n C^{ab}) + (\bar\eta_b - \bar\eta)\, D^c_c\, g^{ab}

and only its normal force ``C_ab t_b^ab`` is kept (the tangential part is dropped, as
in the paper). Its extra term ``C v_n C^ab`` is the one the paper adds "for reasons of
numerical stability"; the signs lost in the extracted text are fixed here so that
the term adds drag: on a sphere, mode ``l`` of ``v_n`` feels an extra normal force
``kappa_l v_n`` with ``kappa_l = (2 eta_bar_b l(l+1) + 8 eta_bar - 4 eta_bar_b) / R^3``
(see :func:`cortex_ti.truth.analytic.sphere_bending_solution`, which the tests compare with).

Written out, with ``C~ = C^a_b C^b_a`` and ``C- = C^a_b C^b_c C^c_a``:

.. math::
    C_{ab} t_b^{ab} = \beta^{cd}\,\nabla_c\nabla_d v_n + \beta_0 v_n,\quad
    \beta^{cd} = -2\bar\eta C^{cd} - (\bar\eta_b-\bar\eta) C g^{cd},\quad
    \beta_0 = 2\bar\eta (C\tilde C - \bar C) - (\bar\eta_b-\bar\eta) C \tilde C,

and ``nabla_c nabla_d v_n = d_c d_d v_n - Gamma^m_cd d_m v_n`` with the derivatives of
``v_n = n . v`` fitted from the nodal values ``n_a . v_a`` (formulation ``paper``).

Formulation ``rayleigh_p1`` has it as the dissipation
``1/2 int [B^cd d_c v_n d_d v_n + beta_0 v_n^2] dA`` with ``B = -beta``. Its Euler-Lagrange force
is ``-nabla_c (B^cd nabla_d v_n) + beta_0 v_n``; Eq. 45 is ``-B^cd nabla_c nabla_d v_n + beta_0 v_n``:
they differ by ``-(nabla_c B^cd) nabla_d v_n``, zero on a sphere and wherever the curvature is
uniform. ``v_n`` is interpolated linearly and its gradient integrated exactly per triangle,
``B`` averaged over the corners, projected on the triangle and clipped to its positive
semidefinite part (:mod:`cortex_ti.physics.galerkin`); ``beta_0 v_n^2`` is lumped at the nodes.
Formulation ``rayleigh_p2`` integrates the same dissipation on the curved cells at their quadrature
points, ``B`` and ``beta_0`` from the smooth curvature tensor there (:mod:`cortex_ti.physics.galerkin_p2`).
"""

from __future__ import annotations

import numpy as np

from .base import ROW_NORMAL, Context, P1Context, P2Context, PaperContext, Term, register


def curvature_invariants(geometry) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``C^a_b``, ``C^ab``, ``C``, ``C~ = C^a_b C^b_a`` and ``C- = C^a_b C^b_c C^c_a`` per node."""
    gi, cab = geometry.metric_inv, geometry.curvature
    cmix = np.einsum("nac,ncb->nab", gi, cab)  # C^a_b
    cup = np.einsum("nab,nbd->nad", cmix, gi)  # C^ad
    ctr = np.trace(cmix, axis1=1, axis2=2)
    c2 = np.einsum("nab,nba->n", cmix, cmix)
    c3 = np.einsum("nab,nbc,nca->n", cmix, cmix, cmix)
    return cmix, cup, ctr, c2, c3


def hessian_weights(geometry, beta: np.ndarray) -> np.ndarray:
    """Weights ``(N, 5)`` on the fitted derivatives of v_n that give ``beta^cd nabla_c nabla_d v_n``,
    with ``nabla_c nabla_d v_n = d_c d_d v_n - Gamma^m_cd d_m v_n``."""
    w = np.zeros((geometry.n_nodes, 5))
    w[:, 0:2] = -np.einsum("ncd,nmcd->nm", beta, geometry.christoffel)
    w[:, 2] = beta[:, 0, 0]
    w[:, 3] = beta[:, 1, 1]
    w[:, 4] = beta[:, 0, 1] + beta[:, 1, 0]
    return w


def bending_tensors(geometry, eta_bar: float, eta_bar_b: float) -> tuple[np.ndarray, np.ndarray]:
    """``beta^cd`` (N, 2, 2) and ``beta_0`` (N,) of the module docstring: the normal force
    ``beta^cd nabla_c nabla_d v_n + beta_0 v_n`` at each node."""
    gi = geometry.metric_inv
    _, cup, ctr, c2, c3 = curvature_invariants(geometry)
    beta = -2.0 * eta_bar * cup - (eta_bar_b - eta_bar) * ctr[:, None, None] * gi
    beta0 = 2.0 * eta_bar * (ctr * c2 - c3) - (eta_bar_b - eta_bar) * ctr * c2
    return beta, beta0


def bending_weights(geometry, eta_bar: float, eta_bar_b: float) -> tuple[np.ndarray, np.ndarray]:
    """Weights ``(N, 5)`` on the fitted derivatives of v_n and ``(N,)`` on v_n itself."""
    beta, beta0 = bending_tensors(geometry, eta_bar, eta_bar_b)
    return hessian_weights(geometry, beta), beta0


@register
class BendingViscosity(Term):
    effect = "bending_viscosity"
    name = "bending viscosity"

    def applies(self, ctx: Context) -> bool:
        # a normal force only; the scene refuses the effect with both coefficients zero
        p = ctx.physics
        return p.normal_balance and (p.eta_bar > 0 or p.eta_bar_b > 0)

    def paper(self, ctx: PaperContext) -> None:
        w, w0 = bending_weights(ctx.geometry, ctx.physics.eta_bar, ctx.physics.eta_bar_b)
        ctx.Wn[:, ROW_NORMAL] += w
        ctx.Wn0[:, ROW_NORMAL] += w0

    def rayleigh_p1(self, ctx: P1Context) -> None:
        beta, beta0 = bending_tensors(ctx.geometry, ctx.physics.eta_bar, ctx.physics.eta_bar_b)
        ctx.add_normal_form(-beta)
        ctx.add_normal_drag(beta0)

    def rayleigh_p2(self, ctx: P2Context) -> None:
        # B = -beta and beta_0 from the smooth curvature tensor at the quadrature points (ambient
        # form: C^ab e_a e_b is the 3x3 tensor c, C = tr c, C~ = tr c^2, C- = tr c^3)
        eta, eta_b = ctx.physics.eta_bar, ctx.physics.eta_bar_b
        c = ctx.surface.qcurvature
        n = ctx.surface.qnormal
        proj = np.eye(3) - n[..., :, None] * n[..., None, :]
        c1 = c[..., 0, 0] + c[..., 1, 1] + c[..., 2, 2]  # the traces, as np.trace sums them (2x faster)
        cc = c @ c
        c2 = cc[..., 0, 0] + cc[..., 1, 1] + cc[..., 2, 2]
        c3 = np.einsum("tqab,tqba->tq", cc, c)
        bform = 2.0 * eta * c + (eta_b - eta) * c1[..., None, None] * proj
        beta0 = 2.0 * eta * (c1 * c2 - c3) - (eta_b - eta) * c1 * c2
        ctx.add_normal_form(bform, beta0)
