"""Helfrich bending rigidity (the effect ``bending_rigidity``): formulation ``rayleigh_p2`` only in 3D.

The axisymmetric model carries it too (:mod:`cortex_ti.axisymmetric.rigidity`); the derivation of both
is ``docs/derivations/bending_rigidity.md``. On the curved cells of ``rayleigh_p2`` the force on the
nodes is minus the exact gradient of the discrete energy ``E_h = kappa/2 [H_h^T M H_h + 2 c0 b^T H_h +
c0^2 A]`` with the mixed curvature vector ``M H_h = -L X``
(:func:`cortex_ti.surface.curved_bending.bending_energy`), so with no activity the shape dynamics is a
gradient flow of ``E_h``: ``dE_h/dt = -(dissipation)`` at every solve (with nodes that move with the
material and ``numerics.pressure_weights: exact``), up to the time scheme's error over a step.

**Semi-implicit.** The force is evaluated on the shape at the start of the step, and its stiffest
mode relaxes at a rate growing like ``kappa / h^4``. When the step is semi-implicit (``implicit_dt >
0``: ``time.implicit_tension``, on with ``bdf2``) the term adds the dissipation ``gamma/2 (v_n -
r_n)^T S (v_n - r_n)``, ``S = c kappa L D^-1 L`` on the nodes' normal speeds (``L`` the cells'
Laplace-Beltrami matrix, ``D`` the diagonal of their mass matrix, ``c`` = :data:`STABILISER`), centred
on the nodes' last rate ``r`` when the scheme gives one: the linearisation of the force about the
step's start with an approximate Jacobian about as large as the frozen-geometry Hessian ``kappa L
M^-1 L`` (at least 0.98 of it), as the semi-implicit tension does for the tension's curvature
(``docs/derivations/bending_rigidity.md``, Sec. 8). Centred on ``r`` its cost is ``O(h^3)`` per step
and the error control sees it.

On the flat triangles of ``paper`` and ``rayleigh_p1`` no bending force has been measured to converge
at every node (``docs/validation/bending_rigidity.md``), so those methods are ``None``: the scene rules
refuse the effect there in one line naming ``rayleigh_p2``, and :func:`~.base.terms_for` would refuse
it again should a scene reach such an assembly another way.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .base import Context, P2Context, Term, register

#: ``c`` of the semi-implicit rigidity ``S = c kappa L D^-1 L``: the largest generalised eigenvalue of
#: ``(L M^-1 L, L D^-1 L)`` on the icospheres' curved cells is 2.46, 2.51, 2.54 at 162, 642, 2562 nodes,
#: so ``S`` is at least 0.98 of the frozen-geometry Hessian, twice what the linearly implicit Euler step's
#: stability needs (``S >= A/2``; docs/derivations/bending_rigidity.md, Sec. 8)
STABILISER = 2.5


@register
class BendingRigidity(Term):
    effect = "bending_rigidity"
    name = "bending rigidity"
    paper = None
    rayleigh_p1 = None

    def applies(self, ctx: Context) -> bool:
        return ctx.physics.kappa > 0

    def rayleigh_p2(self, ctx: P2Context) -> None:
        from ...surface.curved_bending import bending_energy, cell_matrices

        surf = ctx.surface
        e = bending_energy(surf.nodes, surf.cells, ctx.physics.kappa, ctx.physics.c0)
        ctx.add_node_force(-e.gradient)
        if ctx.implicit_dt > 0.0:
            mass, stiff = cell_matrices(surf.nodes, surf.cells)
            s = stiff @ sp.diags(1.0 / mass.diagonal()) @ stiff
            m = surf.n_nodes
            # v (3M, node-major) -> the normal speeds n_i . v_i (M)
            vn = sp.csr_matrix((surf.normal.ravel(), (np.repeat(np.arange(m), 3), np.arange(3 * m))), shape=(m, 3 * m))
            scale = STABILISER * ctx.physics.kappa * ctx.implicit_dt
            ctx.add_matrix((scale * (vn.T @ s @ vn)).tocsr(), ctx.implicit_rate)
