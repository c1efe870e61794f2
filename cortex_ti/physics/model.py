"""The physics a scene switches on: the vocabulary of effects and the coefficients of one run.

:data:`EFFECTS` is the one list of effects a scene may name (the scene rules check against
it; every term of :mod:`cortex_ti.physics.terms` declares one of them). :class:`Physics` is
what the terms read: the effects switched on and the viscous coefficients. No Taichi here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["EFFECTS", "FAR_FIELDS", "FLUID_SOLVERS", "FLUID_AUTO_DENSE_MAX", "Fluid", "Physics", "resolve_fluid_solver"]

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
    "fluids": "a cytoplasm and a medium as Stokes fluids (fluid.inner, fluid.outer; fluid.body_force, "
    "fluid.far_field): their traction by a dense boundary-integral map; the medium fixes the rigid motions "
    "(formulation rayleigh_p1 only, docs/guide/fluids.md)",
}


#: The far-field flows of ``fluid.far_field`` (type -> the flow at infinity, centred on the origin).
FAR_FIELDS: dict[str, str] = {
    "none": "the medium at rest at infinity",
    "uniform": "u = U (fluid.far_field.velocity)",
    "shear": "simple shear u = G y e_x (fluid.far_field.rate G; vorticity -G e_z)",
    "extension": "uniaxial extension along z, u = E (-x / 2, -y / 2, z) (fluid.far_field.rate E)",
}

#: The solves of the effect ``fluids`` (``fluid.solver``; ``auto`` is resolved by the node count).
FLUID_SOLVERS: dict[str, str] = {
    "auto": "dense up to FLUID_AUTO_DENSE_MAX nodes, else direct",
    "dense": "the boundary-integral map as a dense matrix, K + D by a dense Cholesky (physics/fluids.py, "
    "solve/dense.py)",
    "direct": "matrix-free as fmm, the single layer's far field (nodes and triangle centroids as sources) summed pair "
    "by pair by a Taichi kernel (O(N^2) time, O(N) memory; no extra), a viscosity contrast's double layer too "
    "(physics/fluids_double.py)",
    "fmm": "matrix-free: fmm3dpy's Stokes FMM with sparse near corrections, a coupled GMRES preconditioned by the "
    "sparse cortex operator and the fluids' local part (physics/fluids_fast.py, solve/fluid_krylov.py; the extra "
    "fluids; equal viscosities)",
}

#: ``auto`` takes the dense solve up to this many nodes, ``direct`` above (docs/validation/fluids.md, "Cost
#: of a step": one solve at 642 nodes 0.23 CPU s direct against 1.6 dense, furrow_in_fluid's furrow radius
#: within 2.3e-6 of the dense path's there, its discretisation error 8.9e-4; the dense path stays the truth
#: at 162 nodes; fmm3dpy's FMM is slower than the direct sums up to 10242 nodes on this machine)
FLUID_AUTO_DENSE_MAX = 162


def resolve_fluid_solver(choice: str, nodes: int | None, mu_in: float, mu_out: float) -> str:
    """``fluid.solver`` as it runs: ``dense``, ``direct`` or ``fmm`` (``auto``: dense up to
    :data:`FLUID_AUTO_DENSE_MAX` nodes or with a mesh file of a size not known yet; else direct, with a
    viscosity contrast too: the double layer matrix-free, :mod:`cortex_ti.physics.fluids_double`).

    >>> resolve_fluid_solver("auto", 162, 1.0, 1.0), resolve_fluid_solver("auto", 642, 1.0, 1.0)
    ('dense', 'direct')
    """
    if choice != "auto":
        return choice
    if nodes is None or nodes <= FLUID_AUTO_DENSE_MAX:
        return "dense"
    return "direct"


@dataclass(frozen=True)
class Fluid:
    """The cytoplasm and the medium of the effect ``fluids`` (scene section ``fluid``): viscosities
    ``inner``, ``outer`` (eta_s / R0), the body force on the cytoplasm relative to the medium (force per
    volume, eta_s / (R0 t_a)) and the far-field flow (:data:`FAR_FIELDS`: ``far_field`` its type,
    ``velocity`` of ``uniform``, ``rate`` of ``shear`` and ``extension``)."""

    inner: float = 1.0
    outer: float = 1.0
    body_force: tuple[float, float, float] = (0.0, 0.0, 0.0)
    far_field: str = "none"
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rate: float = 0.0
    solver: str = "dense"  # dense | fmm (RunSettings resolves auto by the node count)

    def far_velocity(self, points: np.ndarray) -> np.ndarray | None:
        """The far-field flow at ``points`` (N, 3); None for a medium at rest at infinity.

        >>> Fluid(far_field="shear", rate=2.0).far_velocity(np.array([[0.0, 1.0, 0.0]])).tolist()
        [[2.0, 0.0, 0.0]]
        """
        x = np.asarray(points, float)
        if self.far_field == "uniform":
            return np.broadcast_to(np.asarray(self.velocity, float), x.shape).copy()
        if self.far_field == "shear":
            return np.stack([self.rate * x[:, 1], np.zeros(len(x)), np.zeros(len(x))], axis=1)
        if self.far_field == "extension":
            return self.rate * x * np.array([-0.5, -0.5, 1.0])
        return None

    @property
    def has_body_force(self) -> bool:
        return any(self.body_force)


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
    fluid: Fluid | None = None  # the fluids (effect ``fluids``); None without it

    @property
    def fluids(self) -> bool:
        """Whether the cortex lies between two Stokes fluids (they then fix the rigid motions)."""
        return "fluids" in self.effects

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
