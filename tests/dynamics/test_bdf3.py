"""The third-order scheme ``bdf3`` (cortex_ti.dynamics.bdf3, docs/derivations/time_schemes.md, "Third order").

Truths used: BDF3 is exact on cubics for any step ratios; its constant-step coefficients and error
constants in closed form (derived in the derivation page); the exact solution of a nonlinear scalar
equation with an implicit and an extrapolated part (order 3 by step halving, the error estimate
against the true local error of one step); on the cortex, the exact exponential decay of a uniform
myosin excess by turnover on the sphere (a uniform tension drives no flow, so the field's mean
obeys dc/dt = -k (c - c0) exactly in space). The resume check compares a run with another run of
the same code and is named so.
"""

import math

import numpy as np
import pytest

from cortex_ti.dynamics.bdf3 import BDF3, bdf3_coefficients, bdf3_error_constant
from cortex_ti.dynamics.integrate import integrate
from cortex_ti.dynamics.schemes import SCHEMES
from cortex_ti.dynamics.state import State
from tests.dynamics.test_bdf2 import Scalar

Z = np.array([[0.0, 0.0, 1.0]])


def run_scalar(model, x0, t_end, h, dt0):
    """Steps growing from ``dt0`` (the start) to ``h`` (an unreachable tolerance, ``dt_max = h``); the end value."""
    scheme = BDF3(model, tol=1e9, dt_max=h)
    out = {}

    def on_frame(t, ev, dt, final=False):
        out[round(t, 9)] = float(ev.points[0, 2])

    integrate(model, State(x0 * Z), 0.0, t_end, dt0, scheme, t_end, on_frame, implicit=True)
    return out[round(t_end, 9)]


@pytest.mark.parametrize("ratios", [(1.0, 1.0), (0.3, 1.4), (1.4, 0.5), (0.2, 0.2)])
def test_variable_step_coefficients_are_exact_on_cubics(ratios):
    """x_{n+1} = a0 x_n + a1 x_{n-1} + a2 x_{n-2} + gamma x'(t_{n+1}) for x = 1 + 2 t - 3 t^2 + 5 t^3."""
    h = 0.1
    h1 = h / ratios[0]
    h2 = h1 / ratios[1]
    a0, a1, a2, gamma = bdf3_coefficients(h, h1, h2)

    def x(t):
        return 1 + 2 * t - 3 * t**2 + 5 * t**3

    t1 = 0.7
    lhs = a0 * x(t1 - h) + a1 * x(t1 - h - h1) + a2 * x(t1 - h - h1 - h2) + gamma * (2 - 6 * t1 + 15 * t1**2)
    assert lhs == pytest.approx(x(t1), abs=1e-12)
    assert a0 + a1 + a2 == pytest.approx(1.0, abs=1e-14)


def test_constant_step_values_of_the_derivation():
    """(18, -9, 2, 6 h) / 11 and the estimate's factor max(3/25, 9/13) (derivation, "Third order")."""
    assert np.allclose(bdf3_coefficients(1.0, 1.0, 1.0), np.array([18, -9, 2, 6]) / 11, atol=1e-14)
    assert bdf3_error_constant(1.0, 1.0, 1.0, 1.0) == pytest.approx(9 / 13, abs=1e-14)
    assert SCHEMES["bdf3"].explicit_interval == pytest.approx(20 / 21)


def test_explicit_interval_is_where_a_root_leaves_the_unit_disc():
    """The extrapolated BDF3 on x' = -lam x (x* the quadratic extrapolation) at a constant step: the
    roots of (11/6) r^3 - 3 r^2 + (3/2) r - 1/3 + z (3 r^2 - 3 r + 1) = 0 stay in the unit disc up to
    z = lam h = 20/21 and not beyond (the same scheme stepped on the scalar equation decays and grows)."""
    for z, stable in ((0.98 * 20 / 21, True), (1.02 * 20 / 21, False)):
        roots = np.roots([11 / 6, -3 + 3 * z, 1.5 - 3 * z, -1 / 3 + z])
        assert (np.abs(roots).max() < 1.0) == stable
        end = run_scalar(Scalar(lambda x, z=z: -z * x, 0.0), 1.0, 300.0, 1.0, 0.05)
        assert (abs(end) < 1e-3) == stable and (abs(end) > 1.0) != stable, end


