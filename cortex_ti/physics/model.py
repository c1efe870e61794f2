"""The physics a scene switches on: the vocabulary of effects and the coefficients of one run.

:data:`EFFECTS` is the one list of effects a scene may name (the scene rules check against
it; every term of :mod:`cortex_ti.physics.terms` declares one of them). :class:`Physics` is
what the terms read: the effects switched on and the viscous coefficients. No Taichi here.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["EFFECTS", "Physics"]

#: The vocabulary of physical effects a scene can switch on (name -> description).
EFFECTS: dict[str, str] = {
    "active_stress": "isotropic active tension zeta from the active_stress patterns",
    "shear_viscosity": "in-plane shear viscous stress, coefficient viscosity.shear (eta_s)",
    "bulk_viscosity": "in-plane bulk (area-change) viscous stress, coefficient viscosity.bulk (eta_b)",
    "bending_viscosity": "viscous bending moments, coefficients viscosity.bending and "
    "viscosity.bending_bulk (paper Eq. 45)",
    "bending_rigidity": "Helfrich bending rigidity: the normal force of kappa/2 oint (C - c0)^2 dA, coefficients "
    "rigidity.bending and rigidity.spontaneous_curvature (model: axisymmetric, or 3D with formulation rayleigh_p2)",
    "normal_balance": "solve the normal force balance for the normal velocity",
    "fixed_normal_velocity": "impose zero normal velocity: tangential flow only, the shape stays fixed",
    "incompressibility": "conserve the enclosed volume with a pressure P = p_inside - p_outside",
    "shape_evolution": "move the nodes with the computed velocity and step in time (uses the time section)",
}


@dataclass(frozen=True)
class Physics:
    """The physical parameters and the effects switched on (one scene, one shape)."""

    effects: frozenset
    eta_s: float = 1.0
    eta_b: float = 1.0
    eta_bar: float = 0.0
    eta_bar_b: float = 0.0
    translation: str = "mean_velocity"  # how the free rigid translation is fixed (scene key ``translation``)
    material_nodes: bool = False  # the nodes move with the full velocity (mesh.motion: lagrangian)
    kappa: float = 0.0  # Helfrich bending rigidity (rigidity.bending; 0 without the effect bending_rigidity)
    c0: float = 0.0  # spontaneous curvature (rigidity.spontaneous_curvature, C = 2/R on a sphere)

    @property
    def centroid_gauge(self) -> bool:
        """The translation fixed by holding the enclosed volume's centroid, not by zero mean velocity."""
        return self.translation == "centroid"

    @property
    def normal_balance(self) -> bool:
        return "normal_balance" in self.effects

    @property
    def rows_per_node(self) -> int:
        return 3 if self.normal_balance else 2
