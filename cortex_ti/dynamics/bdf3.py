r"""The third-order scheme ``bdf3``: variable-step, linearly implicit (extrapolated) BDF3.

The step of :class:`~cortex_ti.dynamics.schemes.BDF2` one order up (``docs/derivations/time_schemes.md``,
"Third order: bdf3"). From ``t_n`` with the steps ``h`` (this one), ``h1``, ``h2`` before it:

* the state is extrapolated on the quadratic through the last three states, ``S* = P2(t_{n+1})``
  (third-order close to ``x_{n+1}``), and the force balance solved there once, with the
  semi-implicit tension of step ``gamma`` (:func:`bdf3_coefficients`) centred on the rate
  ``r = (x* - a0 x_n - a1 x_{n-1} - a2 x_{n-2}) / gamma``, so that ``x_{n+1} - x* = gamma (w - r)``
  exactly, as for ``bdf2``;
* ``x_{n+1} = a0 x_n + a1 x_{n-1} + a2 x_{n-2} + gamma w_{n+1}``, the fields' stored quantities
  with the same coefficients and their diffusion and turnover implicit over ``gamma``
  (:meth:`State.combined <cortex_ti.dynamics.state.State.combined>`);
* the local error is estimated against the cubic through the last four states extrapolated to
  ``t_{n+1}`` (:func:`bdf3_error_constant`); the next step is ``h (tol / err)^(1/4)`` (times 0.9,
  within ``[0.2, 1.4] h``: ratios up to 1.4 keep variable-step BDF3 zero-stable, the derivation's
  "Step ratios"), at most ``dt_max``.

The start (the first steps, after a resume without the step history and after a remeshing) is
``bdf2``'s (two semi-implicit Euler steps of ``time.dt / 2``) and one ``bdf2`` step with its own
estimate; from four states on the steps are BDF3. Frames are the cubic through the last four states
(:meth:`BDF2.interpolate <cortex_ti.dynamics.schemes.BDF2.interpolate>` on the longer history), the
checkpoint the four states and their solves.
"""

from __future__ import annotations

import math

import numpy as np

from .schemes import BDF2, Evaluation, StepResult, _lagrange_at, register_scheme
from .state import State

__all__ = ["BDF3", "bdf_coefficients", "bdf3_coefficients", "bdf3_error_constant"]


def bdf_coefficients(steps) -> tuple[list[float], float]:
    """Variable-step BDF of order ``len(steps)``, the steps newest first (``h``, ``h1``, ...), as
    ``x_{n+1} = sum_j a_j x_{n-j} + gamma f(x_{n+1})``: returns ``([a_0, a_1, ...], gamma)``. The
    polynomial through ``x_{n+1}, x_n, ...`` whose slope at ``t_{n+1}`` is ``f``: ``gamma = 1 / l_0'``
    and ``a_j = -l_j' gamma`` with ``l_j'`` the slopes of the Lagrange basis at ``t_{n+1}``.

    >>> [round(c, 12) for c in bdf_coefficients([1.0, 1.0])[0]]  # bdf2: (4 x_n - x_{n-1}) / 3
    [1.333333333333, -0.333333333333]
    """
    times = [0.0]
    for h in steps:
        times.append(times[-1] - float(h))
    slopes = []
    for j, tj in enumerate(times):
        total = 0.0
        for m, tm in enumerate(times):
            if m != j:
                term = 1.0 / (tj - tm)
                for k, tk in enumerate(times):
                    if k not in (j, m):
                        term *= (0.0 - tk) / (tj - tk)
                total += term
        slopes.append(total)
    gamma = 1.0 / slopes[0]
    return [-s * gamma for s in slopes[1:]], gamma


def bdf3_coefficients(h: float, h1: float, h2: float) -> tuple[float, float, float, float]:
    """Variable-step BDF3 from ``x_{n-2}, x_{n-1}, x_n`` (steps ``h2``, ``h1``, then ``h``) as
    ``x_{n+1} = a0 x_n + a1 x_{n-1} + a2 x_{n-2} + gamma f(x_{n+1})``: ``(a0, a1, a2, gamma)``.

    >>> [round(11 * c, 12) for c in bdf3_coefficients(1.0, 1.0, 1.0)]  # (18, -9, 2, 6 h) / 11
    [18.0, -9.0, 2.0, 6.0]
    """
    (a0, a1, a2), gamma = bdf_coefficients([h, h1, h2])
    return a0, a1, a2, gamma


