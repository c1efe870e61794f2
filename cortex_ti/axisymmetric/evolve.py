r"""Shape evolution of the axisymmetric cortex: the material points move with ``v_n n``.

The state is the node positions ``(r, z)`` (``lagrangian``: the nodes are the normally moving
material points, label fixed) or ``(r, z, u)`` (``arclength``: nodes kept equidistant in arc
length, carrying the material label; ``adaptive``: the same, the spacing following a monitor of
curvature, label stretch and tension gradient). The time stepping is scipy's Radau IIA (or BDF) with
error control on the node positions and an exact Jacobian (complex step through one
linearised solve): the normal modes are stiff (rates growing like l^2, bounded by the bending
viscosity), which an L-stable implicit scheme takes in its stride.

This module is the driver (:func:`simulate`: checks, the integration loop, its stops and
failures); the right-hand side and its Jacobian are in :mod:`~cortex_ti.axisymmetric.dynamics`,
what a run returns in :mod:`~cortex_ti.axisymmetric.result`. The names of ``__all__`` defined
there are still importable from here.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import numpy as np
from scipy.integrate import BDF, Radau

from .balance import (
    ForceBalance,
    ZetaFn,
    check_gauge,
    check_n,
    check_visc,
    eval_zeta,
    is_symmetric,
)
from .dynamics import (
    STRETCH_LIMIT,
    ArrayF,
    Dynamics,
    bending_margin,
    first_unresolved,
    full_meridian_dynamics,
    label_matters,
    meridian_neck,
    normal_embedding,
)
from .myosin import Myosin
from .result import SimulationResult, build_result, revolve
from .spectral import Spectral

__all__ = [
    "SimulationResult",
    "simulate",
    "revolve",
    "full_meridian_dynamics",
    "normal_embedding",
    "STRETCH_LIMIT",
    "first_unresolved",
    "label_matters",
]


def simulate(
    zeta: ZetaFn,
    *,
    eta_s: float,
    eta_b: float,
    eta_bar: float,
    eta_bar_b: float,
    radius: float = 1.0,
    t_end: float,
    save_times: Sequence[float] | None = None,
    n: int = 48,
    rtol: float = 1e-10,
    atol: float | None = None,
    symmetric: bool | None = None,
    parametrization: str = "auto",
    gauge: str = "velocity",
    method: str = "Radau",
    interpolate: bool = False,
    max_steps: int = 100000,
    tension: str = "nodes",
    monitor: float = 0.0,
    stop_neck: float | None = None,
    stop_ill_posed: bool = True,
    myosin: Myosin | None = None,
    bending_form: str = "paper",
    kappa: float = 0.0,
    spontaneous_curvature: float = 0.0,
    on_save=None,
    start: tuple[float, ArrayF] | None = None,
    fluids=None,
) -> SimulationResult:
    """Evolve the cortex from the sphere of radius ``radius`` with ``dX/dt = v_n n``.

    Parameters
    ----------
    zeta : callable
        Active tension as a function of the initial polar angle theta0 in [0, pi] (units of
        zeta_0), vectorised or scalar.  Carried by the normally moving material points.  For
        spectral accuracy it should be smooth on the sphere (even about the poles).
    eta_s, eta_b, eta_bar, eta_bar_b : float
        Shear (> 0), bulk (>= 0) and bending (>= 0) viscosities (units eta_s, eta_s R0^2).
    radius : float
        Initial radius (R0).
    t_end : float
        Final time (t_a).
    save_times : sequence of float, optional
        Sorted times in [0, t_end] at which to save (default ``[0, t_end]``).
    n : int
        Collocation points on the half meridian (symmetric) or on the full meridian.
    rtol, atol : float
        Tolerances of the stiff integrator on the node positions (atol default ``rtol * radius``).
    symmetric : bool or None
        Solve only [0, pi/2] using the up-down symmetry (None: detect ``zeta(pi-t) == zeta(t)``).
    parametrization : {'auto', 'lagrangian', 'arclength', 'adaptive'}
        ``lagrangian``: nodes are the normally moving material points (state r, z).
        ``arclength``: nodes stay equidistant in arc length and carry the material label
        (state r, z, u); needed when the material points cluster (e.g. a drifting non-symmetric
        pattern).  ``adaptive``: like ``arclength``, but the nodes equidistribute
        ``sqrt(1 + a^2 (k1^2 + k2^2) + b^2 (d ln|dX/du|/ds)^2 + c^2 (dzeta/ds / range)^2)``
        (``ADAPT_*``), so a closing neck, the flanks of its stretched label map and the
        tension's fronts keep their points: deep glued furrows converge to a neck of 0.1 R0
        (docs/validation/constriction.md).  ``auto``: lagrangian with symmetry, arclength
        without.
    gauge : {'velocity', 'centroid'}
        Full meridian only (irrelevant with symmetry): the rigid axial translation is fixed by
        ``oint v_z dA = 0`` (default, the 3D code's convention) or by ``oint z v_n dA = 0``
        (the enclosed volume's centroid stays put).  With normal-only point motion the choice
        changes which material point sits where, hence the dynamics of a non-symmetric pattern.
    method : {'Radau', 'BDF'}
        scipy's implicit integrator (with the exact complex-step Jacobian).
    interpolate : bool
        Save via the integrator's dense output instead of stopping exactly at each save time
        (cheaper with many save times; its interpolation error is measured in REPORT.md).
    max_steps : int
        Abort with ValueError after this many steps.
    tension : {'nodes', 'material'}
        ``nodes``: the tension stays on the normally moving points (the paper's). ``material``: it
        is carried by the cortex's full velocity, ``dzeta/dt = 0`` following material points
        (the state then carries the material label of every node, Sec. 9 of the derivation).
    monitor : float
        Arc-length mode only: > 0 places the nodes by equidistributing
        ``h sqrt(1 + monitor^2 (k1^2 + k2^2))`` instead of the arc length, so a closing neck
        keeps its share of them (Sec. 11).
    stop_neck : float or None
        Stop cleanly (keeping the frames so far, plus one at the time of the crossing) when the
        neck radius falls to this value (R0); ``SimulationResult.stopped`` says so.
    stop_ill_posed : bool
        With bending viscosity, stop cleanly the same way when ``2 eta_bar k_i + (eta_bar_b -
        eta_bar) C`` (i = 1, 2) falls to 0 at a node: past it the bending-viscosity normal force
        amplifies short waves instead of damping them and the model has no converged solution
        (derivation, Sec. 12). Off, the run goes on until the integrator fails.
    myosin : Myosin or None
        A myosin density carried by the full velocity, diffusing and turning over, whose tension
        ``zeta(c)`` adds to ``zeta`` (:mod:`cortex_ti.axisymmetric.myosin`); the up-down symmetry
        is used only if its initial density has it too.
    bending_form : "paper" (Eq. 45, the default) or "dissipation": the bending viscosity's normal
        force as the 3D formulations ``rayleigh_p1`` and ``rayleigh_p2`` integrate it, the force of
        ``1/2 int B^cd d_c v_n d_d v_n dA``; the two differ by ``(nabla_c beta^cd) d_d v_n``, zero on
        a sphere (:class:`~cortex_ti.axisymmetric.balance._Physics`).
    kappa, spontaneous_curvature : float
        Helfrich bending rigidity (>= 0, eta_s R0^2 / t_a) and spontaneous curvature c0 (1/R0, ``C = 2/R``
        on a sphere): the normal force of ``kappa/2 oint (C - c0)^2 dA`` (:mod:`cortex_ti.axisymmetric.rigidity`).
    on_save : callable or None
        ``on_save(frame, y)`` as each save time is reached (before the next step): ``frame`` the
        :class:`SimulationResult` of that one frame (its statistics zero), ``y`` the integrator's
        state there, from which ``start`` continues. A run writes its frames as they come.
    start : (t, y) or None
        Continue from the state ``y`` at time ``t`` (an earlier run's ``on_save``) instead of the
        sphere at t = 0; only the save times after ``t`` are saved. The integrator starts afresh
        there, so the continued run agrees with the uninterrupted one to its tolerance, not to
        round-off.
    fluids : AxisymmetricFluids or None
        A cytoplasm and a medium as Stokes fluids (:mod:`cortex_ti.axisymmetric.fluids`); they fix
        the translation, so ``gauge`` is not used.

    Returns
    -------
    SimulationResult

    Raises
    ------
    ValueError
        Bad input, singular force balance, or integrator failure (one-line message).
    """
    phys = check_visc(
        eta_s, eta_b, eta_bar, eta_bar_b, radius, bending_form=bending_form, kappa=kappa, c0=spontaneous_curvature
    )
    n = check_n(n)
    R = float(radius)
    st, atol = _check_times(t_end, save_times, rtol, atol, R)
    if method not in ("Radau", "BDF"):
        raise ValueError(f"method must be 'Radau' or 'BDF', got {method!r}")
    if parametrization not in ("auto", "lagrangian", "arclength", "adaptive"):
        raise ValueError(
            f"parametrization must be 'auto', 'lagrangian', 'arclength' or 'adaptive', got {parametrization!r}"
        )
    if tension not in ("nodes", "material"):
        raise ValueError(f"tension must be 'nodes' or 'material', got {tension!r}")
    if not (isinstance(monitor, (int, float)) and math.isfinite(monitor) and monitor >= 0):
        raise ValueError(f"monitor must be a finite number >= 0, got {monitor!r}")
    if stop_neck is not None and not (isinstance(stop_neck, (int, float)) and 0 < stop_neck < radius):
        raise ValueError(f"stop_neck must lie in (0, radius), got {stop_neck!r}")
    eval_zeta(zeta, np.linspace(0.0, np.pi, 7))
    if myosin is not None and not isinstance(myosin, Myosin):
        raise ValueError(f"myosin must be a Myosin or None, got {type(myosin).__name__}")
    # up-down symmetric problems do not translate; the others' node rates are filtered (dynamics.FILTER_STRENGTH)
    mirror_symmetric = is_symmetric(zeta) and (myosin is None or myosin.symmetric())
    mirror_symmetric = mirror_symmetric and (fluids is None or fluids.symmetric)
    if symmetric is None:
        symmetric = mirror_symmetric
    if parametrization == "auto":
        parametrization = "lagrangian" if symmetric else "arclength"
    if monitor and parametrization != "arclength":
        raise ValueError("monitor needs parametrization = 'arclength' (the nodes must be free to move tangentially)")
    sp = Spectral(n, symmetric)
    dyn = (Dynamics if fluids is None else _fluid_dynamics(fluids))(
        sp,
        ForceBalance(sp, phys, check_gauge(gauge)),
        zeta,
        parametrization,
        carried=tension == "material",
        monitor=monitor,
        myosin=myosin,
        filtered=not mirror_symmetric,
    )
    y0 = [R * np.sin(sp.u), R * np.cos(sp.u)] + ([sp.u.copy()] if dyn.labelled else [])
    if myosin is not None:  # q = c r h on the sphere (h = R)
        y0.append(myosin.density(sp.u) * R * np.sin(sp.u) * R)
    y0 = np.concatenate(y0)  # on the sphere the monitor is uniform: the nodes start equidistributed
    t_start = 0.0
    if start is not None:
        t_start, y_start = float(start[0]), np.asarray(start[1], dtype=float)
        if y_start.shape != y0.shape or not (0.0 <= t_start <= t_end):
            raise ValueError(
                f"cannot continue from a state of size {y_start.size} at t = {t_start:g}: this run's state has size "
                f"{y0.size} (n, symmetry, parametrization, tension and myosin must agree) and ends at {t_end:g}"
            )
        y0, st = y_start.copy(), st[st > t_start + 1e-12 * max(1.0, t_end)]
    stops = {}
    if stop_neck is not None:
        stops["neck"] = lambda y: meridian_neck(dyn, y) - stop_neck
    if stop_ill_posed and phys.bending:
        stops["bending"] = lambda y: bending_margin(phys, sp, y)
    params = dict(
        eta_s=phys.eta_s,
        eta_b=phys.eta_b,
        eta_bar=phys.eta_bar,
        eta_bar_b=phys.eta_bar_b,
        radius=R,
        n=n,
        rtol=rtol,
        atol=atol,
        symmetric=symmetric,
        method=method,
        parametrization=parametrization,
        gauge=gauge,
        interpolate=interpolate,
        tension=tension,
        monitor=monitor,
        stop_neck=stop_neck,
        stop_ill_posed=stop_ill_posed,
        myosin=None if myosin is None else {k: v for k, v in vars(myosin).items() if k != "initial"},
    )
    if fluids is not None:
        params["fluids"] = fluids.as_dict()
    if phys.kappa:
        params.update(kappa=phys.kappa, spontaneous_curvature=phys.c0)

    def hook(t, y):
        if on_save is not None:
            on_save(build_result(dyn, [(t, y)], R, dict(_NO_STATS), params), y)

    t0 = time.perf_counter()
    failure = None
    try:
        with _one_blas_thread():
            saved, nsteps, nlu, stopped = _integrate(
                dyn,
                y0,
                st,
                float(t_end),
                Radau if method == "Radau" else BDF,
                rtol,
                atol,
                interpolate,
                max_steps,
                stops,
                t_start=t_start,
                hook=hook,
            )
    except _Failed as exc:
        if not exc.saved:
            raise ValueError(str(exc)) from None
        (failure, saved, nsteps, nlu), stopped = exc.args, f"failed: {exc.args[0]}"
    stats = dict(wall_time=time.perf_counter() - t0, n_rhs=dyn.nrhs, n_steps=nsteps, n_jac=dyn.njac, n_lu=nlu)
    out = build_result(dyn, saved, R, stats, params)
    out.stopped = stopped
    if failure is not None:
        raise StepFailed(failure, out)
    return out


def _fluid_dynamics(fluids):
    """The dynamics class with the fluids bound (:class:`~cortex_ti.axisymmetric.fluids.FluidDynamics`)."""
    from functools import partial

    from .fluids import FluidDynamics

    return partial(FluidDynamics, fluids=fluids)


class StepFailed(ValueError):
    """The integrator failed at a step (one-line message); ``result`` holds the frames saved
    before it (``stopped``: ``'failed: ...'``), so a run can keep them."""

    def __init__(self, message: str, result: SimulationResult):
        super().__init__(message)
        self.result = result


class _Failed(Exception):
    """Inside :func:`_integrate`: a step failed; args ``(message, saved, steps, LU factorisations)``."""

    @property
    def saved(self):
        return self.args[1]


def _check_times(t_end, save_times, rtol, atol, R) -> tuple[ArrayF, float]:
    """The save times (default ``[0, t_end]``) and ``atol`` (default ``rtol R``), checked."""
    for name, val in (("t_end", t_end), ("rtol", rtol)):
        if (
            isinstance(val, bool)
            or not isinstance(val, (int, float, np.floating, np.integer))
            or not math.isfinite(val)
            or val <= 0
        ):
            raise ValueError(f"{name} must be a finite number > 0, got {val!r}")
    atol = rtol * R if atol is None else atol
    if (
        isinstance(atol, bool)
        or not isinstance(atol, (int, float, np.floating))
        or not math.isfinite(atol)
        or atol <= 0
    ):
        raise ValueError(f"atol must be a finite number > 0, got {atol!r}")
    try:
        st = np.asarray([0.0, float(t_end)] if save_times is None else save_times, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ValueError("save_times must be a sequence of numbers") from None
    if (
        st.size == 0
        or not np.all(np.isfinite(st))
        or np.any(st < 0)
        or np.any(st > t_end * (1 + 1e-12))
        or np.any(np.diff(st) < 0)
    ):
        raise ValueError("save_times must be finite, sorted and within [0, t_end]")
    return st, atol


def _crossing(solver, t_old: float, stop) -> tuple[float, ArrayF]:
    """Time and state at which ``stop`` (> 0 before, <= 0 after the last step) crosses zero, on
    the step's dense output."""
    from scipy.optimize import brentq

    dense = solver.dense_output()
    if not math.isfinite(stop(dense(t_old))):  # no neck yet at the step's start: find where one forms
        a, b = t_old, solver.t
        for _ in range(60):
            mid = 0.5 * (a + b)
            a, b = (mid, b) if not math.isfinite(stop(dense(mid))) else (a, mid)
        t_old = b
    if stop(dense(t_old)) <= 0.0:
        return t_old, np.asarray(dense(t_old))
    ts = brentq(lambda t: stop(dense(t)), t_old, solver.t, xtol=1e-12, rtol=1e-12)
    return float(ts), np.asarray(dense(ts))


_STOP_MESSAGES = {
    "neck": "neck {neck:.4g} R0 at t={t:.6g}",
    "bending": "ill-posed at t={t:.6g}: the bending-viscosity normal force lost its sign on the meridian "
    "(2 eta_bar k_i + (eta_bar_b - eta_bar) C = 0; neck {neck:.4g} R0)",
}


class _Saved(list):
    """The saved ``(t, y)`` of :func:`_integrate`, each also handed to ``hook(t, y)`` as it comes."""

    def __init__(self, hook=None):
        super().__init__()
        self.hook = hook

    def append(self, item) -> None:
        super().append(item)
        if self.hook is not None:
            self.hook(*item)


_NO_STATS = dict(wall_time=0.0, n_rhs=0, n_steps=0, n_jac=0, n_lu=0)


def _one_blas_thread():
    """One BLAS thread while the model integrates: its dense matrices are small (the Jacobian's
    batched products, a few hundred rows), and OpenBLAS's threads cost more than they bring there:
    on the 2-core machine with its cores busy, a (96, 48) complex product took 8 ms with OpenBLAS's
    default two threads and 0.09-0.2 ms on one (the threads spin), and the axisymmetric cut's test
    16 CPU s against 5.6. ``threadpoolctl`` sets it for the BLAS libraries NumPy and SciPy loaded,
    and restores it afterwards."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def _integrate(dyn, y0, st, t_end, Solver, rtol, atol, interpolate, max_steps, stops=None, t_start=0.0, hook=None):
    """Step from ``t_start`` (0: the sphere) to the save times (or, with ``interpolate``, to
    ``t_end`` reading the dense output at the save times), or until one of ``stops`` (name -> f(y))
    falls to 0; ``hook(t, y)`` is called as each is saved. Returns ``(saved [(t, y)], steps, LU
    factorisations, why it stopped)``."""
    stops = stops or {}
    saved: list[tuple[float, ArrayF]] = _Saved(hook)
    nsteps = nlu = k = 0
    while k < st.size and st[k] <= t_start:
        saved.append((float(st[k]), y0.copy()))
        k += 1
    t, y = float(t_start), y0
    first = None
    while k < st.size:
        bound = t_end if interpolate else float(st[k])
        if bound <= t:  # repeated save time
            saved.append((float(st[k]), y.copy()))
            k += 1
            continue
        if first is not None:
            first = min(first, bound - t)
        try:
            solver = Solver(dyn.rhs, t, y, bound, rtol=rtol, atol=atol, jac=dyn.jac, first_step=first)
        except (ValueError, np.linalg.LinAlgError) as err:
            raise ValueError(f"integrator start failed at t={t:.6g}: {err}") from None
        while solver.status == "running":
            t_old = solver.t
            try:
                nsteps = _step(solver, nsteps, max_steps)
            except ValueError as err:
                raise _Failed(str(err), saved, nsteps, nlu + solver.nlu) from None
            hit = [(*_crossing(solver, t_old, f), name) for name, f in stops.items() if f(solver.y) <= 0.0]
            if hit:
                tc, yc, name = min(hit, key=lambda h: h[0])
                if interpolate:
                    k = _save_dense(solver, st[st < tc], k, saved)
                saved.append((tc, yc))
                why = _STOP_MESSAGES[name].format(neck=meridian_neck(dyn, yc), t=tc)
                return saved, nsteps, nlu + solver.nlu, why
            if interpolate:
                k = _save_dense(solver, st, k, saved)
        nlu += solver.nlu
        if not interpolate:
            saved.append((float(st[k]), solver.y.copy()))
            k += 1
        # continue with the step size the controller proposed (not the one truncated at the bound)
        first = float(getattr(solver, "h_abs", 0.0) or 0.0) or None
        t, y = solver.t, solver.y
    return saved, nsteps, nlu, "t_end"


def _step(solver, nsteps: int, max_steps: int) -> int:
    """One step of the scipy integrator, its failures as one-line ValueErrors."""
    t_old = solver.t
    try:
        msg = solver.step()
    except (ValueError, np.linalg.LinAlgError) as err:  # singular system inside a stage
        raise ValueError(f"integrator step failed at t={t_old:.6g}: {err}") from None
    if solver.status == "failed":
        raise ValueError(f"integrator step failed at t={solver.t:.6g}: {msg}")
    if nsteps + 1 > max_steps:
        raise ValueError(f"integrator exceeded max_steps={max_steps} at t={solver.t:.6g}")
    return nsteps + 1


def _save_dense(solver, st, k: int, saved: list) -> int:
    """Save the states at the save times the last step passed (dense output between steps)."""
    dense = None
    while k < st.size and st[k] <= solver.t:
        if st[k] == solver.t:
            saved.append((float(st[k]), solver.y.copy()))
        else:
            dense = dense or solver.dense_output()
            saved.append((float(st[k]), np.asarray(dense(st[k]))))
        k += 1
    return k
