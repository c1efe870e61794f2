"""The discretisations of the force balance a scene can choose (``numerics.formulation``).

:data:`FORMULATIONS` is the one registry: the scene schema takes its names from it, the scene
rules refuse a key that belongs to another formulation than the one chosen, and the simulation
asks it for the system of a shape. Each entry says which ``numerics`` keys it reads and whether
its geometry needs the fit residuals.

* ``paper``: the paper's strong form (Sec. 3), the force balance at each node from the fitted
  second derivatives, solved by constrained least squares (:mod:`cortex_ti.physics.assembly`).
  Kept for reproduction: fourth order with the quartic fit on smooth shapes, but it has
  grid-scale normal modes that grow unless a bending viscosity of about the mesh size squared
  holds them down (``benchmarks/spectrum.py``).
* ``rayleigh_p1``: the stationary point of the discrete Rayleighian with piecewise-linear
  velocities integrated exactly over the flat triangles (:mod:`cortex_ti.physics.galerkin`):
  symmetric positive semidefinite, the active force the exact gradient of the discrete energy,
  so no spurious mode can grow; second order.
* ``rayleigh_p2``: the same Rayleighian on curved six-node cells with quadratic velocities whose
  normal part goes along the fitted surface's normal (:mod:`cortex_ti.physics.galerkin_p2`):
  symmetric positive semidefinite as well; third order at t = 0 with its default active force
  (``balanced``), whose dynamics is not a gradient flow; ``gradient`` makes it one.

Every term of :mod:`cortex_ti.physics.terms` says what it adds to each formulation in a method
named after it (``paper``, ``rayleigh_p1``); a new formulation names its method there.
Importing this registry starts no Taichi: the builders import their assembly when a system is
first built (the scene layer reads the registry).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SolverError
from .model import Physics
from .terms.active import ACTIVE_FORCES
from .terms.constraints import PRESSURE_WEIGHTS

if TYPE_CHECKING:  # the geometry module starts Taichi; only its type is needed here
    from ..surface.geometry import Geometry

__all__ = ["ACTIVE_FORCES", "FORMULATIONS", "PRESSURE_WEIGHTS", "Formulation"]


@dataclass(frozen=True)
class Formulation:
    """One discretisation: how it builds the system of a shape from the scene's ``numerics``."""

    name: str
    description: str
    build: Callable  # (geometry, physics, zeta, faces, numerics, dt, implicit_rate) -> system
    keys: tuple[str, ...]  # the numerics keys only this formulation reads
    uses_fit_residual: Callable = staticmethod(lambda numerics: False)
    #: it has the semi-implicit tension centred on the last step's rate (what ``bdf2`` needs)
    centred_implicit: bool = False
    #: said once at the start of a run that evolves its shape (empty: nothing to say)
    dynamic_caveat: str = ""
    #: the ``numerics.active_force`` choices the caveat is about (empty: every one)
    caveat_forces: tuple = ()
    #: its surface is made of curved six-node cells (a mesh in the split layout of
    #: :mod:`cortex_ti.surface.curved`), on which the run's shape measures are taken
    curved: bool = False
    #: the bending viscosity's normal force it discretises, by the axisymmetric model's name
    #: (``simulate(bending_form=...)``): ``"paper"``, paper Eq. 45 as written, or ``"dissipation"``,
    #: the derivative of the dissipation ``1/2 int B^cd d_c v_n d_d v_n dA`` (Eq. 45 plus
    #: ``(nabla_c B^cd) d_d v_n``, zero on a sphere); a run's axisymmetric twin solves the same
    #: (docs/validation/curved.md, "The furrow's dynamics")
    bending_form: str = "dissipation"
    #: with ``bdf2`` / ``bdf3`` and ``solver.rtol`` unset, its GMRES tolerance follows the step's:
    #: ``time.tol / 100``, never tighter than 1e-10 (:func:`cortex_ti.scene.rules.solver_rtol`)
    rtol_from_step: bool = False

    def caveat(self, active_force: str) -> str:
        """What a run that evolves its shape with ``active_force`` is told at its start ("" for nothing)."""
        return self.dynamic_caveat if not self.caveat_forces or active_force in self.caveat_forces else ""

    def system(
        self,
        geometry: Geometry,
        physics: Physics,
        zeta: np.ndarray,
        faces: np.ndarray,
        numerics,
        dt: float = 0.0,
        implicit_rate: np.ndarray | None = None,
    ):
        """The linear system on one shape (``dt > 0``: the semi-implicit step of that length, centred
        on the nodes' rate ``implicit_rate`` when given)."""
        return self.build(geometry, physics, zeta, faces, numerics, dt, implicit_rate)


