"""Helfrich bending rigidity (the effect ``bending_rigidity``): formulation ``rayleigh_p2`` only in 3D.

The axisymmetric model carries it too (:mod:`cortex_ti.axisymmetric.rigidity`); the derivation of both
is ``docs/derivations/bending_rigidity.md``. On the curved cells of ``rayleigh_p2`` the force on the
nodes is minus the exact gradient of the discrete energy ``E_h = kappa/2 [H_h^T M H_h + 2 c0 b^T H_h +
c0^2 A]`` with the mixed curvature vector ``M H_h = -L X``
(:func:`cortex_ti.surface.curved_bending.bending_energy`), so with no activity the shape dynamics is a
gradient flow of ``E_h``: ``dE_h/dt = -(dissipation)`` at every solve (with nodes that move with the
material), up to the time scheme's error over a step. On the flat triangles of ``paper`` and
``rayleigh_p1`` no bending force has been measured to converge at every node
(``docs/validation/bending_rigidity.md``), so those methods are ``None``: the scene rules refuse the
effect there in one line naming ``rayleigh_p2``, and :func:`~.base.terms_for` would refuse it again
should a scene reach such an assembly another way.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .base import Context, P2Context, Term, register

#: the semi-implicit rigidity's factor: ``S = c kappa dt L D^-1 L`` (``D`` the diagonal of the mass
#: matrix) bounds the frozen-geometry Hessian ``kappa L M^-1 L`` from above for ``c >= 2.51`` (the
#: largest generalised eigenvalue of the pair on the 642-node icosphere's curved cells)
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
            s = (STABILISER * ctx.physics.kappa * ctx.implicit_dt) * (stiff @ sp.diags(1.0 / mass.diagonal()) @ stiff)
            m = len(surf.nodes)
            normal = sp.csr_matrix((surf.normal.ravel(), (np.repeat(np.arange(m), 3), np.arange(3 * m))), shape=(m, 3 * m))
            ctx.add_matrix((normal.T @ s @ normal).tocsr(), ctx.implicit_rate)
