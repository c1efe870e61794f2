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
``bdf2``            variable-step, linearly implicit BDF2 (:class:`BDF2`): second order, one solve
                    per step, the stiff normal modes held down by the semi-implicit tension
                    centred on the last step's rate, a step controller whose Milne-type error
                    estimate sees every term, and frames interpolated between the steps
                    (``docs/derivations/time_schemes.md``).

What belongs to a scheme is a property of its class: whether it is ``adaptive`` (a resumed run
continues with the controller's step), ``first_order``, ``semi_implicit`` (the semi-implicit
tension keeps its order, :meth:`Scheme.implicit_tension` resolves ``time.implicit_tension:
auto``), ``dense`` (it steps on its own and interpolates the frames,
:func:`cortex_ti.dynamics.integrate.integrate`).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SceneError, StabilityError
from ..surface.curved_transport import curved_implicit_diffusion_reaction
from ..surface.transport import DENSITY, dual_areas
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
    "BDF2",
    "bdf2_coefficients",
    "bdf2_error_constant",
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
    first_order = True
    semi_implicit = True  # the semi-implicit tension keeps the scheme's order
    dense = False  # steps on its own and interpolates the frames (bdf2)
    dt_cap = math.inf  # largest step the scheme accepts (adaptive_euler learns its own)
    default_tol = 1e-4  # time.tol: null (an adaptive scheme's local error per step, R0)
    default_dt_max = 0.05  # time.dt_max: null
    #: largest ``dt * lam`` for which a term the scheme treats explicitly, decaying at the rate
    #: ``lam``, stays stable (its stability interval on the negative real axis): 2 for forward Euler
    #: and Heun; bdf2 lowers it (the ALE mesh velocity is such a term, :data:`ALE_STIFFEST`)
    explicit_interval = 2.0

    @classmethod
    def resolve_step_control(cls, tol, dt_max, nodes: int | None = None) -> tuple[float, float]:
        """``time.tol`` and ``time.dt_max`` for this scheme: the scene's values, or the scheme's
        defaults where they are null (:meth:`default_tol_for` the mesh's ``nodes``, None for a mesh file)."""
        return (
            float(cls.default_tol_for(nodes) if tol is None else tol),
            float(cls.default_dt_max if dt_max is None else dt_max),
        )

    @classmethod
    def default_tol_for(cls, nodes: int | None) -> float:
        """The scheme's ``time.tol`` when the scene leaves it null (the same at every resolution)."""
        return cls.default_tol

    def __init__(self, evaluate, **_):
        self.evaluate = evaluate

    @classmethod
    def implicit_tension(cls, setting, formulation: str = "rayleigh_p1") -> bool:
        """Resolve ``time.implicit_tension`` (``auto``, true, false) for this scheme: ``auto`` is on
        for the schemes whose order it keeps (the first-order ones and ``bdf2``), off for the
        explicit second-order ones, which it would spoil (the scene rules refuse ``true`` with
        those)."""
        return bool(cls.semi_implicit) if setting == "auto" else bool(setting)

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
    semi_implicit = False

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


def _lagrange_at(times, t):
    """Weights of the polynomial through ``times`` evaluated at ``t`` (Lagrange form)."""
    w = []
    for i, ti in enumerate(times):
        prod = 1.0
        for j, tj in enumerate(times):
            if j != i:
                prod *= (t - tj) / (ti - tj)
        w.append(prod)
    return w


def bdf2_coefficients(h: float, h_prev: float) -> tuple[float, float, float]:
    """Variable-step BDF2 from ``x_{n-1}``, ``x_n`` (steps ``h_prev``, then ``h``), written as
    ``x_{n+1} = a x_n + b x_{n-1} + gamma f(x_{n+1})``: returns ``(a, b, gamma)``.

    >>> bdf2_coefficients(1.0, 1.0)  # (4 x_n - x_{n-1}) / 3 + 2/3 h f
    (1.3333333333333333, -0.3333333333333333, 0.6666666666666666)
    """
    w = h / h_prev
    return (1.0 + w) ** 2 / (1.0 + 2.0 * w), -(w**2) / (1.0 + 2.0 * w), h * (1.0 + w) / (1.0 + 2.0 * w)