def test_order_three_by_step_halving_on_a_nonlinear_equation():
    """dx/dt = -x^2 - beta x (beta = 4 implicit, -x^2 at the extrapolated state) from x = 1:
    x(t) = beta / ((beta + 1) e^(beta t) - 1). With the start's steps small (dt0 = h^2 / 2: its Euler
    errors are O(h^4)), the error at t = 1 falls 8x per halving of the step (third order)."""
    beta = 4.0

    def exact(t):
        return beta / ((beta + 1.0) * math.exp(beta * t) - 1.0)

    model = Scalar(lambda x: -(x**2), beta)
    errors = [abs(run_scalar(model, 1.0, 1.0, h, h * h / 2) - exact(1.0)) for h in (0.04, 0.02, 0.01)]
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(7.0 < r < 9.2 for r in ratios), (ratios, errors)


@pytest.mark.parametrize(
    "split",
    [
        ("implicit", lambda x: 0.0 * x, 4.0, lambda t: math.exp(-4.0 * t), (9 / 13) * (25 / 22) / (3 / 22)),
        ("explicit", lambda x: -4.0 * x, 0.0, lambda t: math.exp(-4.0 * t), 1.0),
        ("mixed", lambda x: -(x**2), 4.0, lambda t: 4.0 / (5.0 * math.exp(4.0 * t) - 1.0), None),
    ],
    ids=lambda s: s[0],
)
def test_error_estimate_sees_the_local_error_of_every_part(split):
    """One step of 0.02 from exact past states: the estimate is never below the true local error;
    for the pure splits their leading-order ratio from the derivation (implicit: (9/13)(25/22) /
    (3/22) = 5.77; explicit: 1) within 15 %."""
    _, g, beta, exact, ratio = split
    model = Scalar(g, beta)
    h = 0.02
    scheme = BDF3(model, tol=1e9, dt_max=h)
    scheme.history = [(t, State(exact(t) * Z), model(State(exact(t) * Z))) for t in (0.1, 0.12, 0.14, 0.16)]
    res = scheme.step(None, h)
    true_error = abs(float(res.points[0, 2]) - exact(0.18))
    assert res.error >= true_error
    if ratio is not None:
        assert res.error / true_error == pytest.approx(ratio, rel=0.15)


def test_controller_meets_the_tolerance_with_fewer_steps_than_bdf2():
    """Adaptive run of dx/dt = -x^2 - 4 x (a contraction) to t = 1: the end error is below
    steps x tol and falls with the tolerance; at the same end error bdf3 takes fewer steps than bdf2."""
    from cortex_ti.dynamics.schemes import BDF2

    beta = 4.0
    exact = beta / ((beta + 1.0) * math.exp(beta) - 1.0)

    def adaptive(cls, tol):
        model = Scalar(lambda x: -(x**2), beta)
        end: dict = {}
        stats = integrate(
            model, State(Z.copy()), 0.0, 1.0, 1e-4, cls(model, tol=tol, dt_max=1.0), 1.0,
            lambda t, ev, dt, final=False: end.update(x=float(ev.points[0, 2])),
        )  # fmt: skip
        return abs(end["x"] - exact), stats.steps

    (e5, n5), (e8, n8) = adaptive(BDF3, 1e-5), adaptive(BDF3, 1e-8)
    assert e5 < n5 * 1e-5 and e8 < n8 * 1e-8 and e8 < 0.01 * e5
    e2, n2 = adaptive(BDF2, 1e-8)
    assert e2 > 0.3 * e8 and n2 > 1.5 * n8, (e2, n2, e8, n8)


