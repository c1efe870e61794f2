r"""Time schemes of the shape evolution (registry :data:`SCHEMES`, the scene key ``time.scheme``).

A scheme advances a :class:`~cortex_ti.dynamics.state.State`: the node positions, which move with
the mesh velocity (``dx_i/dt = (v_i . n_i) n_i`` with the paper's normal motion, Eq. 60; see
:mod:`cortex_ti.dynamics.motion`), and the nodal fields the state carries (the active tension
glued to the nodes or carried by the material, :mod:`cortex_ti.physics.fields`). Each
right-hand-side evaluation recomputes the geometry, the fits, the constrained solve and the
fields' transport rates on the current state; a scheme combines the :class:`~cortex_ti.dynamics.state.Rates`
of its evaluations and :meth:`State.advanced <cortex_ti.dynamics.state.State.advanced>` applies
them (with each field's implicit diffusion and turnover). Schemes, all explicit in the shape:

``euler``           the paper's scheme, fixed step ``time.dt``, first order.
``heun``            explicit trapezoid (RK2), fixed step, second order, two solves per step.
``adaptive``        Heun with the embedded Euler estimate of the local error and a step-size
                    controller: the step grows while the estimated displacement error per step
                    stays below ``time.tol`` (in R0) and shrinks (the step is redone) when it
                    does not. ``time.dt`` is the first step, ``time.dt_max`` the largest.
``adaptive_euler``  Euler whose step follows the change of the rates; one solve per step.

What belongs to a scheme is a property of its class: whether it is ``adaptive`` (a resumed run
continues with the controller's step), ``first_order`` (the semi-implicit tension keeps its
order, :meth:`Scheme.implicit_tension` resolves ``time.implicit_tension: auto``).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, StabilityError
from .state import Rates, State

log = logging.getLogger(__name__)

__all__ = [
    "SCHEMES",
    "Scheme",
    "Evaluation",
    "StepResult",
    "register_scheme",
    "make_scheme",
    "advance",
    "RESOLUTION_HINT",
]

#: how to get out of a resolution problem
RESOLUTION_HINT = (
    "use more mesh nodes (e.g. mesh.nodes=2562); with numerics.formulation=paper, switch to "
    "numerics.formulation=rayleigh_p1 (the default), which has no growing spurious modes"
)


@dataclass
class Evaluation:
    """The dynamics on one state: the velocity, the normal, the nodes' velocity and the rates of the
    transported fields."""

    points: np.ndarray
    velocity: np.ndarray
    normal: np.ndarray
    pressure: float
    solution: object  # simulation.Solution
    edge_length: np.ndarray | None = None  # (N,) mean edge length at each node
    state: State | None = None  # the state evaluated (None: positions only)
    mesh_velocity: np.ndarray | None = None  # (N, 3) dx/dt of the nodes (None: v_n n)
    field_rates: dict = field(default_factory=dict)  # name -> rate of the stored quantity
    transport: dict = field(default_factory=dict)  # name -> FieldTransport (kind, implicit part)

    @property
    def normal_speed(self) -> np.ndarray:
        return np.einsum("nc,nc->n", self.velocity, self.normal)

    @property
    def rate(self) -> np.ndarray:
        """dx/dt of the nodes: the mesh velocity (the normal part of the velocity by default)."""
        if self.mesh_velocity is not None:
            return self.mesh_velocity
        return self.normal_speed[:, None] * self.normal

    @property
    def rates(self) -> Rates:
        """d/dt of the whole state."""
        return Rates(self.rate, self.field_rates)


def advance(ev: Evaluation, dt: float, rates: Rates) -> State:
    """The state of ``ev`` advanced by ``dt`` with ``rates`` (the fields' implicit parts included)."""
    state = ev.state if ev.state is not None else State(ev.points)
    return state.advanced(dt, rates, ev.transport)


@dataclass
class StepResult:
    state: State  # the new state
    dt: float  # the step taken
    error: float  # estimated local displacement error (R0), nan if not estimated
    accepted: bool = True
    dt_next: float | None = None
    solves: int = 1

    @property
    def points(self) -> np.ndarray:
        """The new shape."""
        return self.state.points


SCHEMES: dict[str, type[Scheme]] = {}


def register_scheme(name):
    """Class decorator adding a :class:`Scheme` to :data:`SCHEMES` under ``name``."""

    def deco(cls):
        cls.name = name
        SCHEMES[name] = cls
        return cls

    return deco


class Scheme:
    """One step of the shape evolution, and the rules that belong to the scheme."""

    name = "scheme"
    adaptive = False  # the step follows a controller (a resumed run continues with its step)
    first_order = True  # the semi-implicit tension (first order) keeps the scheme's order
    dt_cap = math.inf  # largest step the scheme accepts (adaptive_euler learns its own)

    def __init__(self, evaluate, **_):
        self.evaluate = evaluate

    @classmethod
    def implicit_tension(cls, setting) -> bool:
        """Resolve ``time.implicit_tension`` (``auto``, true, false) for this scheme: ``auto`` is on
        for the first-order schemes, off for the second-order ones, which it would spoil (the
        scene rules refuse ``true`` with those)."""
        return bool(cls.first_order) if setting == "auto" else bool(setting)

    def step(self, ev: Evaluation, dt: float) -> StepResult:  # pragma: no cover - interface
        raise NotImplementedError

    def restart(self) -> None:
        """Forget the history of earlier steps: the mesh changed (a remeshing), so rates and states
        of earlier steps live on other nodes. A one-step scheme has none."""


@register_scheme("euler")
class Euler(Scheme):
    """y_{n+1} = y_n + dt f(y_n) (positions: x_{n+1} = x_n + dt w(x_n), w = v_n n by default)."""

    def step(self, ev: Evaluation, dt: float) -> StepResult:
        return StepResult(advance(ev, dt, ev.rates), dt, float("nan"), solves=0)


@register_scheme("heun")
class Heun(Scheme):
    """Explicit trapezoid: predictor Euler, corrector with the average rate."""

    first_order = False

    def _pair(self, ev, dt):
        pred = advance(ev, dt, ev.rates)
        ev2 = self.evaluate(pred)
        new = advance(ev, dt, 0.5 * (ev.rates + ev2.rates))
        return new, float(np.max(np.linalg.norm(new.points - pred.points, axis=1)))

    def step(self, ev, dt):
        new, err = self._pair(ev, dt)
        return StepResult(new, dt, err, solves=1)


@register_scheme("adaptive")
class AdaptiveHeun(Heun):
    """Heun with the embedded Euler error estimate and a step-size controller."""

    adaptive = True
    SAFETY, GROW, SHRINK = 0.9, 2.0, 0.2

    def __init__(self, evaluate, tol: float = 1e-4, dt_max: float = 0.05, dt_min: float = 1e-9, **_):
        super().__init__(evaluate)
        self.tol, self.dt_max, self.dt_min = tol, dt_max, dt_min

    def step(self, ev, dt):
        new, err = self._pair(ev, dt)
        ratio = err / self.tol
        factor = self.GROW if ratio == 0 else min(self.GROW, max(self.SHRINK, self.SAFETY * ratio**-0.5))
        dt_next = min(self.dt_max, dt * factor)
        if ratio > 1.0 or not np.all(np.isfinite(new.points)):
            if dt <= self.dt_min:
                raise StabilityError(f"the adaptive step fell below time.dt_min = {self.dt_min:g} at error {err:.2e}")
            old = ev.state if ev.state is not None else State(ev.points)
            return StepResult(old, dt, err, accepted=False, dt_next=max(dt * factor, self.dt_min), solves=1)
        return StepResult(new, dt, err, dt_next=dt_next, solves=1)


@register_scheme("adaptive_euler")
class AdaptiveEuler(Euler):
    """Euler whose step follows the change of the normal rate between steps, and learns
    the explicit stability limit; one solve per step.

    * Accuracy: Euler's local error is ``dt^2 |x''| / 2``; ``x''`` is estimated, at no
      extra solve, from the rates of the last two steps, ``|r_k - r_{k-1}| / dt_{k-1}``,
      and the step is the one that keeps the estimate at ``tol``.
    * Stability: a step beyond the explicit limit shows up as rate changes that flip
      sign and grow from one step to the next (the amplification factor of the stiffest
      mode is below -1). Then the step is cut to 0.7 of it and capped there for the rest
      of the run (cut again if the oscillation comes back), so the controller cannot
      creep back over the limit when the flow slows down and the accuracy estimate
      alone would let it grow.

    Steps are never redone (that would need a second solve); the stability guard still
    stops a run that diverges.
    """

    adaptive = True
    GROW, SHRINK, CAP = 1.5, 0.2, 0.7

    def __init__(self, evaluate, tol: float = 1e-4, dt_max: float = 0.05, dt_min: float = 1e-6, **_):
        super().__init__(evaluate)
        self.tol, self.dt_max, self.dt_min = tol, dt_max, dt_min
        self.dt_cap = dt_max
        self._prev = None  # (rate, dt) of the step before
        self._change = None  # the rate change of the step before

    def step(self, ev, dt):
        err = float("nan")
        dt_next = min(dt, self.dt_cap)
        rate = ev.rate
        if self._prev is not None and self._prev[0].shape == rate.shape:
            prev_rate, prev_dt = self._prev
            change = rate - prev_rate
            curvature = float(np.max(np.linalg.norm(change, axis=1))) / prev_dt
            err = 0.5 * prev_dt**2 * curvature
            if self._change is not None:
                flip = float(np.sum(change * self._change)) < 0.0
                grows = np.linalg.norm(change) > 1.2 * np.linalg.norm(self._change)
                if flip and grows and err > 0.01 * self.tol:
                    if self.CAP * prev_dt < self.dt_min:
                        raise StabilityError(
                            f"the normal rates keep oscillating at steps down to dt = {prev_dt:.2g}: this is not a "
                            "time-step instability but an unresolved shape (spurious modes of the discrete force "
                            f"balance); {RESOLUTION_HINT}"
                        )
                    self.dt_cap = self.CAP * prev_dt
                    log.info(
                        "adaptive_euler: oscillating rates at dt = %.3g; step capped at %.3g", prev_dt, self.dt_cap
                    )
            self._change = change
            ideal = np.sqrt(2.0 * self.tol / curvature) if curvature > 0 else self.dt_max
            dt_next = min(self.dt_max, self.dt_cap, dt * self.GROW, max(dt * self.SHRINK, ideal))
            dt = min(dt, dt_next)
        self._prev = (rate, dt)
        return StepResult(advance(ev, dt, ev.rates), dt, err, dt_next=dt_next, solves=0)

    def restart(self) -> None:
        """The rate history lives on the old nodes: start the accuracy estimate afresh (the learned
        stability cap stays, a property of the dynamics rather than of the nodes)."""
        self._prev = None
        self._change = None


def make_scheme(name: str, evaluate, **options):
    """The scheme ``name`` of :data:`SCHEMES` built on ``evaluate`` with its options."""
    if name not in SCHEMES:
        raise SceneError(f"unknown time scheme {name!r}; choose one of {', '.join(SCHEMES)}")
    return SCHEMES[name](evaluate, **options)
