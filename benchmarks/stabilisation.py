"""What the two stabilisations of the paper's formulation cost and change: the fit-residual rows and
the semi-implicit tension (formulation paper throughout; rayleigh_p1 needs no rows).

For each fit scheme and fit-residual weight, on the furrow's initial sphere (``furrow_p8_a1``):
milliseconds per solve by stage (geometry, assembly, solve; the median of ``--repeat`` solves of
one step with the semi-implicit tension, after a warm-up), and the relative error eps_rel of the
analytic sphere scenes (paper Eq. 58), which the rows must leave alone.

Usage::

    python benchmarks/stabilisation.py --nodes 642 2562 --weights 0 1e-3 --threads 2

Prints two Markdown tables. Timings depend on the machine: report them with it.
"""

from __future__ import annotations

import argparse
import sys

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

from cortex_ti import runtime
from cortex_ti.scene import load_scene
from cortex_ti.simulation import Simulation
from cortex_ti.truth import analytic

SPHERES = ("sphere_y20_full", "sphere_y21_full", "sphere_y20_tangential")


def stage_times(nodes: int, fit: str, weight: float, repeat: int, dt: float) -> dict[str, float]:
    sim = Simulation(
        load_scene(
            "furrow_p8_a1",
            [
                f"mesh.nodes={nodes}",
                f"numerics.fit={fit}",
                "numerics.formulation=paper",
                f"numerics.fit_residual_weight={weight}",
            ],
        )
    )
    sim.solve(dt=dt)  # warm-up: kernels compiled, symbolic analysis done
    runs = [sim.solve(dt=dt).seconds for _ in range(repeat)]
    return {k: 1e3 * float(np.median([r[k] for r in runs])) for k in runs[0]}


def sphere_error(scene_name: str, nodes: int, fit: str, weight: float) -> float:
    scene = load_scene(
        scene_name,
        [
            f"mesh.nodes={nodes}",
            f"numerics.fit={fit}",
            "numerics.formulation=paper",
            f"numerics.fit_residual_weight={weight}",
        ],
    )
    sim = Simulation(scene)
    sol = sim.solve()
    return analytic.error_measures(sol.velocity, analytic.scene_solution(scene.settings, sim.mesh.points))[1]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    p.add_argument("--fits", nargs="+", default=["quadratic", "quartic"])
    p.add_argument("--weights", type=float, nargs="+", default=[0.0, 1e-3])
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--dt", type=float, default=1e-3, help="step of the semi-implicit solve timed")
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.fits, args.repeat = [162], ["quadratic"], 1
    runtime.init(threads=args.threads)

    print("| nodes | fit | rows weight | geometry (ms) | assembly (ms) | solve (ms) | total (ms) | vs rows off |")
    print("|---|---|---|---|---|---|---|---|")
    for nodes in args.nodes:
        for fit in args.fits:
            base = None
            for w in args.weights:
                t = stage_times(nodes, fit, w, args.repeat, args.dt)
                total = sum(t.values())
                base = total if base is None else base
                print(
                    f"| {nodes} | {fit} | {w:g} | {t['geometry']:.1f} | {t['assembly']:.1f} | {t['solve']:.1f} "
                    f"| {total:.0f} | {total / base:.2f}x |",
                    flush=True,
                )
    print()
    print("| nodes | fit | rows weight | " + " | ".join(SPHERES) + " |")
    print("|---|---|---|" + "---|" * len(SPHERES))
    for nodes in args.nodes:
        for fit in args.fits:
            for w in args.weights:
                errs = [sphere_error(s, nodes, fit, w) for s in SPHERES]
                print(f"| {nodes} | {fit} | {w:g} | " + " | ".join(f"{e:.3g}" for e in errs) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