def _paper(geometry, physics, zeta, faces, numerics, dt, implicit_rate=None):
    # Taichi kernels: loaded with the first system, not with the registry
    from .assembly import assemble

    if implicit_rate is not None:
        raise SolverError("formulation 'paper' has no semi-implicit tension centred on a rate (time.scheme = bdf2)")
    return assemble(geometry, physics, zeta, numerics.fit_residual_weight, implicit_dt=dt)


def _rayleigh_p1(geometry, physics, zeta, faces, numerics, dt, implicit_rate=None):
    from .galerkin import assemble_p1

    return assemble_p1(
        geometry,
        physics,
        zeta,
        faces,
        implicit_dt=dt,
        pressure_weights=numerics.pressure_weights,
        active_force=numerics.active_force,
        implicit_rate=implicit_rate,
        implicit_weight=numerics.implicit_tension_weight,
    )


def _rayleigh_p2(geometry, physics, zeta, faces, numerics, dt, implicit_rate=None):
    from .galerkin_p2 import assemble_p2

    return assemble_p2(
        geometry,
        physics,
        zeta,
        faces,
        implicit_dt=dt,
        implicit_rate=implicit_rate,
        active_force=numerics.active_force,
        pressure_weights=numerics.pressure_weights,
        implicit_weight=numerics.implicit_tension_weight,
    )


#: name -> :class:`Formulation`
FORMULATIONS: dict[str, Formulation] = {
    "paper": Formulation(
        "paper",
        "the paper's strong-form least squares with fitted second derivatives (Sec. 3), kept for "
        "reproduction; fourth order with the quartic fit, but grid-scale normal modes grow without a mesh-sized "
        "bending viscosity",
        _paper,
        keys=("fit_residual_weight",),
        uses_fit_residual=lambda numerics: numerics.fit_residual_weight > 0,
        bending_form="paper",
    ),
    "rayleigh_p1": Formulation(
        "rayleigh_p1",
        "stationary point of the discrete Rayleighian, piecewise-linear velocities integrated "
        "exactly on the flat triangles: symmetric positive semidefinite, no growing spurious modes; second order",
        _rayleigh_p1,
        keys=("pressure_weights", "active_force", "implicit_tension_weight"),
        centred_implicit=True,
    ),
    "rayleigh_p2": Formulation(
        "rayleigh_p2",
        "the same Rayleighian on curved six-node cells (midpoints on the fitted surface) with quadratic "
        "velocities, the normal speed along the smooth normal: symmetric positive semidefinite; third order",
        _rayleigh_p2,
        keys=("pressure_weights", "active_force", "implicit_tension_weight"),
        centred_implicit=True,
        curved=True,
        rtol_from_step=True,
        dynamic_caveat="with numerics.active_force balanced (the default) its shape dynamics is not stable by "
        "construction: on shear_075's sheared start the spectrum tool finds 238 normal modes growing faster than "
        "1/t_a at 642 nodes (rayleigh_p1: 33) and the mesh collapses by t = 0.2-0.3; 'gradient' (a gradient flow) "
        "runs it, but its t = 0 flows are less accurate than rayleigh_p1's; on furrow_p4_a1 its radii are 1.8-2.8x "
        "closer to the axisymmetric twin's than rayleigh_p1's at 642-10242 nodes (docs/validation/curved_cost.md)",
        caveat_forces=("balanced",),
    ),
}

#: the choices of ``numerics.pressure_weights`` (rayleigh_p1; petrov and exact in rayleigh_p2), for the schema
PRESSURE_WEIGHT_CHOICES = tuple(PRESSURE_WEIGHTS)
