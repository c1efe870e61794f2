"""The same model restricted to axisymmetric shapes: an in-house truth for every axisymmetric scene.

A scene with ``model: axisymmetric`` is solved along its meridian: spectral collocation with
the pole regularity built into the bases (``spectral``), the force balance with the 3D code's
bending-viscosity normal force and the static flow on a sphere (``balance``), the shape
evolution by normal advection (``dynamics``: the node motion and its exact Jacobian; ``evolve``:
the driver, scipy's Radau; ``result``: the saved states and their diagnostics), and the
scene-facing run that writes a trajectory in the 3D layout (``run``). The equations are derived
in ``docs/derivations/axisymmetric.md``. Imports numpy/SciPy, and for ``run`` the scene, the pattern
evaluation, the diagnostics and the trajectory writer; never the 3D solver or Taichi.
"""

from .balance import StaticResult, static_flow
from .evolve import simulate
from .result import SimulationResult

__all__ = ["static_flow", "simulate", "StaticResult", "SimulationResult"]
