"""The one run loop (cortex_ti.dynamics.integrate) with its hooks in one object (RunHooks), for a
fixed-step and a dense scheme: frames on the frame grid, a remeshing that hands a new state back
(the scheme restarted), a stop hook ending the run. The truth is dx/dt = -x on one node: explicit
Euler at a fixed step h gives x_n = (1 - h)^n exactly."""

import numpy as np
import pytest
from test_bdf2 import Scalar, Z  # the one-node model of the bdf2 tests

from cortex_ti.dynamics.integrate import RunHooks, integrate
from cortex_ti.dynamics.schemes import make_scheme
from cortex_ti.dynamics.state import State


class Recorder(RunHooks):
    def __init__(self, remesh_at=(), stop_below=None):
        self.frames, self.remeshed, self.passes = {}, [], 0
        self.remesh_at, self.stop_below = list(remesh_at), stop_below

    def frame(self, t, ev, dt_next, final=False):
        self.frames[round(t, 9)] = float(ev.points[0, 2])

    def remesh(self, state, t):
        if self.remesh_at and t >= self.remesh_at[0] - 1e-12:
            self.remesh_at.pop(0)
            self.remeshed.append(t)
            return State(state.points.copy(), state.fields, state.faces)  # the same nodes, "a new mesh"
        return None

    def stop(self, t):
        if self.stop_below is not None and self.frames and list(self.frames.values())[-1] <= self.stop_below:
            return "neck"
        return None

    def progress(self, t, ev, dt, stats):
        self.passes += 1


def test_fixed_step_frames_remesh_and_stop():
    h, model = 0.01, Scalar(lambda x: -x, 0.0)
    hooks = Recorder(remesh_at=(0.05, 0.3), stop_below=0.5)
    stats = integrate(model, State(Z.copy()), 0.0, 2.0, h, make_scheme("euler", model), 0.1, hooks)
    # frames every 0.1 up to the first at or below 0.5: (1 - h)^70 = 0.495 at t = 0.7
    assert sorted(hooks.frames) == pytest.approx([0.1 * k for k in range(8)])
    for t, x in hooks.frames.items():
        assert x == pytest.approx((1 - h) ** round(t / h), rel=1e-12)
    assert stats.stopped == "neck" and stats.t == pytest.approx(0.7)
    assert stats.remeshes == 2 and hooks.remeshed == pytest.approx([0.05, 0.3])
    assert stats.steps == 70 and hooks.passes == stats.steps + 1


def test_dense_scheme_remeshes_and_interpolates_on_the_grid():
    """bdf2 (dense: frames interpolated): a remeshing restarts it from a solve on the new state; the
    frames stay on the grid and on the solution e^-t within the scheme's error."""
    model = Scalar(lambda x: -x, 0.0)
    hooks = Recorder(remesh_at=(0.5,))
    stats = integrate(model, State(Z.copy()), 0.0, 1.0, 0.05, make_scheme("bdf2", model, tol=1e-6), 0.1, hooks)
    assert sorted(hooks.frames) == pytest.approx([0.1 * k for k in range(11)])
    assert max(abs(x - np.exp(-t)) for t, x in hooks.frames.items()) < 1e-3
    assert stats.remeshes == 1 and stats.stopped == "t_end" and stats.t == pytest.approx(1.0)


def test_a_frame_function_is_the_frame_hook():
    """The older call: a frame function and the other hooks as keywords."""
    model, seen = Scalar(lambda x: -x, 0.0), []
    integrate(
        model,
        State(Z.copy()),
        0.0,
        0.2,
        0.01,
        make_scheme("euler", model),
        0.1,
        lambda t, ev, dt, final=False: seen.append(round(t, 9)),
        stop=lambda t: "neck" if t > 0.15 else None,
    )
    assert seen == [0.0, 0.1]
