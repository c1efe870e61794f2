"""Cost of one solve (a time step) per formulation: geometry, assembly, solve, median over
repeated solves on slightly different shapes (same topology, warm), the formulations interleaved
so that a varying machine load hits them alike. One thread by default.

Usage::

    CORTEX_TI_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 \
        python benchmarks/formulation_cost.py --nodes 642 2562 10242 --fit quadratic
"""

from __future__ import annotations

import argparse
import sys
import time

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="furrow_p4_a1")
    p.add_argument("--nodes", type=int, nargs="+", default=[2562])
    p.add_argument("--fit", default="quadratic")
    p.add_argument("--formulations", nargs="+", default=["paper", "rayleigh_p1"])
    p.add_argument("--repeat", type=int, default=15)
    p.add_argument("--dt", type=float, default=1e-3, help="step of the semi-implicit tension (0: explicit)")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.repeat = [162], 2
    from cortex_ti import runtime
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    runtime.init(threads=args.threads)
    print(
        f"{_bench.header(note=f'{args.threads} thread(s)')}\n"
        f"Median of {args.repeat} warm solves for a step dt = {args.dt:g}\n"
    )
    print("| N | fit | formulation | geometry ms | assembly ms | solve ms | total ms | CPU ms | ratio |")
    print("|---|---|---|---|---|---|---|---|---|")
    for n in args.nodes:
        sims = {
            f: Simulation(
                load_scene(args.scene, [f"mesh.nodes={n}", f"numerics.fit={args.fit}", f"numerics.formulation={f}"])
            )
            for f in args.formulations
        }
        x0 = next(iter(sims.values())).mesh.points
        rng = np.random.default_rng(0)
        rec = {f: [] for f in sims}
        for k in range(args.repeat + 2):
            x = x0 + 1e-4 * rng.standard_normal(x0.shape)
            for f, sim in sims.items():
                c0 = time.process_time()
                sol = sim.solve(x, dt=args.dt)
                cpu = time.process_time() - c0
                if k >= 2:
                    rec[f].append(dict(sol.seconds, cpu=cpu))
        base = None
        for f, rows in rec.items():
            med = {key: 1e3 * float(np.median([r[key] for r in rows])) for key in rows[0]}
            total = med["geometry"] + med["assembly"] + med["solve"]
            base = base or total
            print(
                f"| {n} | {args.fit} | {f} | {med['geometry']:.1f} | {med['assembly']:.1f} | {med['solve']:.1f} | "
                f"{total:.1f} | {med['cpu']:.1f} | {total / base:.2f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
