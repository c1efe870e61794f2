r"""A cytoplasm and a medium as Stokes fluids (the effect ``fluids``, issue 36): formulation
``rayleigh_p1`` only.

On every solve the fluids' map on the current shape is rebuilt (it depends on the shape), one of
two ways (``fluid.solver``, resolved by ``RunSettings``):

* ``dense``: the fluids' dissipation ``D`` (:func:`cortex_ti.physics.fluids.fluid_operator`: the
  boundary-integral map) is added to the Rayleighian as a dense block (:attr:`P1Context.dense`) and
  the far field's ``mu_out A S^-1 A u_inf`` as nodal forces; the system is then solved densely
  (:mod:`cortex_ti.solve.dense`);
* ``fmm``: the matrix-free operator (:class:`~cortex_ti.physics.fluids_fast.FmmFluid`, equal
  viscosities), far field included, is handed to the system (:meth:`P1Context.add_fluid_operator`),
  which the coupled GMRES of :mod:`cortex_ti.solve.fluid_krylov` solves.

The cytoplasm's hydrostatic pressure ``(b . x) n`` of a body force ``b`` is a nodal force either
way (:func:`~cortex_ti.physics.fluids.body_force_nodes`). The medium fixes the rigid translation and
rotation, so the rigid-body gauge does not apply with this effect
(:class:`~cortex_ti.physics.terms.constraints.RigidBodyGauge`); the volume constraint stays (the
scene rules ask for ``incompressibility``). The paper's strong form and the curved cells have no
term: the scene rules refuse the effect there.
"""

from __future__ import annotations

from .base import P1Context, Term, register


@register
class Fluids(Term):
    effect = "fluids"
    name = "inner and outer Stokes fluids"
    paper = None
    rayleigh_p2 = None

    def rayleigh_p1(self, ctx: P1Context) -> None:
        from ..fluids import body_force_nodes, fluid_operator

        fluid, g = ctx.physics.fluid, ctx.geometry
        if fluid is None:  # the effect on without its settings: resolved by RunSettings, never here
            from ...errors import SolverError

            raise SolverError("the effect 'fluids' needs its settings (Physics.fluid)")
        far = fluid.far_velocity(g.points)
        if fluid.solver in ("fmm", "direct"):
            from ..fluids_fast import fmm_fluid

            ctx.add_fluid_operator(
                fmm_fluid(
                    g.points, ctx.faces, g.normal, mu_in=fluid.inner, mu_out=fluid.outer, far=far, backend=fluid.solver
                )
            )
        else:
            op = fluid_operator(g.points, ctx.faces, g.normal, mu_in=fluid.inner, mu_out=fluid.outer, measure=False)
            ctx.add_dense(op.dissipation)
            if far is not None:
                ctx.add_node_force(op.far_force(far).reshape(-1, 3))
        if fluid.has_body_force:
            ctx.add_node_force(body_force_nodes(g.points, ctx.faces, fluid.body_force))