def bdf2_error_constant(h: float, h_prev: float, h_prev2: float) -> float:
    """The factor ``c`` of the Milne-type estimate ``|local error| ~ c |x_{n+1} - x^P|`` of the
    linearly implicit BDF2, ``x^P`` the quadratic through ``x_{n-2}, x_{n-1}, x_n`` extrapolated to
    ``t_{n+1}``. Both errors are multiples of the third derivative ``x3``; their ratio depends on how
    much of the flow the implicit part carries: all of it (plain BDF2, local error ``c_B h^3 x3``)
    or none (the part evaluated at the extrapolated state adds ``-gamma h (h + h_prev) / 2 x3`` on
    a linear flow). ``c`` is the larger of the two ratios, each found exactly on the cubic
    ``t^3 / 6`` (docs/derivations/time_schemes.md, "Error estimate").

    >>> round(bdf2_error_constant(1.0, 1.0, 1.0), 12)  # constant step: max(2/11, 4/5)
    0.8
    """
    t = [-(h + h_prev + h_prev2), -(h + h_prev), -h]  # t_{n+1} = 0
    cubic = [ti**3 / 6.0 for ti in t]
    a, b, gamma = bdf2_coefficients(h, h_prev)
    implicit = a * cubic[2] + b * cubic[1]  # + gamma x'(0) = 0 on the cubic; the exact value is 0
    explicit = implicit - gamma * h * (h + h_prev) / 2.0  # + gamma x''(0) (x* - x(0)) at leading order
    pred = sum(wi * ci for wi, ci in zip(_lagrange_at(t, 0.0), cubic, strict=True))
    return max(abs(implicit) / abs(implicit - pred), abs(explicit) / abs(explicit - pred))


