"""One scene, from its settings to a trajectory file.

Owns the set-up of a run from its :class:`~cortex_ti.scene.RunSettings` (initial mesh, initial
shape, active tension: ``setup``), :class:`~cortex_ti.simulation.core.Simulation`, the velocity
solve on any shape of the scene's mesh (geometry -> assembly -> constrained solve: ``core``),
and the static and dynamic runs that write and flush trajectories (``run``: the hooks of the
integration loop that write the file), resume them (``resume``) and report how they ended and
what they cost (``report``). Imports every layer below it (scene, surface, physics, solve, dynamics,
analysis, io); ``setup`` needs no Taichi, so ``cortex-ti check`` does not start it
(``tests/repository/test_layers.py``).

``Simulation`` is ``core.Simulation``, loaded on first use: importing this package (which
importing ``setup`` does) must not load the Taichi kernels of ``core``, about 1 s that every
``cortex-ti check`` would pay. Type checkers and editors see the plain import below.
"""

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .core import Simulation

__all__ = ["Simulation"]


def __getattr__(name):
    if name == "Simulation":
        from .core import Simulation

        return Simulation
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
