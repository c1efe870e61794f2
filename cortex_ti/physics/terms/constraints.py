r"""Pressure and the constraints of paper Sec. 3.2, each with a Lagrange multiplier.

* Rigid-body gauge (on unless the effect ``fluids`` is, whose medium fixes the rigid motions; the
  cortex's force balance contains only derivatives of the velocity, so a rigid motion can be added
  to any solution): zero total velocity
  ``sum_i A_i v_i = 0`` (Eq. 36; or, with the scene's ``translation: centroid``, the enclosed
  volume's centroid held, ``sum_i A_i (x_i - x_c) v_n,i = 0``) and zero angular momentum
  ``sum_i A_i (x_i - x_c) x v_i = 0`` (Eq. 37), ``A_i`` the Meyer mixed area, ``x_c``
  the area-weighted centroid (with zero total velocity the reference point drops out).
  In formulation ``rayleigh_p1`` the six multipliers push along the rows of zero total velocity
  and angular momentum in both gauges, ``A_i (lambda_t + lambda_r x (x_i - x_c))`` (the centroid
  gauge is Petrov-Galerkin: its rows fix the translation, the multipliers' force is the other
  gauge's). The multipliers take up the net force and torque of the forces, which vanish in the
  continuum but are O(h^2) on the mesh where a force is consistent without being an exact
  gradient (the pressure on the Meyer areas below, the ``balanced`` active force); with
  the same force density in both gauges, and a dissipation whose kernel holds the rigid motions,
  the two gauges' flows differ by a rigid motion exactly, so with lagrangian nodes their shapes
  differ by a rigid motion over a whole run. With the centroid's own rows as the force, the
  gauges took up that net force as different force densities, and the shapes of a run drifted
  apart as t^2 (docs/validation/formulations.md, "The two gauges over a run").
* Incompressibility (effect ``incompressibility``): the pressure difference ``P``
  becomes an unknown of the normal balance and the enclosed volume is kept,
  ``sum_i v_n,i W_i = 0`` (Eq. 35). We take ``W_i = n_i . dV/dx_i``, the derivative
  of the *triangulated* volume along the direction the node is advected in
  (Eq. 60), rather than the mixed area ``A_i``: both converge to the same
  ``integral of v_n dS = 0``, but with this choice the discrete volume is exactly
  stationary under normal advection, so it is conserved to O(dt^2) per step.

In formulation ``rayleigh_p1`` the constraints are the same rows; the pressure is the volume
row's multiplier. The triangulated volume's exact gradient ``dV/dx_k`` weighs node k with its
barycentric area, the tension's force (the cotangent formula) with its Voronoi area; they differ
by up to 13 % on an icosphere, so a uniform tension would drive an O(h) flow at t = 0 if the
pressure pushed along ``dV/dx_k``. Hence the choices of ``numerics.pressure_weights``
(:data:`PRESSURE_WEIGHTS`): by default (``petrov``) the pressure pushes on the Meyer areas,
``P A_k n_k`` (the paper's Eq. 35, consistent with the tension's force to O(h^2)), while the
constraint it enforces is the exact one, ``sum_k W_k v_n,k = 0``, so the triangulated volume is
stationary under the normal advection of the nodes; ``area``: both on the Meyer areas;
``exact``: both on ``W`` (then the force is exactly minus the gradient of ``E - P V``, at the
price of that O(h) error).

In formulation ``rayleigh_p2`` the rows are integrated exactly on the curved cells
(:meth:`cortex_ti.surface.curved.CurvedSurface.rigid_motion_rows`, ``volume_rows``): the
volume row is the exact rate of the volume the cells enclose under the nodes' motion (along their
normals by ``v_n``, or with ``v`` itself under ``mesh.motion: lagrangian``), and the pressure pushes along the
smooth normal speed's rows ``(int N_i dA) n_i`` (a Petrov-Galerkin constraint as ``petrov`` above:
along the cells' own normal, which is only second-order accurate and kinks between cells, a
uniform pressure would not balance a uniform tension, an error of 7e-2 at 642 nodes). With
``numerics.pressure_weights: exact`` it pushes along the volume rows themselves: the force is then
minus the exact gradient of ``E_h - P V_h``, and with the exact-gradient forces (``active_force:
gradient``, the bending rigidity) the power of every force is the rate of one discrete energy, so
``dE_h/dt = -(dissipation)`` at every solve (docs/derivations/bending_rigidity.md, Sec. 7).
"""

