"""The explicit stability limit of a stored run, frame by frame: the stiffest normal mode.

The shape moves by ``dX/dt = v_n(X) n``. Linearised about a frame, a normal perturbation
``s`` (one number per node) grows or decays with the Jacobian ``J s = d(v_n)/d(X) [s n]``;
explicit Euler is stable for ``dt < 2 / |lambda|`` with ``lambda`` the most negative
eigenvalue. This estimates it by power iteration with finite differences (``--iterations``
solves per frame) and prints lambda, the Euler limit, the step the run actually took and
where the mode sits. With ``--implicit-dt DT`` it measures the step map of the semi-implicit
tension instead (the velocity solved for a step DT): the column ``step factor`` is then
``1 + DT lambda``, the factor by which one step of DT multiplies the stiffest mode (stable if
its magnitude is below 1).

Usage::

    python benchmarks/stiffness.py RUN.h5 --times 0 0.5 1.0 1.3
    python benchmarks/stiffness.py RUN.h5 --times 1.3 --implicit-dt 1e-3
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from cortex_ti import runtime
from cortex_ti.dynamics.spectrum import stiffest_normal_mode
from cortex_ti.io import Trajectory
from cortex_ti.simulation import Simulation


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trajectory")
    p.add_argument("--times", type=float, nargs="+", required=True)
    p.add_argument("--iterations", type=int, default=30)
    p.add_argument("--implicit-dt", type=float, default=0.0,
                   help="measure the semi-implicit step map for this step (default 0: the explicit rate)")
    args = p.parse_args(argv)
    dt = args.implicit_dt
    runtime.init()
    tr = Trajectory(args.trajectory)
    ds = tr.ds
    sim = Simulation(tr.scene)
    t = ds["time"].values
    third = f"step factor at dt = {dt:g}" if dt > 0 else "Euler limit 2/|lambda|"
    print(f"| t | lambda (1/t_a) | {third} | step taken | mode: nodes above 10 % | mode centre z, r |")
    print("|---|---|---|---|---|---|")
    for want in args.times:
        k = int(np.argmin(np.abs(t - want)))
        x = ds["points"].values[k]
        lam, s = stiffest_normal_mode(lambda pts: sim.evaluate(pts, dt), x, args.iterations)
        big = np.abs(s) > 0.1 * np.abs(s).max()
        w = s ** 2 / np.sum(s ** 2)
        zc = float(np.sum(w * np.abs(x[:, 2])))
        rc = float(np.sum(w * np.hypot(x[:, 0], x[:, 1])))
        taken = float(ds["dt"].values[k]) if "dt" in ds else float("nan")
        col = f"{1 + dt * lam:.3g}" if dt > 0 else f"{2 / abs(lam):.2e}"
        print(f"| {t[k]:.3g} | {lam:.3g} | {col} | {taken:.2e} | {int(big.sum())} | {zc:.3f}, {rc:.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
