"""Helfrich rigidity in the axisymmetric model: the stiffness it brings, the power balance over a
relaxation, and the sphere's mode rates (docs/validation/bending_rigidity.md).

* ``stiffness``: the largest eigenvalue of the time stepping's Jacobian at a sphere with
  ``zeta0 = 1`` (half meridian, n points) against the closed-form rate of the highest degree the grid
  holds, ``l = 2n - 2`` (``cortex_ti.truth.helfrich_sphere``);
* ``power``: from ``|X| = 1 + 0.15 P2 + 0.08 P4`` without activity (kappa = 1, c0 = 0.5, eta_s = eta_b = 1,
  n = 16, rtol 1e-10, to t = 0.2): the energy lost ``E(0) - E(T)`` against the time integral of the
  dissipation (Simpson's rule on frames at ``T s^4``, s uniform, for several frame counts), and the
  largest ``|oint f v_n dA - D| / D`` over the frames.

Usage::

    python benchmarks/bending_rigidity_axisym.py

Cost: ~1 min.
"""

from __future__ import annotations

import argparse
import sys

import _bench  # benchmarks/_bench.py: what the scripts share
import numpy as np
from numpy.polynomial import legendre as npl
from scipy.integrate import simpson

from cortex_ti.axisymmetric.balance import ForceBalance, check_visc
from cortex_ti.axisymmetric.dynamics import Dynamics
from cortex_ti.axisymmetric.evolve import simulate
from cortex_ti.axisymmetric.rigidity import area_weights, dissipation, helfrich_energy, helfrich_force
from cortex_ti.axisymmetric.spectral import Spectral, geometry
from cortex_ti.truth.helfrich_sphere import rate


def stiffness(kappas, ns) -> None:
    print("stiffness: largest |eigenvalue| of the Jacobian at the sphere (zeta0 = 1) vs the closed form at l = 2n - 2")
    for kappa in kappas:
        for n in ns:
            sp = Spectral(n, True)
            dyn = Dynamics(
                sp, ForceBalance(sp, check_visc(1.0, 1.0, 0, 0, 1.0, kappa=kappa)), lambda t: 1.0 + 0 * t, "lagrangian"
            )
            ev = np.linalg.eigvals(dyn.jac(0.0, np.concatenate([np.sin(sp.u), np.cos(sp.u)])))
            top = abs(rate(2 * n - 2, kappa=kappa, eta_s=1.0, eta_b=1.0, zeta0=1.0))
            big, re = np.abs(ev).max(), ev.real.max()
            print(f"  kappa={kappa:g} n={n}: {big:.4e}  (closed form {top:.4e}); largest Re {re:.1e}")


def power(n: int, counts, T: float = 0.2, kappa: float = 1.0, c0: float = 0.5) -> None:
    sp = Spectral(n, True)
    leg = npl.legval(np.cos(sp.u), [0, 0, 0.15, 0, 0.08])
    y0 = np.concatenate([np.sin(sp.u) * (1 + leg), np.cos(sp.u) * (1 + leg)])
    fb = ForceBalance(sp, check_visc(1.0, 1.0, 0.0, 0.0, 1.0, kappa=kappa, c0=c0))
    print(f"power balance: n = {n}, kappa = {kappa:g}, c0 = {c0:g}, to t = {T:g}")
    for count in counts:
        ts = T * np.linspace(0.0, 1.0, count) ** 4
        E, D, W = [], [], []

        def measure(y, E=E, D=D, W=W):
            g = geometry(sp, y[:n], y[n : 2 * n])
            g["zeta"] = np.zeros(n)
            A, b = fb.assemble(g)
            x = np.linalg.solve(A, b)
            E.append(helfrich_energy(sp, g, kappa, c0))
            D.append(dissipation(sp, g, x[:n], x[n : 2 * n], 1.0, 1.0))
            W.append((helfrich_force(sp, g, kappa, c0) * x[n : 2 * n] * area_weights(sp, g)).sum())

        measure(y0)
        simulate(
            lambda t: 0.0 * t, eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0, t_end=T, save_times=ts, n=n,
            symmetric=True, kappa=kappa, spontaneous_curvature=c0, start=(0.0, y0), rtol=1e-10,
            parametrization="lagrangian", on_save=lambda frame, y: measure(y),
        )  # fmt: skip
        E, D, W = map(np.asarray, (E, D, W))
        lost, integral = E[0] - E[-1], simpson(D, x=ts)
        print(
            f"  {count:4d} frames: E(0) = {E[0]:.6f}, E(0) - E(T) = {lost:.10e}, int D dt = {integral:.10e}, "
            f"relative difference {(lost - integral) / lost:.2e}; max |W - D|/D = {np.max(np.abs(W - D) / D):.1e}"
        )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        stiffness([0.01], [8])
        power(8, [9], T=0.02)
        return 0
    stiffness([0.0, 0.01, 1.0], [16, 32, 48])
    power(16, [41, 81, 161])
    return 0


if __name__ == "__main__":
    sys.exit(main())