@register_scheme("bdf2")
class BDF2(Scheme):
    r"""Variable-step, linearly implicit (extrapolated) BDF2 with error control and dense output.

    A step from ``t_n`` of length ``h`` (ratio ``w = h / h_{n-1}``):

    * the state is extrapolated, ``S* = S_n + w (S_n - S_{n-1})``, and the force balance solved
      there once, with the semi-implicit tension of step ``gamma = h (1 + w) / (1 + 2 w)`` centred
      on the last step's rate ``r = (x_n - x_{n-1}) / h_{n-1}`` (the tension's force at
      ``x_{n+1}``, linearised about ``x*``, since ``x_{n+1} - x* = gamma (w_{n+1} - r)``);
    * ``x_{n+1} = a x_n + b x_{n-1} + gamma w_{n+1}`` (:func:`bdf2_coefficients`), the fields'
      stored quantities with the same coefficients and their diffusion and turnover implicit over
      ``gamma`` (:meth:`State.combined <cortex_ti.dynamics.state.State.combined>`);
    * the local error is estimated against the quadratic extrapolation of the last three states
      (:func:`bdf2_error_constant`), so it sees every term that moved ``x_{n+1}``, the implicit
      one included; a step whose estimate exceeds ``tol`` is redone with a smaller one, the next
      step is ``h (tol / err)^(1/3)`` (times 0.9, within [0.2, 2] h: ratios below ``1 + sqrt 2``
      keep variable-step BDF2 zero-stable), at most ``dt_max``.

    The start (the first steps, after a resume and after a remeshing) is two semi-implicit Euler
    steps of ``time.dt / 2`` (the second with its own solve), so that every
    BDF2 step has the three states its error estimate needs: a BDF2 step from two states would
    extrapolate a fast transient the first Euler step damped back to its full amplitude, unchecked.
    Frames between steps are interpolated (:meth:`interpolate`): positions and fields on the quadratic
    through the last three states, velocities linearly between the steps' solves.
    """

    adaptive = True
    first_order = False
    semi_implicit = True
    dense = True
    SAFETY, GROW, SHRINK = 0.9, 2.0, 0.2
    KEEP = 3  # the states a step reads (its error estimate's quadratic)
    default_tol = 4e-6  # at TOL_NODES nodes, and for a mesh file; scaled with the mesh (default_tol_for)
    TOL_NODES = 10242
    default_dt_max = 0.2
    # extrapolated BDF2 on x' = -lam x (x* = 2 x_n - x_(n-1)): roots of 3/2 r^2 - 2 r + 1/2 = -z (2 r - 1)
    # stay in the unit disc for 0 <= z = lam dt < 4/3 (docs/derivations/time_schemes.md)
    explicit_interval = 4.0 / 3.0

    @classmethod
    def default_tol_for(cls, nodes: int | None) -> float:
        """``4e-6 * 10242 / nodes`` to two digits: a tolerance that follows the mesh's own error, so the time error
        stays below it at every resolution without paying for more. The mesh's error of the radii is
        second order, ~1/N (furrow_p4_a1 at t = 0: 2.5e-3, 6.4e-4, 1.6e-4 at 642, 2562, 10242 nodes);
        the time error over a furrow run is ~3-10 tol at any N. So 6.4e-5, 1.6e-5, 4e-6 there, for
        time errors of 2.1e-4, 9.0e-5 and 3.7e-5: a twelfth, a seventh and a quarter of the mesh's
        (docs/validation/time_schemes.md, "The default tolerance"). A mesh file (``nodes`` None) gets
        the finest, 4e-6."""
        if nodes is None:
            return cls.default_tol
        return float(f"{cls.default_tol * cls.TOL_NODES / max(int(nodes), 1):.2g}")  # 2 digits: 1.6e-5, not 1.599...e-5

    @classmethod
    def implicit_tension(cls, setting, formulation: str = "rayleigh_p1") -> bool:
        """``auto``: on with the formulations that have the tension centred on a rate (``rayleigh_p1``,
        ``rayleigh_p2``); with ``paper`` the scheme runs explicit (extrapolated BDF2, the step then also
        bounded by the explicit limit through the error estimate). ``true`` with ``paper`` is refused by
        the scene rules."""
        if setting == "auto":
            from ..physics.formulations import FORMULATIONS

            return FORMULATIONS[formulation].centred_implicit
        return bool(setting)

    def __init__(
        self, evaluate, tol: float = 1e-4, dt_max: float = 0.05, dt_min: float = 1e-8, implicit: bool = True, **_
    ):
        super().__init__(evaluate)
        self.tol, self.dt_max, self.dt_min, self.implicit = tol, dt_max, dt_min, implicit
        self.history: list = []  # [(t, state, evaluation or None)], oldest first, at most three

    def start(self, t: float, ev: Evaluation) -> None:
        """Forget the past: the next two steps are the Euler start from ``ev`` (the solve at ``t``)."""
        state = ev.state if ev.state is not None else State(ev.points)
        self.history = [(t, state, ev)]

    @staticmethod
    def start_step(dt: float) -> float:
        """The step of the start's first semi-implicit Euler step when ``dt`` is offered: the solve
        that starts the scheme is for that step."""
        return 0.5 * dt

    def _solve(self, state: State, gamma: float, rate: np.ndarray) -> Evaluation:
        if self.implicit:
            return self.evaluate(state, gamma, implicit_rate=rate)
        return self.evaluate(state)

    def step(self, ev: Evaluation, dt: float) -> StepResult:
        if not self.history:
            self.start(0.0, ev)
        t_n, s_n, ev_n = self.history[-1]
        if len(self.history) == 1:  # the start: semi-implicit Euler with the solve at t_n, half the step
            dt = self.start_step(dt)
            new = advance(ev_n, dt, ev_n.rates)
            self._accept(t_n + dt, new, None)
            return StepResult(new, dt, float("nan"), dt_next=min(dt, self.dt_max), solves=0)
        t_p, s_p, _ = self.history[-2]
        h_prev = t_n - t_p
        if len(self.history) == 2:
            # the start's second semi-implicit Euler step (as long as the first), with its own solve
            # at t_n: then every BDF2 step has the three states its error estimate needs
            # (docs/derivations/time_schemes.md, "Start"; a BDF2 step taken without one extrapolates a
            # fast transient the first Euler step has damped back at its full amplitude, unchecked)
            dt = min(dt, h_prev)
            ev_n = self.evaluate(s_n, dt) if self.implicit else self.evaluate(s_n)
            new = advance(ev_n, dt, ev_n.rates)
            self.history[-1] = (t_n, s_n, ev_n)
            self._accept(t_n + dt, new, None)
            return StepResult(new, dt, float("nan"), dt_next=min(dt, self.dt_max), solves=1)
        a, b, gamma = bdf2_coefficients(dt, h_prev)
        rate = (s_n.points - s_p.points) / h_prev
        ev_new = self._solve(s_n.extrapolated(s_p, dt / h_prev), gamma, rate)
        new = State.combined([(b, s_p), (a, s_n)], gamma, ev_new.rates, ev_new.transport)
        if not np.all(np.isfinite(new.points)):
            err = math.inf
        else:
            t_q, s_q, _ = self.history[-3]
            weights = _lagrange_at([t_q, t_p, t_n], t_n + dt)
            pred = weights[0] * s_q.points + weights[1] * s_p.points + weights[2] * s_n.points
            c = bdf2_error_constant(dt, h_prev, t_p - t_q)
            err = c * float(np.max(np.linalg.norm(new.points - pred, axis=1)))
        return self._judge(err, dt, t_n, s_n, new, ev_new, 3)

    def _judge(self, err: float, dt: float, t_n: float, s_n: State, new: State, ev_new, order: int) -> StepResult:
        """Accept the step to ``new`` (solved by ``ev_new``) or reject it, by its estimated error
        against ``tol``; the next step ``dt (tol / err)^(1 / order)`` times ``SAFETY``, within
        ``[SHRINK, GROW] dt``, at most ``dt_max``."""
        ratio = 0.0 if math.isnan(err) else err / self.tol
        factor = self.GROW if ratio == 0 else min(self.GROW, max(self.SHRINK, self.SAFETY * ratio ** (-1.0 / order)))
        if ratio > 1.0:
            if dt <= self.dt_min:
                raise StabilityError(
                    f"{self.name}: the step cannot be made small enough at t = {t_n:.6g}: dt = {dt:.3g} (the "
                    f"smallest, {self.dt_min:g}) still leaves an estimated error {err:.2e} > time.tol = {self.tol:g}"
                )
            return StepResult(s_n, dt, err, accepted=False, dt_next=max(dt * factor, self.dt_min), solves=1)
        self._accept(t_n + dt, new, ev_new)
        return StepResult(new, dt, err, dt_next=min(self.dt_max, dt * factor), solves=1)

    def _accept(self, t: float, state: State, ev: Evaluation | None) -> None:
        self.history = [*self.history[1 - self.KEEP :], (t, state, ev)]

    def checkpoint(self) -> dict[str, np.ndarray]:
        """The step history as named arrays, from which :meth:`restore` continues exactly: the
        accepted states (time, positions, fields) and, of the steps' solves, what the steps and
        the interpolation of frames read (velocity, normal, pressure, mesh velocity, edge lengths)."""
        out = {"n": np.array(len(self.history))}
        for k, (t, state, ev) in enumerate(self.history):
            out[f"{k}__t"] = np.array(float(t))
            out[f"{k}__points"] = state.points
            for name, values in state.fields.items():
                out[f"{k}__field__{name}"] = values
            if ev is not None:
                out[f"{k}__velocity"], out[f"{k}__normal"] = ev.velocity, ev.normal
                out[f"{k}__pressure"] = np.array(float(ev.pressure))
                for name in ("mesh_velocity", "edge_length"):
                    if getattr(ev, name) is not None:
                        out[f"{k}__{name}"] = getattr(ev, name)
        return out

    def restore(self, data, faces: np.ndarray, solved: Evaluation) -> float:
        """Continue from a :meth:`checkpoint` (on the mesh ``faces``); ``solved``, a solve on its
        newest state, lends the restored solves its solver diagnostics and field transport (their
        flows are the saved ones). Returns the time of the newest state."""
        history, shared = [], {}
        for k in range(int(data["n"])):
            fields = {}
            for key in (key for key in data if key.startswith(f"{k}__field__")):
                name, values = key[len(f"{k}__field__") :], np.asarray(data[key])
                same = shared.get(name)
                # a field glued to the nodes is one array in every state (interpolate keeps it exactly)
                fields[name] = same if same is not None and np.array_equal(same, values) else values
                shared[name] = fields[name]
            state = State(np.asarray(data[f"{k}__points"]), fields, faces)
            ev = None
            if f"{k}__velocity" in data:
                ev = Evaluation(
                    points=state.points,
                    velocity=np.asarray(data[f"{k}__velocity"]),
                    normal=np.asarray(data[f"{k}__normal"]),
                    pressure=float(data[f"{k}__pressure"]),
                    solution=solved.solution,
                    edge_length=np.asarray(data[f"{k}__edge_length"]) if f"{k}__edge_length" in data else None,
                    state=state,
                    mesh_velocity=np.asarray(data[f"{k}__mesh_velocity"]) if f"{k}__mesh_velocity" in data else None,
                    transport=solved.transport,
                )
            history.append((float(data[f"{k}__t"]), state, ev))
        self.history = history
        return history[-1][0]

    @property
    def last_evaluation(self) -> Evaluation:
        """The solve of the last step (during the start: the Euler step's solve, at its beginning)."""
        return next(ev for _, _, ev in reversed(self.history) if ev is not None)

    def interpolate(self, t: float) -> Evaluation:
        """The state and the flow at ``t`` between the last two accepted states: positions and
        field values (a density's content ``c A``, so that its total is kept) on the quadratic
        through the last three states (the line through two after the start); velocity, normal
        and pressure linear in time between the two latest solves (the start's solve taken at its
        own time); the solve's diagnostics those of the last step."""
        times = [h[0] for h in self.history]
        states = [h[1] for h in self.history]
        t_new, newest, _ = self.history[-1]
        transport = self.last_evaluation.transport
        if abs(t - t_new) <= 1e-12 * max(1.0, abs(t_new)):
            points, fields = newest.points, dict(newest.fields)
        else:
            w = _lagrange_at(times, t)
            points = sum(wi * st.points for wi, st in zip(w, states, strict=True))
            fields = {}
            for k, v in newest.fields.items():
                tr = transport.get(k)
                if all(st.fields.get(k) is v for st in states):
                    fields[k] = v  # glued to the nodes
                elif tr is not None and tr.curved_density:  # the content M c on the curved cells
                    content = sum(wi * st.stored(k, tr.kind, tr.cells) for wi, st in zip(w, states, strict=True))
                    fields[k] = curved_implicit_diffusion_reaction(content, points, newest.faces, 0.0)
                elif tr is not None and tr.kind == DENSITY:  # the content c A: its total is kept
                    content = sum(wi * st.stored(k, tr.kind) for wi, st in zip(w, states, strict=True))
                    fields[k] = content / dual_areas(points, newest.faces)
                else:
                    fields[k] = sum(wi * st.fields[k] for wi, st in zip(w, states, strict=True))
        solved = [(ti, ev) for ti, _, ev in self.history if ev is not None]
        (t0, e0), (t1, e1) = (solved[-1], solved[-1]) if len(solved) == 1 else (solved[-2], solved[-1])
        # the start's second step has its solve at its beginning: after it, that solve's flow (no extrapolation)
        th = 0.0 if t1 == t0 else min(1.0, (t - t0) / (t1 - t0))

        def lin(a, b):
            return a if a is b else (1.0 - th) * a + th * b

        normal = lin(e0.normal, e1.normal)
        normal = normal / np.linalg.norm(normal, axis=1, keepdims=True)
        return Evaluation(
            points=points,
            velocity=lin(e0.velocity, e1.velocity),
            normal=normal,
            pressure=float(lin(e0.pressure, e1.pressure)),
            solution=e1.solution,
            edge_length=e1.edge_length,
            state=State(points, fields, newest.faces),
            mesh_velocity=None if e1.mesh_velocity is None else lin(e0.mesh_velocity, e1.mesh_velocity),
            field_rates={},
            transport=e1.transport,
        )


def make_scheme(name: str, evaluate, **options):
    """The scheme ``name`` of :data:`SCHEMES` built on ``evaluate`` with its options."""
    if name not in SCHEMES:
        raise SceneError(f"unknown time scheme {name!r}; choose one of {', '.join(SCHEMES)}")
    return SCHEMES[name](evaluate, **options)
