"""Constriction to the end and pinch-off in the axisymmetric model with bending rigidity (issue 35).

Rings zeta = 1 + A exp(-10 |theta - theta_r|^4) (ring-to-pole tension ratio 1 + A), eta_s = eta_b =
1, no bending viscosity, rigidity kappa (eta_s R0^2 / t_a), adaptive points.

Sections:

- ``neck``: the symmetric ring A = 20, kappa = 0.01 to a neck of 1e-4 (or the integrator's end):
  the neck radius at fixed times over n (48, 64, 96) and rtol (1e-8, 1e-10), its local rate
  -d ln r / dt, and the times it reaches 0.1, 1e-2 and 1e-3 R0 (the reference numbers for 3D).
- ``map``: closed (neck 1e-2 before t = 10), arrested (|d neck / dt| < 1e-4 at t = 10) or failed,
  over kappa and A, with the up-down lobe mode's growth rate at the last frame (the largest real
  eigenvalue among the modes odd under z -> -z of the full-meridian Jacobian at the mirrored state).
- ``lobe``: the lobe mode's growth rate along the constriction of the ``cytokinesis`` ring (A = 12)
  against kappa (and of the rings A = 6, 20, 30 at kappa = 0.01, 0.1): the rate at the frames where
  the neck passes 0.5, 0.4, 0.3, 0.2, 0.15 and 0.1, and its integral ``G = int rate dt`` from a
  neck of 0.5 to 0.1 (a seed grows by ``exp(G)``).
- ``asymmetric``: the ring off the equator (theta_r = pi/2 - offset): A = 20, kappa = 0.01 at offset 0.2
  (the north lobe empties: no cut), and cytokinesis_asymmetric's ring (A = 30, kappa = 0.1) cut at a neck
  of 0.1: the daughters' volume ratio over the offset and, at its offset 0.001, over n.
- ``modes``: the off-centre ring's fastest growth rate at t = 0.1 over n, with and without the
  filter of the full meridian's node rates (the grid-scale mode that ended the run at t = 0.24).
- ``cut``: the symmetric run cut at a neck of 0.02 and the daughters evolved 0.2 t_a (ring
  disassembled at the cut): volumes and roundness.

Usage (one core): ``python benchmarks/division_axisym.py [--smoke] [section ...]``
"""

from __future__ import annotations

import os

