"""The axisymmetric model carrying the myosin field against its truths (issue 20): the conservation
law, the closed-form linear stability of the uniform sphere, and the growth of an l = 2 seed in
nonlinear runs.

Tables:

1. Total myosin ``oint c dA`` over a run without turnover (D = 0.05; seed ``0.1 P2`` plus, on the
   full meridian, ``0.05 cos(theta)``): the largest relative drift over 7 frames to t = 3, and how
   much the area moved meanwhile.
2. The exact Jacobian (complex step) of the meridian dynamics at the uniform sphere: for degrees
   0-5 the largest distance from a closed-form rate (:mod:`cortex_ti.analysis.myosin_stability`)
   to the nearest eigenvalue, relative, for both laws, with and without bending viscosity, both
   translation gauges, sub- and supercritical.
3. Nonlinear runs from ``c = c0 (1 + 1e-4 P2)`` (symmetric half, D = 0.05, k = 0.2): the rate of
   the density's P2 amplitude between t = 5.5 and 6 against the closed form's l = 2 rate, for n.

Usage::

    python benchmarks/axisymmetric_myosin.py [--smoke]

Cost: seconds.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

NO_BEND = dict(eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0)
BEND = dict(eta_s=1.0, eta_b=1.0, eta_bar=5e-4, eta_bar_b=2.5e-3)
D, K = 0.05, 0.2


def zero(theta):
    return 0.0 * np.asarray(theta, dtype=float)


def p2(theta):
    return 0.5 * (3.0 * np.cos(theta) ** 2 - 1.0)


def conservation(n: int) -> None:
    from cortex_ti.axisymmetric.evolve import simulate
    from cortex_ti.axisymmetric.myosin import Myosin

    print("| meridian | n | max abs(M(t) - M(0)) / M(0), t <= 3 | area range | wall (s) |")
    print("|---|---|---|---|---|")
    for tilt, name in ((0.0, "symmetric half"), (0.05, "full")):
        m = Myosin(diffusion=D, initial=lambda th, tilt=tilt: 1.0 + 0.1 * p2(th) + tilt * np.cos(th))
        res = simulate(zero, **NO_BEND, t_end=3.0, save_times=np.linspace(0, 3, 7), n=n, rtol=1e-8, myosin=m)
        drift = np.max(np.abs(res.myosin_total - res.myosin_total[0])) / res.myosin_total[0]
        print(f"| {name} | {n} | {drift:.1e} | {np.ptp(res.area):.2e} | {res.wall_time:.2f} |")


def linearisation(n: int) -> None:
    from cortex_ti.analysis import myosin_stability as ms
    from cortex_ti.axisymmetric.evolve import full_meridian_dynamics
    from cortex_ti.axisymmetric.myosin import Myosin

    print("| law | gamma | bending | gauge | l = 2 rates (closed form) | max rel. distance, l = 0..5 |")
    print("|---|---|---|---|---|---|")
    cases = [
        ("linear", 1.0, NO_BEND, "velocity"),
        ("linear", 0.5, NO_BEND, "velocity"),
        ("linear", 0.25, NO_BEND, "velocity"),
        ("saturating", 1.0, BEND, "velocity"),
        ("linear", 0.6, BEND, "centroid"),
    ]
    for law, gamma, visc, gauge in cases:
        m = Myosin(diffusion=D, turnover=K, law=law, gamma=gamma)
        dyn = full_meridian_dynamics(zero, n, **visc, gauge=gauge, myosin=m)
        u = dyn.sp.u
        y = np.concatenate([np.sin(u), np.cos(u), np.sin(u)])
        ev = np.linalg.eigvals(dyn.jac(0.0, y))
        A = ms.activity(law, 1.0, gamma)
        tr = "mean_velocity" if gauge == "velocity" else "centroid"
        kw = dict(translation=tr, eta_b=visc["eta_b"], eta_bar=visc["eta_bar"], eta_bar_b=visc["eta_bar_b"])
        worst = 0.0
        for l in range(6):
            for rate in ms.growth_rates(l, 1.0, A, D, K, decimals=None, **kw):
                worst = max(worst, np.min(np.abs(ev - rate)) / max(1.0, abs(rate)))
        r2 = ms.growth_rates(2, 1.0, A, D, K, **kw)
        bend = "yes" if visc["eta_bar"] else "no"
        print(f"| {law} | {gamma:g} | {bend} | {tr} | {r2[0]:+.6f}, {r2[1]:+.6f} | {worst:.1e} |")


def growth(ns) -> None:
    from cortex_ti.analysis import myosin_stability as ms
    from cortex_ti.axisymmetric.evolve import simulate
    from cortex_ti.axisymmetric.myosin import Myosin

    print("| gamma | n | closed form | run, t = 5.5-6 | rel. error | steps | wall (s) |")
    print("|---|---|---|---|---|---|---|")
    th = np.linspace(0.0, np.pi, 2001)
    for gamma in (1.0, 0.5):
        exact = ms.growth_rates(2, 1.0, gamma, D, K, decimals=None)[0]
        for n in ns:
            m = Myosin(diffusion=D, turnover=K, gamma=gamma, initial=lambda t: 1.0 + 1e-4 * p2(t))
            ts = np.array([5.5, 6.0])
            res = simulate(zero, **NO_BEND, t_end=6.0, save_times=ts, n=n, rtol=1e-10, myosin=m)
            amp = [
                np.trapezoid((res.evaluate(i, th, coordinate="sigma")["c"] - 1.0) * p2(th) * np.sin(th), th)
                for i in range(2)
            ]
            rate = np.log(amp[1] / amp[0]) / 0.5
            err = (rate - exact) / abs(exact)
            print(
                f"| {gamma:g} | {n} | {exact:+.6f} | {rate:+.6f} | {err:+.1e} | {res.n_steps} | {res.wall_time:.2f} |"
            )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    n = 8 if args.smoke else 24
    print("## Total myosin without turnover\n")
    conservation(n)
    print("\n## Linearisation at the uniform sphere (n = 32 on the full meridian)\n")
    linearisation(8 if args.smoke else 32)
    print("\n## Growth of an l = 2 seed in nonlinear runs (symmetric half)\n")
    growth([8] if args.smoke else [8, 16, 32])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
