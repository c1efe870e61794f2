"""Physical terms of the force balance, one module each; importing registers them."""

from ..model import Physics
from . import active, bending, constraints, implicit_tension, viscous  # noqa: F401  (registration)
from .base import TERMS, AssemblyContext, Constraint, Term, active_terms, register

__all__ = ["TERMS", "AssemblyContext", "Constraint", "Physics", "Term", "active_terms", "register"]
