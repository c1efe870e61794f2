r"""Nodal fields the cortex carries (registry :data:`FIELDS`): what a state holds beside its shape.

A field is one registry entry (:class:`FieldSpec`) that says

* its ``kind``: a conserved ``density`` that surface stretching dilutes, or a ``property`` carried
  by the material (:mod:`cortex_ti.surface.transport`);
* whether the scene has it (``present``), its values on the initial mesh (``initial``), whether it
  moves with the material (``carried``: transported by the velocity relative to the mesh) or stays
  on the nodes, its surface diffusion and linear turnover (implicit in the step);
* what it adds to the active tension (``tension``): the tension is a function of the state,
  recomputed at every evaluation;
* how a trajectory stores it (``variable``, ``attrs``: units and definition).

The one field today is the tension of the scene's ``active_stress`` patterns,
``prescribed_tension``: assigned on the initial (undeformed) mesh, glued to the nodes
(``tension_transport: nodes``, the paper's) or carried by the material (``material``). A new
field (a myosin density, say) is one more :func:`register_field` call; the state, the time
schemes, the trajectory and ``--resume`` take it from here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..surface.transport import DENSITY, PROPERTY
from .patterns import evaluate_active_stress

__all__ = ["FIELDS", "FieldSpec", "register_field", "scene_fields", "tension_of"]


@dataclass(frozen=True)
class FieldSpec:
    """One nodal field (module docstring). Every callable takes the run's
    :class:`~cortex_ti.scene.RunSettings`."""

    name: str
    kind: str                                   # DENSITY or PROPERTY
    present: Callable                           # settings -> bool
    initial: Callable                           # (settings, undeformed points) -> (N,)
    carried: Callable                           # settings -> bool: transported relative to the mesh
    tension: Callable | None = None             # (values, settings) -> (N,) its part of the active tension
    diffusion: Callable = staticmethod(lambda settings: 0.0)        # settings -> D
    turnover: Callable = staticmethod(lambda settings: (0.0, 0.0))  # settings -> (k, c_target)
    variable: str | None = None                 # the trajectory variable (None: the field's name)
    attrs: tuple = ()                           # (key, value) pairs of the variable's attributes

    @property
    def var(self) -> str:
        return self.variable or self.name


#: name -> :class:`FieldSpec`, in registration order
FIELDS: dict[str, FieldSpec] = {}


def register_field(spec: FieldSpec) -> FieldSpec:
    """Add a field to :data:`FIELDS`."""
    if spec.kind not in (DENSITY, PROPERTY):
        raise ValueError(f"field {spec.name!r}: kind must be {DENSITY!r} or {PROPERTY!r}, got {spec.kind!r}")
    FIELDS[spec.name] = spec
    return spec


def _prescribed_initial(settings, points: np.ndarray) -> np.ndarray:
    return evaluate_active_stress(points, list(settings.patterns))


register_field(FieldSpec(
    name="prescribed_tension", kind=PROPERTY,
    present=lambda s: s.has("active_stress"),
    initial=_prescribed_initial,
    carried=lambda s: s.tension_carried and s.mesh.motion != "lagrangian",
    tension=lambda values, s: values,
    variable="prescribed_tension",
    attrs=(("units", "zeta_0"), ("long_name", "active tension of the scene's active_stress patterns, assigned on "
                                             "the initial mesh and glued to the nodes (tension_transport: nodes) or "
                                             "carried by the material (material)")),
))


def scene_fields(settings) -> list[FieldSpec]:
    """The fields a scene's state holds, in registration order."""
    return [spec for spec in FIELDS.values() if spec.present(settings)]


def tension_of(fields, n_nodes: int, settings=None) -> np.ndarray:
    """The active tension ``(N,)`` of a state's fields (name -> values): the sum of every field's
    part (zeros without any)."""
    total = None
    for name, values in fields.items():
        spec = FIELDS.get(name)
        if spec is None or spec.tension is None:
            continue
        part = spec.tension(values, settings)
        total = part if total is None else total + part
    return np.zeros(n_nodes) if total is None else total
