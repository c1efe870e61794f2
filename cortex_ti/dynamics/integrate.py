r"""Advancing a shape in time: the integration loop of every scheme.

Frames are written every ``time.save_every`` and at the extra times ``time.save_times`` (the
steps are shortened to land on the frame times exactly), and the run stops at ``time.t_end``
or when ``max |v_n|`` falls below ``time.steady_tol``. With ``time.implicit_tension`` (default for the first-order
schemes) each
solve is for the step about to be taken: the active tension's curvature is evaluated at the
end of the step (:mod:`cortex_ti.physics.terms.implicit_tension`), which holds down the stiff
high-frequency normal modes, so the step is set by accuracy rather than by the explicit
stability limit (a sheared cortex whose explicit limit falls to 1e-5 runs at 1e-3). The
velocity written with a frame is then the one the shape moves with over the next step.

A scheme that steps on its own (``scheme.dense``: ``bdf2``, which solves at its own
extrapolated states) is not shortened to land on the frames: its frames are interpolated between
its steps (:meth:`~cortex_ti.dynamics.schemes.BDF2.interpolate`), and only the last step lands on
``t_end``.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass

import numpy as np

from ..errors import SolverError
from .guard import StabilityGuard
from .state import State

__all__ = ["RunHooks", "RunStats", "FrameClock", "integrate"]


@dataclass
class RunStats:
    steps: int = 0
    rejected: int = 0
    solves: int = 0
    wall: float = 0.0
    t: float = 0.0  # the time reached
    stopped: str = "t_end"  # why the run ended: t_end, steady, or what ``stop`` said
    remeshes: int = 0  # remeshings done (mesh.remesh)
    remesh_wall: float = 0.0  # seconds spent remeshing (the new mesh's set-up included)


class RunHooks:
    """What a run does besides stepping, in one object: :func:`integrate` calls

    * ``frame(t, ev, dt_next, final)`` at each frame time (the frame's evaluation, the step taken next);
    * ``remesh(state, t) -> State | None`` after every accepted step: a new state on a new mesh
      replaces the step's (None: the mesh stays);
    * ``stop(t) -> str | None`` where the steady state is checked (after each step's frames): a reason
      ends the run there (:attr:`RunStats.stopped`);
    * ``progress(t, ev, dt, stats)`` once per pass of the loop (after the step's frames).

    The defaults do nothing; a run subclasses it (:mod:`cortex_ti.simulation.run`), a test passes a
    frame function. ``remesh`` is None for a run that never remeshes (no new mesh is asked for).
    """

    remesh = None

    def __init__(self, frame=None, progress=None, remesh=None, stop=None):
        if frame is not None:
            self.frame = frame
        if progress is not None:
            self.progress = progress
        if remesh is not None:
            self.remesh = remesh
        if stop is not None:
            self.stop = stop

    def frame(self, t: float, ev, dt_next: float, final: bool = False) -> None:
        pass

    def stop(self, t: float) -> str | None:
        return None

    def progress(self, t: float, ev, dt: float, stats: RunStats) -> None:
        pass


class FrameClock:
    """The frame times: every multiple of ``save_every`` (counted from 0, so that a run resumed from
    an extra frame keeps the same grid) and each of ``save_times``."""

    def __init__(self, save_every: float, save_times=()):
        self.save_every = save_every
        self.eps = 1e-9 * max(save_every, 1e-12)
        self.extra = sorted(float(s) for s in save_times)

    def after(self, t: float) -> float:
        """The first frame time after ``t``."""
        regular = self.save_every * (math.floor((t + self.eps) / self.save_every) + 1)
        return min([regular] + [s for s in self.extra if s > t + self.eps])


def integrate(
    evaluate,
    state0: State | np.ndarray,
    t0: float,
    t_end: float,
    dt0: float,
    scheme,
    save_every: float,
    hooks,
    steady_tol: float = 0.0,
    progress=None,
    guard: StabilityGuard | None = None,
    write_first: bool = True,
    implicit: bool = False,
    save_times: tuple[float, ...] = (),
    remesh=None,
    stop=None,
    restored=None,
) -> RunStats:
    """Advance the shape from ``t0`` to ``t_end``: one loop for the fixed-step, adaptive and dense schemes.

    ``state0`` is the :class:`~cortex_ti.dynamics.state.State` to start from (an array: positions only).
    ``evaluate(state, dt) -> Evaluation`` solves the force balance on a state (for a step
    ``dt`` with the semi-implicit tension when ``implicit``, else always with ``dt = 0``).
    ``hooks`` (:class:`RunHooks`, or a frame function ``(t, ev, dt_next, final)`` with the other hooks
    given as ``progress``, ``remesh``, ``stop``) is called at ``t0`` (if ``write_first``; a resumed
    run has that frame already), at every multiple of ``save_every`` and at each of ``save_times``
    (extra frame times, e.g. a figure's) between ``t0`` and ``t_end``. After a remeshing the scheme
    forgets its history (:meth:`Scheme.restart`; a dense scheme starts again from a solve on the new
    mesh, with its Euler start of at most ``dt0``) and the guard follows the new triangles.
    ``restored = (checkpoint, dt)``: a dense scheme (bdf2) continues from its saved step history
    (:meth:`~cortex_ti.dynamics.schemes.BDF2.checkpoint`) with the step ``dt`` it had proposed,
    ``t0`` being the last frame written: the run goes on as the uninterrupted one did.
    """
    if not isinstance(hooks, RunHooks):
        hooks = RunHooks(frame=hooks, progress=progress, remesh=remesh, stop=stop)
    stats = RunStats()
    start = _time.perf_counter()
    guard = guard if guard is not None else StabilityGuard()
    clock = FrameClock(save_every, save_times)
    eps, dense = clock.eps, getattr(scheme, "dense", False)
    x = state0 if isinstance(state0, State) else State(np.asarray(state0))
    t, dt = t0, dt0

    def solve(state, t_now, step, starting=False):
        """The solve a step is taken with: for the scheme's step ``step`` with the semi-implicit
        tension (not the one shortened to land on a frame: a shorter step than solved for is still
        damped, and the rate then depends only on the controller's step, which varies smoothly);
        ``starting``: the solve a dense scheme starts with (its Euler start's step)."""
        planned = (scheme.start_step(step) if starting else step) if implicit else 0.0
        try:
            ev = evaluate(state, planned)
        except SolverError as exc:
            raise _which_solve(exc, t_now, step, implicit) from None
        stats.solves += 1
        return ev

    if dense and restored is not None:  # the history's newest state, solved for the diagnostics it lends
        dt = restored[1]
        x = State(np.asarray(restored[0][f"{int(restored[0]['n']) - 1}__points"]), x.fields, x.faces)
    ev = solve(x, t, dt, starting=dense)
    if dense and restored is not None:
        t = scheme.restore(restored[0], x.faces, ev)
        x, ev = scheme.history[-1][1], scheme.last_evaluation
    elif dense:
        scheme.start(t, ev)
    if write_first:
        hooks.frame(t, ev, dt, final=False)
    next_save = clock.after(t0)
    while True:
        hooks.progress(t, ev, dt, stats)
        if t >= t_end - eps:
            break
        if steady_tol > 0 and float(np.max(np.abs(ev.normal_speed))) < steady_tol:
            stats.stopped = "steady"
            break
        if (why := hooks.stop(t)) is not None:
            stats.stopped = why
            break
        h = min(dt, t_end - t) if dense else min(dt, t_end - t, next_save - t)  # a dense scheme interpolates
        try:
            res = scheme.step(ev, h)
        except SolverError as exc:
            raise guard.failed_solve(_which_solve(exc, t, h, True), ev) from None
        stats.solves += res.solves
        if not res.accepted:
            stats.rejected += 1
            dt = res.dt_next
            continue
        ev_step = scheme.last_evaluation if dense else ev
        guard.check(t + res.dt, res.dt, x.points, res.points, ev_step, ev_step.edge_length)
        t_new = t + res.dt  # the scheme may take a shorter step than offered
        final = t_new >= t_end - eps
        if dense:
            dt = res.dt_next if res.dt_next is not None else dt
            next_save = _interpolated_frames(hooks, scheme, clock, next_save, t_new, dt, final)
        elif scheme.adaptive and res.dt_next is not None:
            # keep the controller's proposal, not the step shortened to reach a frame time
            dt = res.dt_next if res.dt >= dt * (1 - 1e-12) else max(dt, res.dt_next)
            dt = min(dt, scheme.dt_cap)
        x, t, ev = res.state, t_new, ev_step
        stats.steps += 1
        new = None
        if hooks.remesh is not None and not (dense and final):  # a dense run's last frame is written
            started = _time.perf_counter()
            new = hooks.remesh(x, t)
            if new is not None:
                x = new
                guard.new_mesh(new.faces)
                stats.remeshes += 1
                if dense:  # the scheme starts again from a solve on the new mesh
                    dt = min(dt, dt0)
                    ev = solve(x, t, dt, starting=True)
                    scheme.start(t, ev)
                else:
                    scheme.restart()
            stats.remesh_wall += _time.perf_counter() - started
        if not dense:
            ev = solve(x, t, dt)
            if t >= next_save - eps or final:
                hooks.frame(t, ev, dt, final=final)
                next_save = clock.after(t)
    stats.wall = _time.perf_counter() - start
    stats.t = t
    return stats


def _interpolated_frames(hooks, scheme, clock: FrameClock, next_save: float, t_new: float, dt: float, final: bool):
    """A dense scheme's frames passed in its step to ``t_new``, interpolated (on the mesh they were
    computed on, before a remeshing), and the frame time after them (``final``: the last step also
    writes a frame at ``t_new``)."""
    eps = clock.eps
    while next_save <= t_new + eps or (final and next_save < math.inf):
        tf = min(next_save, t_new)
        hooks.frame(tf, scheme.interpolate(tf), dt, final=final and tf >= t_new - eps)
        if tf >= t_new - eps:
            break
        next_save = clock.after(tf)
    return clock.after(t_new) if next_save <= t_new + eps else next_save


def _which_solve(exc: SolverError, t: float, step: float, with_step: bool) -> SolverError:
    """The solver's message, prefixed with the solve that failed (and what to change when the
    step is in the matrix: the semi-implicit tension puts ``dt`` into it)."""
    what = f"the solve at t = {t:.4g}" + (f" for a step dt = {step:.3g}" if with_step else "")
    hint = (
        " (the semi-implicit tension puts dt into the matrix: try a smaller time.dt)"
        if with_step and step > 1.0
        else ""
    )
    return SolverError(f"{what} failed: {exc}{hint}")
