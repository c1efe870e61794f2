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

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..surface.transport import DENSITY, PROPERTY
from .patterns import evaluate_active_stress

__all__ = ["FIELDS", "FieldSpec", "register_field", "scene_fields", "tension_of"]


@dataclass(frozen=True)
class FieldSpec:
    """One nodal field (module docstring). Every callable takes the run's
    :class:`~cortex_ti.scene.RunSettings`."""

    name: str
    kind: str  # DENSITY or PROPERTY
    present: Callable  # settings -> bool
    initial: Callable  # (settings, undeformed points) -> (N,)
    carried: Callable  # settings -> bool: transported relative to the mesh
    tension: Callable | None = None  # (values, settings) -> (N,) its part of the active tension
    diffusion: Callable = staticmethod(lambda settings: 0.0)  # settings -> D
    turnover: Callable = staticmethod(lambda settings: (0.0, 0.0))  # settings -> (k, c_target)
    variable: str | None = None  # the trajectory variable (None: the field's name)
    attrs: tuple = ()  # (key, value) pairs of the variable's attributes
    schema: dict | None = None  # its scene keys under fields.<name> (JSON-schema fragment)

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


register_field(
    FieldSpec(
        name="prescribed_tension",
        kind=PROPERTY,
        present=lambda s: s.has("active_stress"),
        initial=_prescribed_initial,
        carried=lambda s: s.tension_carried and s.mesh.motion != "lagrangian",
        tension=lambda values, s: values,
        variable="prescribed_tension",
        attrs=(
            ("units", "zeta_0"),
            (
                "long_name",
                "active tension of the scene's active_stress patterns, assigned on "
                "the initial mesh and glued to the nodes (tension_transport: nodes) or "
                "carried by the material (material)",
            ),
        ),
    )
)


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


# ---------------------------------------------------------------------------------------------
# myosin: a conserved density carried by the full velocity, diffusing and turning over, that
# makes the active tension (issue: a self-organising cortex; theory in analysis.myosin_stability)
# ---------------------------------------------------------------------------------------------

#: the tension laws of the myosin field: (c, c0, zeta0, gamma) -> zeta, each with zeta(c0) = zeta0
TENSION_LAWS = {
    "linear": lambda c, c0, zeta0, gamma: zeta0 * (1.0 - gamma + gamma * c / c0),
    "saturating": lambda c, c0, zeta0, gamma: 2.0 * zeta0 * c * c / (c0 * c0 + c * c),
}

_MYOSIN_SCHEMA = {
    "description": "A myosin (regulator) density c: conserved, carried by the cortex's full velocity (diluted by "
    "surface stretching), diffusing (diffusion), turning over toward c0 (turnover), making the active "
    "tension zeta(c) (tension), added to the prescribed patterns of active_stress.",
    "type": "object",
    "additionalProperties": False,
    "properties": {
        "c0": {
            "description": "Uniform reference density (the turnover's target; units of c).",
            "type": "number",
            "exclusiveMinimum": 0,
            "default": 1.0,
        },
        "diffusion": {
            "description": "Surface diffusion coefficient D (R0^2/t_a), implicit in the step.",
            "type": "number",
            "minimum": 0,
            "default": 0.0,
        },
        "turnover": {
            "description": "Turnover rate k (1/t_a): dc/dt = ... - k (c - c0), implicit in the step.",
            "type": "number",
            "minimum": 0,
            "default": 0.0,
        },
        "initial": {
            "description": "Patterns added to c0 on the initial (undeformed) mesh (the active_stress pattern types).",
            "type": "array",
            "items": {"$ref": "#/$defs/pattern"},
            "default": [],
        },
        "noise": {
            "description": "Seeded random perturbation added to the initial density: amplitude times a "
            "standard normal per node; symmetric: mirror-symmetric about the equator z = 0.",
            "type": "object",
            "additionalProperties": False,
            "properties": {
                "amplitude": {
                    "type": "number",
                    "minimum": 0,
                    "default": 0.0,
                    "description": "Standard deviation (units of c).",
                },
                "seed": {"type": "integer", "default": 1, "description": "Random seed."},
                "symmetric": {"type": "boolean", "default": False, "description": "Mirror-symmetric about z = 0."},
            },
            "default": {},
        },
        "tension": {
            "description": "The active tension of the density: law 'linear', zeta0 (1 - gamma + gamma "
            "c/c0), or 'saturating', 2 zeta0 c^2/(c0^2 + c^2); both give zeta0 at c = c0.",
            "type": "object",
            "additionalProperties": False,
            "properties": {
                "law": {"enum": list(TENSION_LAWS), "default": "linear", "description": "The tension law."},
                "zeta0": {
                    "type": "number",
                    "minimum": 0,
                    "default": 1.0,
                    "description": "Tension at c = c0 (units of zeta_0).",
                },
                "gamma": {
                    "type": "number",
                    "minimum": 0,
                    "maximum": 1,
                    "default": 1.0,
                    "description": "Linear law: the share of the tension that follows c "
                    "(at most 1, so zeta >= 0 for c >= 0).",
                },
            },
            "default": {},
        },
    },
}


def _myosin_initial(settings, points: np.ndarray) -> np.ndarray:
    f = settings.field("myosin")
    c = np.full(points.shape[0], float(f["c0"]))
    if f["initial"]:
        c = c + evaluate_active_stress(points, list(f["initial"]))
    noise = f["noise"]
    if noise["amplitude"] > 0:
        rng = np.random.default_rng(noise["seed"])
        if noise["symmetric"]:
            # the same value at a node and at its mirror image z -> -z (nearest node)
            from scipy.spatial import cKDTree

            mirror = cKDTree(points).query(points * np.array([1.0, 1.0, -1.0]))[1]
            raw = rng.standard_normal(points.shape[0])
            c = c + noise["amplitude"] * 0.5 * (raw + raw[mirror])
        else:
            c = c + noise["amplitude"] * rng.standard_normal(points.shape[0])
    return c


def _myosin_tension(values: np.ndarray, settings) -> np.ndarray:
    f = settings.field("myosin")
    t = f["tension"]
    return TENSION_LAWS[t["law"]](values, float(f["c0"]), float(t["zeta0"]), float(t["gamma"]))


register_field(
    FieldSpec(
        name="myosin",
        kind=DENSITY,
        present=lambda s: s.field("myosin") is not None,
        initial=_myosin_initial,
        carried=lambda s: s.mesh.motion != "lagrangian",
        tension=_myosin_tension,
        diffusion=lambda s: float(s.field("myosin")["diffusion"]),
        turnover=lambda s: (float(s.field("myosin")["turnover"]), float(s.field("myosin")["c0"])),
        attrs=(
            ("units", "c0 units (amount per R0^2)"),
            ("long_name", "myosin density: conserved, carried by the full velocity, diffusing, turning over"),
        ),
        schema=_MYOSIN_SCHEMA,
    )
)