@pytest.mark.slow
def test_a_resumed_run_is_the_uninterrupted_one(tmp_path):
    """A regression check (the code against another run of itself): furrow_p4_a1 with bdf3 at 162
    nodes to t = 1, and the same run killed (no clean-up) once its frame at t = 0.5 is written, then
    resumed: the saved step history (four states, their solves, the proposed step) makes the resumed
    run the same computation, every frame equal to the uninterrupted run's to 1e-12 (the factorisation
    not reused across solves, as in test_bdf2)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    from cortex_ti.io import load_trajectory
    from cortex_ti.io.trajectory import committed_frames, partial_path
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.simulation.run import history_path
    from tests.dynamics.test_bdf2 import _KILLED_AT_T

    sets = ["mesh.nodes=162", "time.save_every=0.25", "time.t_end=1.0", "solver.reuse=false", "time.scheme=bdf3"]
    whole, out = tmp_path / "whole.h5", tmp_path / "resumed.h5"
    Simulation(load_scene("furrow_p4_a1", sets)).run(whole, progress=False)
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    child = subprocess.run(
        [sys.executable, "-c", _KILLED_AT_T, str(out), "0.5", *sets], env=env, capture_output=True, text=True
    )
    assert child.returncode == 9, child.stderr
    assert committed_frames(partial_path(out)) == (3, 0.5)
    with np.load(history_path(out)) as saved:
        assert int(saved["n"]) == 4  # the four states of a BDF3 step
    Simulation(load_scene("furrow_p4_a1", sets)).run(out, resume=True, progress=False)
    a, b = load_trajectory(whole), load_trajectory(out)
    np.testing.assert_array_equal(a.time.values, b.time.values)
    assert float(np.abs(a.points.values - b.points.values).max()) <= 1e-12
    assert float(np.abs(a.velocity.values - b.velocity.values).max()) <= 1e-12


def test_order_three_on_the_cortex_a_uniform_myosin_excess_decays_as_its_exponential():
    """A uniform myosin excess 0.5 on the 162-node sphere with turnover k = 1 (no other active stress):
    a uniform tension drives no flow, so the mean obeys dc/dt = -k (c - c0) exactly in space and is
    c0 + 0.5 e^(-k t). Stepped by bdf3 through the cortex's own solves and field transport (steps
    growing from h^2 / 2 to h), the error of the mean at t = 2 falls 8x per halving of h (third order:
    measured 7.75 and 7.9 for h = 0.1, 0.05, 0.025); the shape stays put and the field uniform."""
    from cortex_ti.dynamics.schemes import make_scheme
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation.core import Simulation
    from cortex_ti.surface.transport import dual_areas

    excess, t_end = 0.5, 2.0
    initial = f"[{{type: harmonics, terms: [{{l: 0, m: 0, coeff: {excess * math.sqrt(4 * math.pi)}}}]}}]"
    sets = ["mesh.nodes=162", "active_stress=[]", "fields.myosin.c0=1.0", "fields.myosin.turnover=1.0"]
    sim = Simulation(load_scene("furrow_p4_a1", [*sets, f"fields.myosin.initial={initial}"]))
    errors = []
    for h in (0.1, 0.05, 0.025):
        end = {}
        scheme = make_scheme("bdf3", sim.evaluate, tol=1e9, dt_max=h, implicit=True)

        def frame(t, ev, dt, final=False, end=end):
            end["s"] = ev.state

        integrate(sim.evaluate, sim.state0, 0.0, t_end, h * h / 2, scheme, t_end, frame, implicit=True)
        s = end["s"]
        c, a = s.fields["myosin"], dual_areas(s.points, s.faces)
        errors.append(abs(float(np.sum(c * a) / np.sum(a)) - (1.0 + excess * math.exp(-t_end))))
        assert np.ptp(c) < 1e-6 and np.abs(s.points - sim.state0.points).max() < 1e-6
    ratios = [errors[0] / errors[1], errors[1] / errors[2]]
    assert all(7.0 < r < 9.0 for r in ratios), (ratios, errors)


def test_frames_are_the_cubic_through_the_last_four_states():
    """Steps of 0.05 (from a start at 1e-3) and frames every 0.01 on dx/dt = -x: every frame lands on
    its time, and between two steps it is off e^-t by at most the larger of the two steps' own errors
    plus 1e-6: the cubic through the last four states adds at most h^4 / 24 |x''''| = 2.6e-7 between
    the steps, where a quadratic through three would add up to 0.064 h^3 |x'''| (3-8e-6 here)."""
    steps = []

    class Recording(BDF3):
        def _accept(self, t, state, ev):
            steps.append((t, abs(float(state.points[0, 2]) - math.exp(-t))))
            super()._accept(t, state, ev)

    model = Scalar(lambda x: -x, 0.0)
    frames = {}
    integrate(
        model, State(Z.copy()), 0.0, 1.0, 1e-3, Recording(model, tol=1e9, dt_max=0.05), 0.01,
        lambda t, ev, dt, final=False: frames.update({t: abs(float(ev.points[0, 2]) - math.exp(-t))}),
    )  # fmt: skip
    times = np.array(sorted(frames))
    assert len(times) == 101 and np.allclose(times, np.linspace(0.0, 1.0, 101), atol=1e-12)
    for (ta, ea), (tb, eb) in zip([(0.0, 0.0), *steps[:-1]], steps, strict=True):
        inside = [frames[t] for t in times if ta < t < tb]
        assert all(e <= max(ea, eb) + 1e-6 for e in inside), (ta, tb, ea, eb, inside)
