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

__all__ = ["RunStats", "integrate"]


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


def integrate(
    evaluate,
    state0: State | np.ndarray,
    t0: float,
    t_end: float,
    dt0: float,
    scheme,
    save_every: float,
    on_frame,
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
    """Advance the shape from ``t0`` to ``t_end``.

    ``state0`` is the :class:`~cortex_ti.dynamics.state.State` to start from (an array: positions only).
    ``evaluate(state, dt) -> Evaluation`` solves the force balance on a state (for a step
    ``dt`` with the semi-implicit tension when ``implicit``, else always with ``dt = 0``);
    ``on_frame(t, ev, dt_next, final)`` is called at ``t0`` (if ``write_first``; a
    resumed run has that frame already), at every multiple of ``save_every`` and at each of
    ``save_times`` (extra frame times, e.g. a figure's) between ``t0`` and ``t_end``.
    ``remesh(state, t) -> State | None`` is asked after every accepted step: a new state (on a new
    mesh) replaces the step's, the scheme forgets its history (:meth:`Scheme.restart`) and the
    guard follows the new triangles; None: the mesh stays. ``stop(t) -> str | None``, asked where the
    steady state is (after each step's frames): a reason ends the run there (``RunStats.stopped``).
    ``restored = (checkpoint, dt)``: a dense scheme (bdf2) continues from its saved step history
    (:meth:`~cortex_ti.dynamics.schemes.BDF2.checkpoint`) with the step ``dt`` it had proposed,
    ``t0`` being the last frame written: the run goes on as the uninterrupted one did.
    """
    stats = RunStats()
    start = _time.perf_counter()
    guard = guard if guard is not None else StabilityGuard()
    t, dt = t0, dt0
    x = state0 if isinstance(state0, State) else State(np.asarray(state0))
    eps = 1e-9 * max(save_every, 1e-12)
    extra = sorted(float(s) for s in save_times)

    def next_frame(t_now):
        """The first frame time after ``t_now``: a multiple of ``save_every`` (counted from 0, so
        a run resumed from an extra frame keeps the same grid) or an extra time."""
        regular = save_every * (math.floor((t_now + eps) / save_every) + 1)
        return min([regular] + [s for s in extra if s > t_now + eps])

    if getattr(scheme, "dense", False):
        return _integrate_dense(
            evaluate,
            x,
            t0,
            t_end,
            dt0,
            scheme,
            save_every,
            on_frame,
            steady_tol,
            progress,
            guard,
            write_first,
            implicit,
            next_frame,
            stats,
            start,
            remesh,
            stop,
            restored,
        )

    next_save = next_frame(t0)

    def planned(dt):
        """The step the implicit solve is for: the scheme's step, not the one shortened to land on
        a frame (a shorter step than solved for is still damped, and the rate then depends only
        on the controller's step, which varies smoothly, not on where the frames fall)."""
        return dt if implicit else 0.0

    def solve(points, t_now, step):
        try:
            return evaluate(points, planned(step))
        except SolverError as exc:
            raise _which_solve(exc, t_now, step, implicit) from None

    ev = solve(x, t, dt)
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
        if stop is not None and (why := stop(t)) is not None:
            stats.stopped = why
            break
        h = min(dt, t_end - t, next_save - t)
        try:
            res = scheme.step(ev, h)
        except SolverError as exc:
            raise guard.failed_solve(_which_solve(exc, t, h, True), ev) from None
        stats.solves += res.solves
        if not res.accepted:
            stats.rejected += 1
            dt = res.dt_next
            continue
        guard.check(t + res.dt, res.dt, x.points, res.points, ev, ev.edge_length)
        x, t = res.state, t + res.dt  # the scheme may take a shorter step than offered
        stats.steps += 1
        if remesh is not None:
            started = _time.perf_counter()
            new = remesh(x, t)
            if new is not None:
                x = new
                scheme.restart()
                guard.new_mesh(new.faces)
                stats.remeshes += 1
            stats.remesh_wall += _time.perf_counter() - started
        if scheme.adaptive and res.dt_next is not None:
            # keep the controller's proposal, not the step shortened to reach a frame time
            dt = res.dt_next if res.dt >= dt * (1 - 1e-12) else max(dt, res.dt_next)
            dt = min(dt, scheme.dt_cap)
        ev = solve(x, t, dt)
        stats.solves += 1
        if t >= next_save - eps or t >= t_end - eps:
            on_frame(t, ev, dt, final=t >= t_end - eps)
            next_save = next_frame(t)
    stats.wall = _time.perf_counter() - start
    stats.t = t
    return stats


def _integrate_dense(
    evaluate,
    x,
    t0,
    t_end,
    dt0,
    scheme,
    save_every,
    on_frame,
    steady_tol,
    progress,
    guard,
    write_first,
    implicit,
    next_frame,
    stats,
    start,
    remesh=None,
    stop=None,
    restored=None,
) -> RunStats:
    """:func:`integrate` for a scheme that steps on its own and interpolates its frames (module
    docstring): one solve at ``t0`` (the start), then the scheme's steps, each frame time passed
    on the way written from the scheme's ``interpolate``. A remeshing comes after the frames of
    the step (interpolated on the mesh they were computed on); the scheme then starts again from a
    solve on the new mesh, with its Euler start of the first ``dt0``."""
    t, dt = t0, dt0
    eps = 1e-9 * max(save_every, 1e-12)
    if restored is not None:  # the history's newest state, solved for the diagnostics it lends
        dt = restored[1]
        x = State(np.asarray(restored[0][f"{int(restored[0]['n']) - 1}__points"]), x.fields, x.faces)
    try:
        ev = evaluate(x, scheme.start_step(dt) if implicit else 0.0)  # the solve the start steps with
    except SolverError as exc:
        raise _which_solve(exc, t, dt, implicit) from None
    stats.solves += 1
    if restored is not None:
        t = scheme.restore(restored[0], x.faces, ev)
        x, ev = scheme.history[-1][1], scheme.last_evaluation
    else:
        scheme.start(t, ev)
    if write_first:
        on_frame(t, ev, dt, final=False)
    next_save = next_frame(t0)
    while True:
        if progress is not None:
            progress(t, ev, dt, stats)
        if t >= t_end - eps:
            break
        if steady_tol > 0 and float(np.max(np.abs(ev.normal_speed))) < steady_tol:
            stats.stopped = "steady"
            break
        if stop is not None and (why := stop(t)) is not None:
            stats.stopped = why
            break
        h = min(dt, t_end - t)
        try:
            res = scheme.step(ev, h)
        except SolverError as exc:
            raise guard.failed_solve(_which_solve(exc, t, h, True), ev) from None
        stats.solves += res.solves
        if not res.accepted:
            stats.rejected += 1
            dt = res.dt_next
            continue
        ev_step = scheme.last_evaluation
        guard.check(t + res.dt, res.dt, x.points, res.points, ev_step, ev_step.edge_length)
        t_new = t + res.dt
        dt = res.dt_next if res.dt_next is not None else dt
        final = t_new >= t_end - eps
        while next_save <= t_new + eps or (final and next_save < math.inf):
            tf = min(next_save, t_new)
            on_frame(tf, scheme.interpolate(tf), dt, final=final and tf >= t_new - eps)
            if tf >= t_new - eps:
                break
            next_save = next_frame(tf)
        next_save = next_frame(t_new) if next_save <= t_new + eps else next_save
        x, t, ev = res.state, t_new, ev_step
        stats.steps += 1
        if remesh is not None and not final:
            started = _time.perf_counter()
            new = remesh(x, t)
            if new is not None:
                x, dt = new, min(dt, dt0)
                try:
                    ev = evaluate(x, scheme.start_step(dt) if implicit else 0.0)
                except SolverError as exc:
                    raise _which_solve(exc, t, dt, implicit) from None
                stats.solves += 1
                scheme.start(t, ev)
                guard.new_mesh(new.faces)
                stats.remeshes += 1
            stats.remesh_wall += _time.perf_counter() - started
    stats.wall = _time.perf_counter() - start
    stats.t = t
    return stats


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
