r"""Viscous surface stress (paper Eqs. 14-17): shear viscosity eta_s and bulk viscosity eta_b.

With ``V_a = d_a v`` and ``V_ab = d_a d_b v`` the fitted velocity derivatives, the
strain rate and its covariant derivative at the node are (conventions.md; paper
Eqs. 10, 22 with the Christoffel terms kept, since the angle-weighted normal is
not exactly the normal of the fitted patch)

.. math::
    u_{cd} &= \tfrac12 (V_c\cdot e_d + V_d\cdot e_c) \\
    \nabla_a u_{cd} &= \tfrac12 (H_{ac}\cdot e_d + H_{ad}\cdot e_c)
        - \tfrac12 C_{ad}\, V_c\cdot n - \tfrac12 C_{ac}\, V_d\cdot n,
    \qquad H_{ab} = V_{ab} - \Gamma^m_{ab} V_m .

The viscous stress ``t^ab = 2 eta_s (u^ab - u g^ab / 2) + eta_b u g^ab`` then gives

* tangential rows (contravariant components ``f^b = nabla_a t^ab``, which are the
  components of the tangential force along ``e_xi``, ``e_eta``):
  ``f^b = sum_acd [eta_s (2 g^ac g^bd - g^ab g^cd) + eta_b g^ab g^cd] nabla_a u_cd``
* normal row: ``C_ab t^ab = sum_cd [eta_s (2 C^cd - C g^cd) + eta_b C g^cd] u_cd``.

Shear and bulk viscosity are separate effects sharing one kernel.

Formulation ``paper`` writes these weights with one Taichi kernel (:mod:`.viscous_kernel`,
loaded when the term is first applied, so the registry imports no Taichi). Formulation
``rayleigh_p1`` integrates the dissipation ``A_T [eta_s |U~_T|^2 + eta_b/2 (tr U_T)^2]`` exactly on
each flat triangle (:func:`cortex_ti.physics.p1_blocks.viscous_blocks`): the terms give its two
coefficients.
"""

from .base import P1Context, P2Context, PaperContext, Term, register


def add_viscous(ctx: PaperContext, eta_s: float, eta_b: float) -> None:
    """Add the weights of the viscous stress with coefficients ``eta_s``, ``eta_b`` to ``ctx``."""
    # Taichi, loaded on the first assembly (the registry imports no Taichi)
    from .viscous_kernel import viscous_kernel

    g = ctx.geometry
    viscous_kernel(
        g.tangents,
        g.normal_fit,
        g.metric_inv,
        g.curvature,
        g.christoffel,
        float(eta_s),
        float(eta_b),
        int(ctx.physics.normal_balance),
        ctx.W,
    )


@register
class ShearViscosity(Term):
    """``2 eta_s`` times the traceless strain rate."""

    effect = "shear_viscosity"
    name = "shear viscosity"

    def paper(self, ctx: PaperContext) -> None:
        add_viscous(ctx, ctx.physics.eta_s, 0.0)

    def rayleigh_p1(self, ctx: P1Context) -> None:
        ctx.shear += ctx.physics.eta_s

    def rayleigh_p2(self, ctx: P2Context) -> None:
        ctx.shear += ctx.physics.eta_s


@register
class BulkViscosity(Term):
    """``eta_b`` times the rate of area change."""

    effect = "bulk_viscosity"
    name = "bulk viscosity"

    def paper(self, ctx: PaperContext) -> None:
        add_viscous(ctx, 0.0, ctx.physics.eta_b)

    def rayleigh_p1(self, ctx: P1Context) -> None:
        ctx.bulk += ctx.physics.eta_b

    def rayleigh_p2(self, ctx: P2Context) -> None:
        ctx.bulk += ctx.physics.eta_b