from __future__ import annotations

import numpy as np

from ...solve.system import rigid_motion_rows
from .base import Constraint, Context, P1Context, P2Context, PaperContext, Term, register

#: How the pressure enters formulation ``rayleigh_p1`` (``numerics.pressure_weights``, module docstring).
PRESSURE_WEIGHTS = {
    "petrov": "force on the Meyer areas, constraint on the exact rate of the triangulated volume",
    "area": "force and constraint on the Meyer areas (the paper's Eq. 35)",
    "exact": "force and constraint on the exact gradient of the triangulated volume",
}


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

    def applies(self, ctx: Context) -> bool:
        return not ctx.physics.fluids  # the medium fixes the rigid motions (physics/terms/fluids.py)

    def paper(self, ctx: Context) -> None:
        ctx.constraints.append(Constraint("momentum", gauge_rows(ctx.geometry, ctx.physics)))

    def rayleigh_p1(self, ctx: P1Context) -> None:
        g = ctx.geometry
        rows = gauge_rows(g, ctx.physics)
        # the multipliers push along the mean-velocity gauge's rows in either gauge (module docstring):
        # a gauge then only chooses the rigid motion, and the flows of the two differ by one exactly
        force = rigid_motion_rows(g.points, g.area) if ctx.physics.centroid_gauge else None
        ctx.constraints.append(Constraint("momentum", rows, force_rows=force))

    def rayleigh_p2(self, ctx: P2Context) -> None:
        surf = ctx.surface
        rows = surf.rigid_motion_rows(ctx.physics.centroid_gauge)
        # as in rayleigh_p1: the multipliers push along the mean-velocity rows in either gauge
        force = surf.rigid_motion_rows(False) if ctx.physics.centroid_gauge else None
        ctx.constraints.append(Constraint("momentum", rows, force_rows=force))


@register
class Incompressibility(Term):
    effect = "incompressibility"
    name = "pressure and volume conservation"

    def applies(self, ctx: Context) -> bool:
        return ctx.physics.normal_balance  # the scene refuses the effect without it

    def paper(self, ctx: PaperContext) -> None:
        g = ctx.geometry
        weight = np.einsum("nc,nc->n", g.normal, g.volume_gradient)
        ctx.pressure = True
        if ctx.physics.material_nodes:
            # the nodes move with v itself: keep the triangulated volume under that motion
            ctx.constraints.append(Constraint("volume", g.volume_gradient[None], pressure=True))
            return
        ctx.constraints.append(Constraint("volume", (weight[:, None] * g.normal)[None], pressure=True))

    def rayleigh_p1(self, ctx: P1Context) -> None:
        g, how = ctx.geometry, ctx.pressure_weights
        nrm = g.normal
        exact = np.einsum("nc,nc->n", nrm, g.volume_gradient)
        force_on = exact if how == "exact" else g.area
        enforce = g.area if how == "area" else exact
        force = (force_on[:, None] * nrm)[None] if how == "petrov" else None
        rows = (enforce[:, None] * nrm)[None]
        if ctx.physics.material_nodes and how != "area":
            # the nodes move with v itself (mesh.motion: lagrangian): the rate of the triangulated
            # volume is sum_k dV/dx_k . v_k, tangential parts included; holding it at zero keeps the
            # volume and makes a rigid translation satisfy the constraint exactly
            rows = g.volume_gradient[None]
        ctx.constraints.append(Constraint("volume", rows, force_rows=force, pressure=True))

    def rayleigh_p2(self, ctx: P2Context) -> None:
        # the pressure pushes along the smooth normal speed's rows (consistent with the tension's
        # normal force); the constraint is the exact rate of the curved cells' volume
        surf = ctx.surface
        rows = surf.volume_rows()
        if not ctx.physics.material_nodes:
            # the nodes move along their normals by v_n only: the volume's rate under that motion
            rows = np.einsum("nc,nc->n", rows, surf.normal)[:, None] * surf.normal
        force = None if ctx.pressure_weights == "exact" else surf.normal_rows()[None]
        ctx.constraints.append(Constraint("volume", rows[None], force_rows=force, pressure=True))
