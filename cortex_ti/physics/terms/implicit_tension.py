r"""Semi-implicit active tension: the normal force of the tension on the shape after the step.

Explicit normal advection evaluates the tension's normal force ``-zeta C`` on the current
shape. A normal perturbation of wavenumber q changes C by ``q^2`` times its height, so
the explicit step must resolve a relaxation rate that grows with q; where the discrete
viscous operator holds such a mode only weakly (the stiff spurious modes of sheared,
coarse meshes, :func:`cortex_ti.dynamics.spectrum.normal_spectrum`) the step collapses.

The classical remedy for surface tension (the semi-implicit curvature of free-surface
flow solvers) is to evaluate the curvature on the shape the step produces,
``C(t + dt) ~ C + dt dC/dt``, with the Eulerian rate under normal advection
(conventions of :mod:`cortex_ti.physics.terms.bending`)

.. math:: \partial_t C = -\Delta v_n - \tilde C\, v_n, \qquad \tilde C = C^a_b C^b_a .

The normal balance ``... = -zeta C`` becomes

.. math:: \ldots - \zeta\,\Delta t\,(\Delta v_n + \tilde C v_n) = -\zeta C,

i.e. a drag ``zeta dt q^2`` on mode q: for a mode whose explicit rate is ``lambda`` the
step multiplies it by ``1 / (1 - lambda dt)`` (backward Euler) instead of
``1 + lambda dt``. The term is O(dt), so the scheme stays first order and a steady
shape (v_n = 0) is unchanged; at ``dt = 0`` (static solves, frame diagnostics) it is
absent. It is assembled only when the time integrator asks for it
(``time.implicit_tension``) and the normal balance is solved.

Formulation ``rayleigh_p1`` adds the dissipation ``dt zeta |grad v_n|^2`` (``zeta`` clipped at 0),
integrated as the bending viscosity's: the leading part of the tension's Hessian (the
``-zeta dt Lap v_n`` above, without its indefinite ``-zeta dt C~ v_n``), so the step's matrix stays
definite whatever ``dt``.

**Centred on a rate** (``implicit_rate``, the second-order scheme ``bdf2``,
``docs/derivations/time_schemes.md``): the dissipation becomes ``dt zeta |grad (v_n - r_n)|^2``
with ``r`` the nodes' rate over the last step, i.e. the drag acts on the *change* of the normal
velocity, ``O(dt^2)`` on a smooth flow, and still holds down every stiff mode. Only
``rayleigh_p1`` implements it (the scene rules refuse ``bdf2`` with ``numerics.formulation:
paper``).

**Its weight** (``numerics.implicit_tension_weight``, ``theta``, default 1): ``rayleigh_p1`` and
``rayleigh_p2`` multiply the drag by ``theta``. The drag is the continuum Hessian's leading part, not
the discrete tension's stiffness: on a mode the viscous dissipation hardly resists (a mesh-scale
near-isometry of a saddle, where the stub of a just-divided daughter meets its lobe), extrapolated BDF2 maps the mode by
``z^2 - 2 a z + a = 0``, ``a = 1 - rho / theta``, ``rho`` the ratio of the discrete tension's
stiffness to the drag on it, stable only for ``rho < 4 theta / 3``; on flat triangles with the nodes
moving along their normals ``rho`` reaches 2.0 (icospheres) to 3.2 (the daughters' MMG meshes), so
``theta = 1`` lets the mode oscillate from step to step and the error control shrinks the step to
that of the explicit scheme (docs/derivations/implicit_tension_weight.md). Centred on the rate the
weighted drag stays ``O(dt^2)``, but it pulls the state toward the extrapolation the error estimate
compares it with, hiding part of the step's error: the daughters of a division get ``theta = 2.5``
from the cut on (``division.implicit_tension_weight``), the rest keeps 1.
"""

from __future__ import annotations

import numpy as np

from ...errors import SolverError
from ..p1_blocks import normal_form_force  # the P1 blocks the formulation shares, not the formulation
from .base import ROW_NORMAL, Context, P1Context, P2Context, PaperContext, Term, register
from .bending import curvature_invariants, hessian_weights


def implicit_tension_weights(geometry, zeta: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Weights ``(N, 5)`` on the fitted derivatives of v_n and ``(N,)`` on v_n."""
    _, _, _, c2, _ = curvature_invariants(geometry)
    beta = -(dt * zeta)[:, None, None] * geometry.metric_inv
    return hessian_weights(geometry, beta), -dt * zeta * c2


@register
class ImplicitTension(Term):
    effect = "active_stress"
    name = "semi-implicit active tension"

    def applies(self, ctx: Context) -> bool:
        return ctx.implicit_dt > 0.0 and ctx.physics.normal_balance

    def paper(self, ctx: PaperContext) -> None:
        if ctx.implicit_rate is not None:
            raise SolverError(
                "the semi-implicit tension centred on a rate (time.scheme = bdf2) is implemented for "
                "numerics.formulation = rayleigh_p1 only"
            )
        w, w0 = implicit_tension_weights(ctx.geometry, ctx.zeta, ctx.implicit_dt)
        ctx.Wn[:, ROW_NORMAL] += w
        ctx.Wn0[:, ROW_NORMAL] += w0

    def rayleigh_p1(self, ctx: P1Context) -> None:
        # theta dt zeta |grad v_n|^2, zeta clipped at 0: positive semidefinite whatever dt (theta: module docstring)
        scale = ctx.implicit_weight * ctx.implicit_dt
        bform = (scale * np.clip(ctx.zeta, 0.0, None))[:, None, None] * ctx.geometry.metric_inv
        ctx.add_normal_form(bform)
        if ctx.implicit_rate is not None:
            ctx.add_triangle_force(
                normal_form_force(
                    ctx.geometry, ctx.faces, bform, ctx.tnormal, ctx.grads, ctx.area, np.asarray(ctx.implicit_rate)
                )
            )

    def rayleigh_p2(self, ctx: P2Context) -> None:
        # theta dt zeta |grad (v_n - r_n)|^2 at the quadrature points, zeta clipped at 0
        surf = ctx.surface
        zq = np.clip(surf.at_quadrature(ctx.zeta), 0.0, None)
        n = surf.qnormal
        proj = np.eye(3) - n[..., :, None] * n[..., None, :]
        centre = None if ctx.implicit_rate is None else np.asarray(ctx.implicit_rate)
        ctx.add_normal_form((ctx.implicit_weight * ctx.implicit_dt * zq)[..., None, None] * proj, None, centre)
