"""Helfrich bending rigidity (the effect ``bending_rigidity``): in no 3D formulation yet.

The axisymmetric model carries it (:mod:`cortex_ti.axisymmetric.rigidity`, derivation
``docs/derivations/bending_rigidity.md``). On the 3D formulations no bending force has been measured
to converge at every node (``docs/validation/bending_rigidity.md``), so every method is ``None``: the
scene rules refuse the effect with ``model: 3d`` in one line, and :func:`~.base.terms_for` would
refuse it again should a scene reach a 3D assembly another way.
"""

from __future__ import annotations

from .base import Context, Term, register


@register
class BendingRigidity(Term):
    effect = "bending_rigidity"
    name = "bending rigidity"
    paper = None
    rayleigh_p1 = None
    rayleigh_p2 = None

    def applies(self, ctx: Context) -> bool:
        return False
