r"""Shape evolution by normal advection of the nodes (paper Eq. 60).

Every node moves with its normal velocity, ``dx_i/dt = (v_i . n_i) n_i``; the active
tension stays attached to the node (it was evaluated once, on the initial shape).
Each right-hand-side evaluation recomputes the geometry, the fits and the
constrained solve on the current shape.

Schemes (``time.scheme``), all explicit in the shape:

``euler``     the paper's scheme, fixed step ``time.dt``, first order.
``heun``      explicit trapezoid (RK2), fixed step, second order, two solves per step.
``adaptive``  Heun with the embedded Euler estimate of the local error and a step-size
              controller: the step grows while the estimated displacement error per step
              stays below ``time.tol`` (in R0) and shrinks (the step is redone) when it
              does not. The explicit stability limit shows up as a growing error
              estimate, so the controller settles below it by itself. ``time.dt`` is
              the first step, ``time.dt_max`` the largest.

With ``time.implicit_tension`` (default for the first-order schemes) each solve is for the
step about to be taken: the active tension's curvature is evaluated at the end of the step
(:mod:`cortex_ti.terms.implicit_tension`), which holds down the stiff high-frequency normal
modes, so the step is set by accuracy rather than by the explicit stability limit (a
sheared cortex whose explicit limit falls to 1e-5 runs at 1e-3). The velocity written with
a frame is then the one the shape moves with over the next step.

A fixed-step scheme whose step is too large for the problem blows up: high-frequency
normal modes grow by a factor each step. :class:`StabilityGuard` watches the normal
speed and the mesh and stops such a run with a :class:`~cortex_ti.errors.StabilityError`
that names the step size to try, before the output fills with garbage.

Frames are written every ``time.save_every`` (the steps are shortened to land on the
frame times exactly), and the run stops at ``time.t_end`` or when ``max |v_n|`` falls
below ``time.steady_tol``.
"""

from __future__ import annotations

import logging
import math
import time as _time
from dataclasses import dataclass, field

import numpy as np

from .errors import StabilityError

log = logging.getLogger(__name__)

#: how to get out of a resolution problem (the rows may already be on: then only more nodes help)
RESOLUTION_HINT = ("use more mesh nodes (e.g. mesh.nodes=2562), or on a coarse mesh the stabilising rows "
                   "numerics.fit_residual_weight=1e-3 if they are not on already")


@dataclass
class Evaluation:
    """The solve on one shape: the velocity and the normal the nodes move along."""

    points: np.ndarray
    velocity: np.ndarray
    normal: np.ndarray
    pressure: float
    solution: object  # simulation.Solution
    edge_length: np.ndarray | None = None  # (N,) mean edge length at each node

    @property
    def normal_speed(self) -> np.ndarray:
        return np.einsum("nc,nc->n", self.velocity, self.normal)

    @property
    def rate(self) -> np.ndarray:
        """dx/dt of the nodes: the normal part of the velocity."""
        return self.normal_speed[:, None] * self.normal


@dataclass
class StepResult:
    points: np.ndarray        # the new shape
    dt: float                 # the step taken
    error: float              # estimated local displacement error (R0), nan if not estimated
    accepted: bool = True
    dt_next: float | None = None
    solves: int = 1


SCHEMES: dict[str, type] = {}


def register_scheme(name):
    def deco(cls):
        cls.name = name
        SCHEMES[name] = cls
        return cls

    return deco


@register_scheme("euler")
class Euler:
    """x_{n+1} = x_n + dt v_n(x_n) n(x_n)."""

    adaptive = False
    first_order = True   # the semi-implicit tension keeps its order
    dt_cap = math.inf  # largest step the scheme accepts (adaptive_euler learns its own)

    def __init__(self, evaluate, **_):
        self.evaluate = evaluate

    def step(self, ev: Evaluation, dt: float) -> StepResult:
        return StepResult(ev.points + dt * ev.rate, dt, float("nan"), solves=0)