def bdf3_error_constant(h: float, h1: float, h2: float, h3: float) -> float:
    """The factor ``c`` of the estimate ``|local error| ~ c |x_{n+1} - x^P|``, ``x^P`` the cubic
    through the last four states at ``t_{n+1}``. Both are multiples of the fourth derivative; the
    local error lies between plain BDF3's (the flow all implicit) and that plus ``gamma`` times the
    quadratic extrapolation's error of ``x'''`` (the flow all at ``x*``); ``c`` is the larger ratio,
    each exact on the quartic ``t^4 / 24`` (docs/derivations/time_schemes.md, "Third order: bdf3").

    >>> round(bdf3_error_constant(1.0, 1.0, 1.0, 1.0), 12)  # constant step: max(3/25, 9/13)
    0.692307692308
    """
    t = [-h, -(h + h1), -(h + h1 + h2), -(h + h1 + h2 + h3)]  # t_{n+1} = 0
    a0, a1, a2, gamma = bdf3_coefficients(h, h1, h2)
    quartic = [ti**4 / 24.0 for ti in t]
    implicit = a0 * quartic[0] + a1 * quartic[1] + a2 * quartic[2]  # exact value 0, slope 0 at t = 0
    star = sum(w * ti**3 / 6.0 for w, ti in zip(_lagrange_at(t[:3], 0.0), t[:3], strict=True))
    explicit = implicit + gamma * star  # + gamma f'(x* - x(0)), f' x''' = x'''' on a linear flow
    pred = sum(w * q for w, q in zip(_lagrange_at(t, 0.0), quartic, strict=True))
    return max(abs(implicit) / abs(implicit - pred), abs(explicit) / abs(explicit - pred))


def _combination(parts) -> State:
    """``sum_k w_k S_k`` of positions and field values (a field glued to the nodes, one array in
    every state, kept), on the newest (last) state's mesh: the extrapolated state ``S*``."""
    newest = parts[-1][1]
    points = sum(w * st.points for w, st in parts)
    fields = {}
    for name, values in newest.fields.items():
        if all(st.fields.get(name) is values for _, st in parts):
            fields[name] = values
        else:
            fields[name] = sum(w * st.fields[name] for w, st in parts)
    return State(points, fields, newest.faces)


@register_scheme("bdf3")
class BDF3(BDF2):
    """Variable-step, linearly implicit (extrapolated) BDF3 with error control and dense output
    (module docstring)."""

    GROW = 1.4  # the largest step ratio: zero-stable (docs/derivations/time_schemes.md, "Step ratios")
    KEEP = 4
    #: at TOL_NODES (10242) nodes, scaled as 1 / N like bdf2's (1e-6 at 2562, 4e-6 at 642 nodes): a
    #: sixteenth of bdf2's, where bdf3's steps on the rayleigh_p2 furrow are set by accuracy; at bdf2's
    #: tolerances they are set by a stability limit of the late furrow and come out more than bdf2's
    #: (docs/validation/time_schemes.md, "bdf3 on the curved furrow")
    default_tol = 2.5e-7
    # extrapolated BDF3 on x' = -lam x (x* = 3 x_n - 3 x_(n-1) + x_(n-2)): at rho = -1 for lam dt = 20/21,
    # the first root to leave the unit disc (docs/derivations/time_schemes.md)
    explicit_interval = 20.0 / 21.0

    def step(self, ev: Evaluation, dt: float) -> StepResult:
        if len(self.history) < 4:  # the start: bdf2's two Euler steps, then one bdf2 step
            return super().step(ev, dt)
        (t_r, s_r, _), (t_q, s_q, _), (t_p, s_p, _), (t_n, s_n, _) = self.history[-4:]
        h1, h2, h3 = t_n - t_p, t_p - t_q, t_q - t_r
        a0, a1, a2, gamma = bdf3_coefficients(dt, h1, h2)
        weights = _lagrange_at([t_q, t_p, t_n], t_n + dt)
        star = _combination([(weights[0], s_q), (weights[1], s_p), (weights[2], s_n)])
        rate = (star.points - (a0 * s_n.points + a1 * s_p.points + a2 * s_q.points)) / gamma
        ev_new = self._solve(star, gamma, rate)
        new = State.combined([(a2, s_q), (a1, s_p), (a0, s_n)], gamma, ev_new.rates, ev_new.transport)
        if not np.all(np.isfinite(new.points)):
            err = math.inf
        else:
            cubic = _lagrange_at([t_r, t_q, t_p, t_n], t_n + dt)
            pred = sum(w * st.points for w, st in zip(cubic, (s_r, s_q, s_p, s_n), strict=True))
            c = bdf3_error_constant(dt, h1, h2, h3)
            err = c * float(np.max(np.linalg.norm(new.points - pred, axis=1)))
        return self._judge(err, dt, t_n, s_n, new, ev_new, 4)