for _k in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
    os.environ.setdefault(_k, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from _bench import HELP, run_sections  # noqa: E402

from cortex_ti.axisymmetric.balance import ForceBalance, check_gauge, check_visc  # noqa: E402
from cortex_ti.axisymmetric.division import cut, simulate_division  # noqa: E402
from cortex_ti.axisymmetric.dynamics import Dynamics  # noqa: E402
from cortex_ti.axisymmetric.evolve import StepFailed, simulate  # noqa: E402
from cortex_ti.axisymmetric.lobe import fastest_mode  # noqa: E402
from cortex_ti.axisymmetric.lobe import lobe_rate as _lobe_rate  # noqa: E402
from cortex_ti.axisymmetric.spectral import Spectral  # noqa: E402

VISC = dict(eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0)
SMOKE = False


def ring(A: float, centre: float = np.pi / 2):
    return lambda th: 1.0 + A * np.exp(-10.0 * np.abs(np.asarray(th, dtype=float) - centre) ** 4)


def run(A, kappa, n, *, rtol=1e-8, t_end=10.0, stop=1e-4, centre=np.pi / 2, keep=None):
    """The run (frames every 0.05 t_a) or the frames before a failure; ``keep`` collects states."""
    times = np.round(np.linspace(0.0, t_end, int(round(t_end * 20)) + 1), 10)
    try:
        return simulate(
            ring(A, centre),
            **VISC,
            kappa=kappa,
            t_end=t_end,
            save_times=times,
            n=n,
            rtol=rtol,
            interpolate=True,
            parametrization="adaptive",
            stop_neck=stop,
            max_steps=50000,
            on_save=keep,
        )
    except StepFailed as exc:
        return exc.result


def neck(res):
    return np.where(np.isfinite(res.neck_radius), res.neck_radius, res.furrow_radius)


def crossing(t, r, level):
    """First time the neck falls to ``level`` (log-linear between frames), nan if never."""
    k = np.flatnonzero(r <= level)
    if not k.size or k[0] == 0:
        return float("nan")
    i = k[0]
    a, b = np.log(r[i - 1]), np.log(r[i])
    return float(t[i - 1] + (np.log(level) - a) / (b - a) * (t[i] - t[i - 1]))


def section_neck():
    cases = [(16, 1e-6)] if SMOKE else [(48, 1e-8), (64, 1e-8), (96, 1e-8), (64, 1e-10)]
    checks = (0.5,) if SMOKE else (1.0, 1.5, 1.7, 1.8, 1.9)
    t_end = 0.5 if SMOKE else 3.0
    print("## The symmetric ring A = 20, kappa = 0.01, to the end\n")
    print(
        "| n | rtol | "
        + " | ".join(f"neck at t={t:g}" for t in checks)
        + " | t(0.1) | t(1e-2) | t(1e-3) | smallest neck | end | CPU s |"
    )
    print("|---:|---:|" + "---:|" * (len(checks) + 6) + "---|")
    runs = {}
    for n, rt in cases:
        c0 = time.process_time()
        r = run(20.0, 0.01, n, rtol=rt, t_end=t_end)
        cpu = time.process_time() - c0
        nk = neck(r)
        runs[(n, rt)] = r
        cells = [f"{nk[r.index(t)]:.8f}" if t <= r.t[-1] + 1e-9 else "-" for t in checks]
        tc = [crossing(r.t, nk, lv) for lv in (0.1, 1e-2, 1e-3)]
        print(
            f"| {n} | {rt:g} | "
            + " | ".join(cells)
            + " | "
            + " | ".join(f"{x:.4f}" for x in tc)
            + f" | {nk.min():.3e} | {r.stopped[:60]} | {cpu:.1f} |"
        )
    print()
    r = runs[cases[-2] if len(cases) > 1 else cases[0]]
    nk = neck(r)
    print(f"Local rate -d ln r / dt (central differences of the frames, n = {r.params['n']}):\n")
    print("| t | neck | -d ln r/dt |")
    print("|---:|---:|---:|")
    for i in range(1, r.t.size - 1):
        if nk[i] < 0.2:
            rate = -(np.log(nk[i + 1]) - np.log(nk[i - 1])) / (r.t[i + 1] - r.t[i - 1])
            print(f"| {r.t[i]:.2f} | {nk[i]:.4e} | {rate:.3f} |")
    print()


def lobe_rate(res, y, kappa, A, n):
    """The lobe mode's rate at the mirrored state ``y`` (cortex_ti.axisymmetric.lobe.lobe_rate)."""
    return _lobe_rate(ring(A), y, **VISC, kappa=kappa)


def section_map():
    kappas = (0.01,) if SMOKE else (0.001, 0.01, 0.1)
    amps = (20.0,) if SMOKE else (6.0, 12.0, 20.0)
    n, t_end = (16, 0.3) if SMOKE else (48, 10.0)
    print(f"## Closing, arrest or slipping over (kappa, A), n = {n}, rtol 1e-8, to t = {t_end:g} or a neck of 1e-2\n")
    print("| kappa | 1 + A | outcome | t at the end | neck at the end | lobe rate at the end (1/t_a) | CPU s |")
    print("|---:|---:|---|---:|---:|---:|---:|")
    for kappa in kappas:
        for A in amps:
            box = {}
            c0 = time.process_time()
            r = run(A, kappa, n, t_end=t_end, stop=1e-2, keep=lambda f, y, box=box: box.__setitem__("y", y))
            cpu = time.process_time() - c0
            nk = neck(r)
            if r.stopped.startswith("neck"):
                out = "closed"
            elif r.stopped != "t_end":
                out = "failed: " + r.stopped.split(":")[1][:50]
            else:
                rate = (nk[-1] - nk[-2]) / (r.t[-1] - r.t[-2])
                out = f"arrested (rate {rate:.1e})" if abs(rate) < 1e-4 else f"closing (rate {rate:.1e})"
            lobe = lobe_rate(r, box["y"], kappa, A, n)
            print(f"| {kappa:g} | {1 + A:g} | {out} | {r.t[-1]:.3f} | {nk[-1]:.4e} | {lobe:+.3f} | {cpu:.1f} |")
    print()


def section_lobe():
    cases = [(12.0, 0.01)] if SMOKE else [(12.0, k) for k in (0.0, 0.001, 0.01, 0.03, 0.1, 0.3, 1.0)]
    if not SMOKE:
        cases += [(a, k) for a in (6.0, 20.0, 30.0) for k in (0.01, 0.1)]
    n, t_end = (16, 0.3) if SMOKE else (48, 6.0)
    levels = (0.5, 0.4, 0.3, 0.2, 0.15, 0.1)
    print(f"## The lobe mode along the constriction, n = {n}, rtol 1e-8 (frames every 0.05 t_a)\n")
    print(
        "| 1 + A | kappa | "
        + " | ".join(f"rate at neck {lv:g}" for lv in levels)
        + " | G = int rate dt, neck 0.5 -> 0.1 (or the end) | t(0.5), t(0.1) | end | CPU s |"
    )
    print("|---:|---:|" + "---:|" * (len(levels) + 3) + "---|")
    for A, kappa in cases:
        states = []
        c0 = time.process_time()
        r = run(A, kappa, n, t_end=t_end, stop=0.09, keep=lambda f, y, states=states: states.append(y.copy()))
        nk = neck(r)
        m = min(len(states), nk.size)
        rates = np.array([lobe_rate(r, states[i], kappa, A, n) if nk[i] <= 0.55 else np.nan for i in range(m)])
        cpu = time.process_time() - c0
        cells = []
        for lv in levels:
            k = np.flatnonzero(nk[:m] <= lv)
            cells.append(f"{rates[k[0]]:+.2f} ({nk[k[0]]:.3f})" if k.size else "-")
        span = np.flatnonzero((nk[:m] <= 0.5) & (nk[:m] >= 0.1))
        g = float(np.trapezoid(rates[span], r.t[span])) if span.size > 1 else float("nan")
        t5, t1 = crossing(r.t, nk, 0.5), crossing(r.t, nk, 0.1)
        print(
            f"| {1 + A:g} | {kappa:g} | "
            + " | ".join(cells)
            + f" | {g:.2f} | {t5:.3f}, {t1:.3f} | {r.stopped[:50]} | {cpu:.1f} |"
        )
    print()


def _split(A, kappa, n, offset, stop):
    """The ring of amplitude ``A`` centred ``offset`` rad north of the equator, to a neck of ``stop``: (run,
    north, south daughters at the cut or None, CPU s)."""
    box = {}
    c0 = time.process_time()
    centre = np.pi / 2 - offset
    r = run(A, kappa, n, t_end=3.0, stop=stop, centre=centre, keep=lambda f, y, box=box: box.__setitem__("y", y))
    if not r.stopped.startswith("neck"):
        return r, None, None, time.process_time() - c0
    sp = Spectral(n, False)
    ph = check_visc(**VISC, radius=1.0, kappa=kappa)
    dyn = Dynamics(sp, ForceBalance(sp, ph, check_gauge("velocity")), ring(A, centre), "adaptive", filtered=True)
    north, south = cut(dyn, box["y"], 2 * n)
    return r, north, south, time.process_time() - c0


def section_asymmetric():
    print("## The ring off the equator (theta_r = pi/2 - offset)\n")
    print("A = 20, kappa = 0.01, offset 0.2 (the case that failed at t = 0.24 before the filter), to a neck of 0.02:\n")
    print("| n | end | smallest neck (t) | north pole height at the end | CPU s |")
    print("|---:|---|---:|---:|---:|")
    for n in (24,) if SMOKE else (48, 64):
        c0 = time.process_time()
        r = run(20.0, 0.01, n, t_end=0.2 if SMOKE else 3.0, stop=0.02, centre=np.pi / 2 - 0.2)
        nk = np.where(np.isfinite(r.neck_radius), r.neck_radius, np.inf)
        i = int(np.argmin(nk))
        cpu = time.process_time() - c0
        print(f"| {n} | {r.stopped[:70]} | {nk[i]:.4f} ({r.t[i]:.2f}) | {r.z[-1][0]:+.4f} | {cpu:.1f} |")
    print()
    A, kappa, stop = 30.0, 0.1, 0.1
    print(f"cytokinesis_asymmetric's ring (A = {A:g}, kappa = {kappa:g}), cut at a neck of {stop:g}:\n")
    print("| offset (rad) | n | cut time | V north | V south | V south / V north | sum - mother | CPU s |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|")
    cases = [(0.001, 24)] if SMOKE else [(o, 48) for o in (0.0003, 0.003, 0.01, 0.03)]
    cases += [] if SMOKE else [(0.001, n) for n in (32, 48, 64, 96)]
    for off, n in cases:
        r, north, south, cpu = _split(A, kappa, n, off, stop)
        if north is None:
            print(f"| {off:g} | {n} | no cut: {r.stopped[:60]} (neck at the end {neck(r)[-1]:.3f}) |||| | {cpu:.1f} |")
            continue
        print(
            f"| {off:g} | {n} | {r.t[-1]:.5f} | {north.volume:.8f} | {south.volume:.8f} | "
            f"{south.volume / north.volume:.6f} | {north.volume + south.volume - r.volume[-1]:.1e} | {cpu:.1f} |"
        )
    print()


def section_modes():
    """The fastest growth rate of the off-centre ring's shape dynamics at t = 0.1 over n, with and without
    the filter of the node rates (cortex_ti.axisymmetric.dynamics.FILTER_STRENGTH)."""
    centre, t = np.pi / 2 - 0.2, 0.1
    print("## The off-centre ring's fastest mode (A = 20, kappa = 0.01, theta_r = pi/2 - 0.2, t = 0.1)\n")
    print("| n | filtered: fastest rate (1/t_a) | its zigzag | unfiltered: fastest rate | its zigzag | CPU s |")
    print("|---:|---:|---:|---:|---:|---:|")
    for n in (16,) if SMOKE else (32, 48, 64, 96):
        box = {}
        c0 = time.process_time()
        run(20.0, 0.01, n, t_end=t, centre=centre, keep=lambda f, y, box=box: box.__setitem__("y", y))
        cells = []
        for filtered in (True, False):
            rate, zigzag = fastest_mode(ring(20.0, centre), box["y"], kappa=0.01, filtered=filtered, **VISC)
            cells += [f"{rate:.5f}", f"{zigzag:.2f}"]
        print(f"| {n} | " + " | ".join(cells) + f" | {time.process_time() - c0:.1f} |")
    print("\n(zigzag: |diff v| / |v| of the mode's r part, 2 for a pure grid-scale zigzag)\n")
    print("Unfiltered, by parametrisation and gauge (the centred ring: the same ring at pi/2):\n")
    cases = [("lagrangian", "velocity", centre), ("arclength", "velocity", centre), ("adaptive", "centroid", centre)]
    cases.append(("adaptive", "velocity", np.pi / 2))
    print("| n | " + " | ".join(f"{m}, {g} gauge{'' if c == centre else ', centred'}" for m, g, c in cases) + " |")
    print("|---:|" + "---:|" * len(cases))
    for n in (16,) if SMOKE else (32, 48, 64, 96):
        cells = []
        for mode, gauge, c in cases:
            box = {}
            keep = lambda f, y, box=box: box.__setitem__("y", y)  # noqa: E731
            kw = dict(parametrization=mode, gauge=gauge, symmetric=False, on_save=keep, interpolate=True)
            simulate(ring(20.0, c), **VISC, kappa=0.01, t_end=t, save_times=[0.0, t], n=n, rtol=1e-8, **kw)
            rate, zz = fastest_mode(ring(20.0, c), box["y"], kappa=0.01, filtered=False, mode=mode, gauge=gauge, **VISC)
            cells.append(f"{rate:.2f} ({zz:.2f})")
        print(f"| {n} | " + " | ".join(cells) + " |")
    print("\n(the fastest rate, 1/t_a, and its zigzag)\n")


def section_cut():
    n, nd, stop, t_end = (24, 32, 0.1, 1.3) if SMOKE else (48, 96, 0.02, 1.8)
    c0 = time.process_time()
    res = simulate_division(
        ring(20.0),
        neck_radius=stop,
        t_end=t_end,
        save_times=np.round(np.linspace(0, t_end, int(t_end * 20) + 1), 10),
        n=n,
        daughter_n=nd,
        **VISC,
        kappa=0.01,
        rtol=1e-8,
        interpolate=True,
    )
    cpu = time.process_time() - c0
    ci = res.cut_info
    print(f"## Cut of the symmetric ring at a neck of {stop:g} (n = {n}, daughters {nd} points), to t = {t_end:g}\n")
    print(
        f"cut at t = {ci['time']:.6f}; mother volume {ci['mother_volume']:.15f}; daughters {ci['volumes'][0]:.15f} + "
        f"{ci['volumes'][1]:.15f} (sum - mother {sum(ci['volumes']) - ci['mother_volume']:.1e}); cap arc length "
        f"{ci['cap_lengths'][0]:.4f}; CPU {cpu:.1f} s\n"
    )
    print(
        "| body | t | volume - volume at the cut | max - min distance from the centroid "
        "| R of a sphere of that volume |"
    )
    print("|---|---:|---:|---:|---:|")
    for name, d, v0 in zip(("north", "south"), res.daughters, ci["volumes"], strict=True):
        for i in (0, -1):
            rr = np.hypot(d.r[i], d.z[i] - d.z_centroid[i])
            r_v = (3 * d.volume[i] / (4 * np.pi)) ** (1 / 3)
            print(f"| {name} | {d.t[i]:.3f} | {d.volume[i] - v0:.1e} | {np.ptp(rr):.4f} | {r_v:.6f} |")
    print()


SECTIONS = {
    "neck": section_neck,
    "lobe": section_lobe,
    "asymmetric": section_asymmetric,
    "modes": section_modes,
    "cut": section_cut,
    "map": section_map,
}


def main(argv=None):
    global SMOKE
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--smoke", action="store_true", help=HELP)
    p.add_argument("sections", nargs="*", choices=[*SECTIONS, []], default=[])
    a = p.parse_args(argv)
    SMOKE = a.smoke
    run_sections(SECTIONS, a.sections)


if __name__ == "__main__":
    main()