@register_scheme("heun")
class Heun:
    """Explicit trapezoid: predictor Euler, corrector with the average rate."""

    adaptive = False
    first_order = False
    dt_cap = math.inf

    def __init__(self, evaluate, **_):
        self.evaluate = evaluate

    def _pair(self, ev, dt):
        pred = ev.points + dt * ev.rate
        ev2 = self.evaluate(pred)
        new = ev.points + 0.5 * dt * (ev.rate + ev2.rate)
        return new, float(np.max(np.linalg.norm(new - pred, axis=1)))

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
        factor = self.GROW if ratio == 0 else min(self.GROW, max(self.SHRINK, self.SAFETY * ratio ** -0.5))
        dt_next = min(self.dt_max, dt * factor)
        if ratio > 1.0 or not np.all(np.isfinite(new)):
            if dt <= self.dt_min:
                raise StabilityError(f"the adaptive step fell below time.dt_min = {self.dt_min:g} at error {err:.2e}")
            return StepResult(ev.points, dt, err, accepted=False, dt_next=max(dt * factor, self.dt_min), solves=1)
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
        self._prev = None    # (rate, dt) of the step before
        self._change = None  # the rate change of the step before

    def step(self, ev, dt):
        err = float("nan")
        dt_next = min(dt, self.dt_cap)
        rate = ev.rate
        if self._prev is not None and self._prev[0].shape == rate.shape:
            prev_rate, prev_dt = self._prev
            change = rate - prev_rate
            curvature = float(np.max(np.linalg.norm(change, axis=1))) / prev_dt
            err = 0.5 * prev_dt ** 2 * curvature
            if self._change is not None:
                flip = float(np.sum(change * self._change)) < 0.0
                grows = np.linalg.norm(change) > 1.2 * np.linalg.norm(self._change)
                if flip and grows and err > 0.01 * self.tol:
                    if self.CAP * prev_dt < self.dt_min:
                        raise StabilityError(
                            f"the normal rates keep oscillating at steps down to dt = {prev_dt:.2g}: this is not a "
                            "time-step instability but an unresolved shape (spurious modes of the discrete force "
                            f"balance); {RESOLUTION_HINT}")
                    self.dt_cap = self.CAP * prev_dt
                    log.info("adaptive_euler: oscillating rates at dt = %.3g; step capped at %.3g",
                             prev_dt, self.dt_cap)
            self._change = change
            ideal = np.sqrt(2.0 * self.tol / curvature) if curvature > 0 else self.dt_max
            dt_next = min(self.dt_max, self.dt_cap, dt * self.GROW, max(dt * self.SHRINK, ideal))
            dt = min(dt, dt_next)
        self._prev = (rate, dt)
        return StepResult(ev.points + dt * rate, dt, err, dt_next=dt_next, solves=0)


