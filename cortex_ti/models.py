"""The models that run a scene (registry :data:`MODELS`, the scene key ``model``).

A model is a way to solve the same scene: ``3d``, the triangulated cortex
(:class:`cortex_ti.simulation.core.Simulation`), and ``axisymmetric``, the spectral meridian solver
(:class:`cortex_ti.axisymmetric.run.AxisymmetricRun`). Each entry builds the scene's runner, an
object with ``run(output, resume=False, progress=True, force=False) -> Path`` (what is at ``output``
treated by :func:`cortex_ti.io.claim.check_output`), ``summary()`` and ``settings``;
the command line and :func:`cortex_ti.run` ask this registry, never an ``if`` on the model's name.
Runners are imported when built, so naming a model starts nothing (no Taichi for ``axisymmetric``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

__all__ = ["MODELS", "Model", "register_model", "make_runner"]


@dataclass(frozen=True)
class Model:
    """One model: its name, what it is, and ``build(scene, arch, threads) -> runner``."""

    name: str
    description: str
    build: Callable


#: name -> :class:`Model`
MODELS: dict[str, Model] = {}


def register_model(name: str, description: str):
    """Decorator adding a runner factory ``(scene, arch, threads) -> runner`` to :data:`MODELS`."""

    def deco(func):
        MODELS[name] = Model(name, description, func)
        return func

    return deco


@register_model("3d", "the triangulated cortex of the paper (Taichi kernels and a sparse solve)")
def _three_d(scene, arch=None, threads=None):
    from . import runtime
    from .simulation.core import Simulation

    runtime.init(arch, threads)
    return Simulation(scene)


@register_model("axisymmetric", "the same model on surfaces of revolution, spectral along the meridian")
def _axisymmetric(scene, arch=None, threads=None):
    import logging

    import numpy as np

    from .axisymmetric.run import AxisymmetricRun
    from .dynamics.guard import extensile_tension

    run = AxisymmetricRun(scene)
    if run.settings.dynamic:  # the counterpart of the 3D run's warning on an extensile tension
        physical = extensile_tension(run.zeta(np.linspace(0.0, np.pi, 181)))
        if physical is not None:
            logging.getLogger("cortex_ti").warning("scene '%s': %s", run.settings.name, physical)
    return run


def make_runner(scene, arch: str | None = None, threads: int | None = None):
    """The runner of ``scene``'s model (:data:`MODELS`)."""
    return MODELS[scene.settings.model].build(scene, arch, threads)
