"""Physical terms of the force balance, one module each; importing registers them.

Each term says, in one class, what it adds to every formulation (:mod:`.base`); the
formulations' assemblies (:mod:`cortex_ti.physics.assembly`, :mod:`cortex_ti.physics.galerkin`,
:mod:`cortex_ti.physics.galerkin_p2`)
loop over the terms of the enabled effects. Importing the registry starts no Taichi.
"""

from ..model import Physics
from . import active, bending, constraints, fluids, implicit_tension, rigidity, viscous  # noqa: F401  (registration)
from .base import (
    TERMS,
    Constraint,
    Context,
    P1Context,
    P2Context,
    PaperContext,
    Term,
    effects_without_terms,
    register,
    terms_for,
)

__all__ = [
    "TERMS",
    "Constraint",
    "Context",
    "P1Context",
    "P2Context",
    "PaperContext",
    "Physics",
    "Term",
    "effects_without_terms",
    "register",
    "terms_for",
]