@dataclass
class StabilityGuard:
    """Stops a run that is going unstable or has stopped meaning anything, naming what to try.

    Checked after every step:

    * signs of an explicit instability: non-finite positions; a node displaced by more than
      ``max_fraction`` of its shortest edge in one step; or the largest normal speed growing by
      more than ``growth`` per step for ``patience`` consecutive steps while exceeding its
      running minimum by ``jump``;
    * signs of an unresolved shape, which a damped (semi-implicit) step can otherwise carry on
      through: the force balance no longer satisfied (relative least-squares residual above
      ``max_residual``; resolved runs stay below 3e-3), or the mesh collapsing (the smallest
      triangle angle below ``angle_fraction`` of its value at the start of the run).
    """

    growth: float = 1.5
    patience: int = 3
    jump: float = 10.0
    max_fraction: float = 0.5
    max_residual: float = 0.05
    angle_fraction: float = 0.2
    faces: np.ndarray | None = None
    _history: list = field(default_factory=list)
    _angle0: float | None = None

    def _min_angle(self, points) -> float:
        from .diagnostics import mesh_quality

        return mesh_quality(points, self.faces)["min_angle_deg"]

    def check(self, t: float, dt: float, old_points, new_points, ev: Evaluation, edge_length: np.ndarray) -> None:
        suggestion = (f"try time.dt={dt / 4:.3g} or time.scheme=adaptive; if smaller steps blow up too, the mesh "
                      f"is too coarse for the force balance: {RESOLUTION_HINT}")
        if not np.all(np.isfinite(new_points)) or not np.all(np.isfinite(ev.velocity)):
            raise StabilityError(f"the step dt={dt:.3g} produced non-finite values at t={t:.4g}; {suggestion}")
        move = np.linalg.norm(new_points - old_points, axis=1)
        worst = int(np.argmax(move / edge_length))
        if move[worst] > self.max_fraction * edge_length[worst]:
            raise StabilityError(
                f"the step dt={dt:.3g} at t={t:.4g} moves node {worst} by {move[worst]:.3g}, "
                f"{move[worst] / edge_length[worst]:.2f} of its edge length: the explicit scheme is unstable; {suggestion}")
        vmax = float(np.max(np.abs(ev.normal_speed)))
        self._history.append(vmax)
        h = self._history
        if len(h) > self.patience:
            recent = h[-self.patience - 1:]
            if all(b > self.growth * a for a, b in zip(recent[:-1], recent[1:])) and vmax > self.jump * min(h):
                raise StabilityError(
                    f"max |v_n| grew from {recent[0]:.3g} to {vmax:.3g} in {self.patience} steps of dt={dt:.3g} "
                    f"(t={t:.4g}): the explicit scheme is unstable at this step; {suggestion}")
        residual = ev.solution.info.relative_residual
        if residual > self.max_residual:
            raise StabilityError(
                f"the force balance is no longer satisfied at t={t - dt:.4g}: relative least-squares residual "
                f"{residual:.2g} > {self.max_residual:g} (resolved runs stay below 3e-3); the shape is not resolved: "
                f"{RESOLUTION_HINT}")
        if self.faces is not None:
            if self._angle0 is None:
                self._angle0 = self._min_angle(old_points)
            angle = self._min_angle(new_points)
            if angle < self.angle_fraction * self._angle0:
                raise StabilityError(
                    f"the mesh is collapsing at t={t:.4g}: smallest triangle angle {angle:.2g} deg, from "
                    f"{self._angle0:.3g} at the start; either the step is unstable ({suggestion}) or the shape is "
                    "not resolved")


def stiffest_normal_mode(evaluate, points: np.ndarray, iterations: int = 30, eps: float = 1e-7,
                         seed: int = 0) -> tuple[float, np.ndarray]:
    """The most strongly growing or decaying normal mode of the shape dynamics at ``points``.

    The shape moves by ``dX/dt = v_n(X) n``; a normal perturbation ``s`` (one number per node)
    evolves with the Jacobian ``J s = d v_n / dX [s n]``. Power iteration with finite
    differences (``iterations`` + 1 solves) returns ``(lambda, s)``: the eigenvalue of largest
    magnitude and its unit mode. ``lambda < 0``: explicit Euler is stable for
    ``dt < 2 / |lambda|``; ``lambda > 0``: the discrete problem has a growing mode that no time
    step removes (for instance spurious normal modes the bending viscosity cannot hold down).
    """
    ev0 = evaluate(points)
    n, vn0 = ev0.normal, ev0.normal_speed
    s = np.random.default_rng(seed).standard_normal(len(points))
    s /= np.linalg.norm(s)
    lam = 0.0
    for _ in range(iterations):
        js = (evaluate(points + eps * s[:, None] * n).normal_speed - vn0) / eps
        lam = float(s @ js)
        s = js / np.linalg.norm(js)
    return lam, s


