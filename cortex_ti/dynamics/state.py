r"""The state the time schemes advance: the shape (node positions) and the nodal fields it carries.

A :class:`State` is immutable: ``points`` (N, 3) and ``fields``, a mapping of field name to its
nodal values (N,) (:data:`cortex_ti.physics.fields.FIELDS`). An evaluation of the dynamics on a
state gives its :class:`Rates`: the nodes' velocity (the mesh velocity ``w``,
:mod:`cortex_ti.dynamics.motion`) and, for each transported field, the rate of its stored
quantity (a density's content ``c A``, a property's value: :mod:`cortex_ti.surface.transport`).
Rates add and scale like vectors, so a scheme writes its update once for the whole state::

    new = ev.state.advanced(dt, 0.5 * (ev.rates + ev2.rates), implicit)   # Heun

:meth:`State.advanced` takes the explicit update and then the implicit part of the step
(diffusion and turnover, on the new shape), and turns stored quantities back into values on the
new shape. A field without a rate (``None``: glued to the nodes) keeps its values exactly.

A density's content is measured on the cells of the formulation (``FieldTransport.cells``): the flat
dual cells' ``c A`` (:mod:`cortex_ti.surface.transport`), or on the curved six-node cells of
``rayleigh_p2`` the consistent mass's ``M c`` (:mod:`cortex_ti.surface.curved_transport`), whose
implicit step then solves with the curved mass and stiffness.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ..surface.curved_transport import CURVED, FLAT, curved_content, curved_implicit_diffusion_reaction
from ..surface.transport import DENSITY, dual_areas, implicit_diffusion_reaction

__all__ = ["State", "Rates", "FieldTransport"]


@dataclass(frozen=True)
class FieldTransport:
    """How one field of a state moves in a step: its kind, its implicit diffusion and turnover, and
    the cells a density's content is measured on (``flat`` dual cells or the ``curved`` cells)."""

    kind: str
    diffusion: float = 0.0
    turnover: float = 0.0
    target: float = 0.0
    cells: str = FLAT

    @property
    def curved_density(self) -> bool:
        """A density on the curved cells: content ``M c``, Galerkin transport (module docstring)."""
        return self.cells == CURVED and self.kind == DENSITY


@dataclass(frozen=True)
class Rates:
    """d/dt of a state: ``points`` (N, 3), and per transported field the rate of its stored
    quantity (fields absent or None do not change)."""

    points: np.ndarray
    fields: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __add__(self, other: Rates) -> Rates:
        keys = set(self.fields) | set(other.fields)
        return Rates(self.points + other.points, {k: _add(self.fields.get(k), other.fields.get(k)) for k in keys})

    def __mul__(self, factor: float) -> Rates:
        return Rates(factor * self.points, {k: None if v is None else factor * v for k, v in self.fields.items()})

    __rmul__ = __mul__


def _add(a, b):
    if a is None:
        return b
    return a if b is None else a + b


@dataclass(frozen=True)
class State:
    """Node positions and the nodal fields (name -> (N,) values) of one instant."""

    points: np.ndarray
    fields: Mapping[str, np.ndarray] = field(default_factory=dict)
    faces: np.ndarray | None = None

    def __post_init__(self):
        object.__setattr__(self, "fields", MappingProxyType(dict(self.fields)))

    @property
    def n_nodes(self) -> int:
        return self.points.shape[0]

    def with_points(self, points: np.ndarray) -> State:
        """The same fields on other node positions."""
        return State(points, self.fields, self.faces)

    def stored(self, name: str, kind: str, cells: str = FLAT) -> np.ndarray:
        """The quantity a scheme advances for field ``name``: ``c A`` (dual areas of this shape) for
        a density, ``M c`` on the ``curved`` cells, the value for a property."""
        values = self.fields[name]
        if kind == DENSITY and cells == CURVED:
            return curved_content(values, self.points, self.faces)
        return values * dual_areas(self.points, self.faces) if kind == DENSITY else values

    def advanced(self, dt: float, rates: Rates, transport: Mapping[str, FieldTransport]) -> State:
        """The state after a step ``dt`` with the (combined) ``rates``: explicit update of the
        positions and of the stored quantities, then each field's implicit diffusion and turnover on
        the new shape."""
        return State.combined([(1.0, self)], dt, rates, transport)

    @staticmethod
    def combined(parts, dt: float, rates: Rates, transport: Mapping[str, FieldTransport]) -> State:
        """``sum_k a_k S_k + dt rates`` for ``parts = [(a_k, S_k), ...]`` (the ``a_k`` summing to 1,
        the last state the newest), then each field's implicit diffusion and turnover of a step
        ``dt`` on the new shape: the update of a multistep scheme (``bdf2``: the states ``n`` and
        ``n - 1`` and ``dt`` its ``gamma``); :meth:`advanced` is the one-step case. The stored
        quantities are combined (a density's content ``c A`` on each state's own shape), a field glued
        to the nodes keeps the newest state's values."""
        newest = parts[-1][1]
        points = sum(a * st.points for a, st in parts) + dt * rates.points
        fields = {}
        for name, values in newest.fields.items():
            rate = rates.fields.get(name)
            tr = transport.get(name)
            if tr is None or (rate is None and tr.kind != DENSITY and tr.diffusion == 0.0 and tr.turnover == 0.0):
                fields[name] = values  # glued to the nodes: unchanged
                continue
            stored = sum(a * st.stored(name, tr.kind, tr.cells) for a, st in parts)
            if rate is not None:
                stored = stored + dt * rate
            implicit = curved_implicit_diffusion_reaction if tr.curved_density else implicit_diffusion_reaction
            args = () if tr.curved_density else (tr.kind,)
            fields[name] = implicit(stored, *args, points, newest.faces, dt, tr.diffusion, tr.turnover, tr.target)
        return State(points, fields, newest.faces)

    def extrapolated(self, older: State, factor: float) -> State:
        """``self + factor (self - older)``, positions and field values: the linear extrapolation a
        multistep scheme evaluates its explicit part at (``factor`` = the step ratio)."""
        points = (1.0 + factor) * self.points - factor * older.points
        fields = {
            k: v if older.fields.get(k) is v else (1.0 + factor) * v - factor * older.fields[k]
            for k, v in self.fields.items()
        }
        return State(points, fields, self.faces)

    def total(self, name: str, cells: str = FLAT) -> float:
        """The amount of a density on this shape: ``sum_i c_i A_i``, or ``int c_h dA`` on the
        ``curved`` cells."""
        return float(np.sum(self.stored(name, DENSITY, cells)))

    @staticmethod
    def empty_transport() -> Mapping[str, FieldTransport]:
        return MappingProxyType({})