def make_scheme(name: str, evaluate, **options):
    if name not in SCHEMES:
        from .errors import SceneError

        raise SceneError(f"unknown time scheme {name!r}; choose one of {', '.join(SCHEMES)}")
    return SCHEMES[name](evaluate, **options)


@dataclass
class RunStats:
    steps: int = 0
    rejected: int = 0
    solves: int = 0
    seconds: dict = field(default_factory=lambda: {"geometry": 0.0, "assembly": 0.0, "solve": 0.0})
    wall: float = 0.0
    t: float = 0.0             # the time reached
    stopped: str = "t_end"     # why the run ended: t_end or steady


def implicit_tension_on(setting, scheme) -> bool:
    """Resolve ``time.implicit_tension`` ('auto', true, false) for a scheme (the scene checks
    refuse ``true`` with a second-order scheme)."""
    return bool(scheme.first_order) if setting == "auto" else bool(setting)


def scene_implicit_tension(scene) -> bool:
    """Whether a scene's time steps use the semi-implicit tension: its setting, resolved for its
    scheme, and only where there is a normal balance to put it in."""
    return implicit_tension_on(scene["time.implicit_tension"], SCHEMES[scene["time.scheme"]]) \
        and scene.has("normal_balance")


def integrate(evaluate, points0: np.ndarray, t0: float, t_end: float, dt0: float, scheme,
              save_every: float, on_frame, steady_tol: float = 0.0, progress=None,
              guard: StabilityGuard | None = None, write_first: bool = True,
              implicit: bool = False) -> RunStats:
    """Advance the shape from ``t0`` to ``t_end``.

    ``evaluate(points, dt) -> Evaluation`` solves the force balance on a shape (for a step
    ``dt`` with the semi-implicit tension when ``implicit``, else always with ``dt = 0``);
    ``on_frame(t, ev, dt_next, final)`` is called at ``t0`` (if ``write_first``; a
    resumed run has that frame already) and at every multiple of ``save_every``.
    """
    stats = RunStats()
    start = _time.perf_counter()
    guard = guard if guard is not None else StabilityGuard()
    t, dt = t0, dt0
    x = points0
    next_save = t0 + save_every
    eps = 1e-9 * max(save_every, 1e-12)

    def planned(dt):
        """The step the implicit solve is for: the scheme's step, not the one shortened to land on
        a frame (a shorter step than solved for is still damped, and the rate then depends only
        on the controller's step, which varies smoothly, not on where the frames fall)."""
        return dt if implicit else 0.0

    ev = evaluate(x, planned(dt))
    stats.solves += 1
    if write_first:
        on_frame(t, ev, dt, final=False)
    while True:
        if progress is not None:
            progress(t, ev, dt, stats)
        vmax = float(np.max(np.abs(ev.normal_speed)))
        if t >= t_end - eps:
            break
        if steady_tol > 0 and vmax < steady_tol:
            stats.stopped = "steady"
            break
        h = min(dt, t_end - t, next_save - t)
        res = scheme.step(ev, h)
        stats.solves += res.solves
        if not res.accepted:
            stats.rejected += 1
            dt = res.dt_next
            continue
        guard.check(t + res.dt, res.dt, x, res.points, ev, ev.edge_length)
        x, t = res.points, t + res.dt  # the scheme may take a shorter step than offered
        stats.steps += 1
        if scheme.adaptive and res.dt_next is not None:
            # keep the controller's proposal, not the step shortened to reach a frame time
            dt = res.dt_next if res.dt >= dt * (1 - 1e-12) else max(dt, res.dt_next)
            dt = min(dt, scheme.dt_cap)
        ev = evaluate(x, planned(dt))
        stats.solves += 1
        if t >= next_save - eps or t >= t_end - eps:
            on_frame(t, ev, dt, final=t >= t_end - eps)
            next_save = t0 + save_every * (math.floor((t - t0) / save_every + 0.5) + 1)
    stats.wall = _time.perf_counter() - start
    stats.t = t
    return stats
