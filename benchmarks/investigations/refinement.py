"""Question: Does one step of iterative refinement (``solver.refine``) lift the rounding floor of the paper
formulation's normal equations, and at what cost?

Answer: Yes: on Y21 full with the quartic fit the relative least-squares residual drops from 3.3e-12 /
2.1e-10 / 4.9e-10 to ~5e-15 at 2562 / 10242 / 40962 nodes, and eps_rel converges again (1.87e-5 ->
3.92e-7 at 40962), for a few per cent more solve time (20.9 -> 21.7 s). So ``solver.refine`` is on by
default. docs/validation/formulations.md, "Refinement".

Iterative refinement of the solve (``solver.refine``): the rounding floor of the paper
formulation's normal equations. A static sphere scene (Y21 full, quartic fit, formulation paper
by default) with and without one corrected semi-normal-equations step, against its closed form;
one process per configuration (so the peak memory is that configuration's own).

Usage::

    python benchmarks/investigations/refinement.py --nodes 2562 10242 40962
    python benchmarks/investigations/refinement.py --nodes 2562 10242 --formulation rayleigh_p1 --fit quadratic
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)


def one(scene_name, nodes, fit, formulation, refine):
    from cortex_ti import runtime
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.truth import analytic

    runtime.init(threads=int(os.environ.get("CORTEX_TI_THREADS", "1")))
    sc = load_scene(
        scene_name,
        [
            f"mesh.nodes={nodes}",
            f"numerics.fit={fit}",
            f"numerics.formulation={formulation}",
            "solver.reuse=false",
            f"solver.refine={'true' if refine else 'false'}",
        ],
    )
    sim = Simulation(sc)
    t0 = time.perf_counter()
    sol = sim.solve()
    wall = time.perf_counter() - t0
    eps, eps_rel = analytic.error_measures(sol.velocity, analytic.scene_solution(sc.settings, sim.mesh.points))
    return dict(
        scene=scene_name,
        nodes=nodes,
        fit=fit,
        formulation=formulation,
        refine=refine,
        eps_rel=eps_rel,
        relative_residual=sol.info.relative_residual,
        kkt=sol.info.kkt_residual,
        seconds=wall,
        solve_s=sol.seconds["solve"],
        peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="+", default=[2562, 10242])
    p.add_argument("--scene", default="sphere_y21_full")
    p.add_argument("--fit", default="quartic")
    p.add_argument("--formulation", default="paper")
    p.add_argument("--json", default=None)
    p.add_argument("--one", nargs=2, help=argparse.SUPPRESS)
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes = [162]
    if args.one:
        print(json.dumps(one(args.scene, int(args.one[0]), args.fit, args.formulation, args.one[1] == "1")))
        return 0
    print(f"{args.scene}, {args.fit} fit, formulation {args.formulation}\n")
    print("| N | refine | eps_rel | relative residual | solve s | peak MB |")
    print("|---|---|---|---|---|---|")
    for n in args.nodes:
        for refine in (0, 1):
            res = subprocess.run(
                [
                    sys.executable,
                    __file__,
                    "--scene",
                    args.scene,
                    "--fit",
                    args.fit,
                    "--formulation",
                    args.formulation,
                    "--one",
                    str(n),
                    str(refine),
                ],
                capture_output=True,
                text=True,
            )
            if res.returncode:
                print(f"| {n} | {refine} | failed: {res.stderr.strip().splitlines()[-1:]} |")
                if args.smoke:
                    return 1
                continue
            r = json.loads(res.stdout.strip().splitlines()[-1])
            print(
                f"| {n} | {'yes' if refine else 'no'} | {r['eps_rel']:.3e} | "
                f"{r['relative_residual']:.2e} | {r['solve_s']:.2f} | {r['peak_mb']:.0f} |",
                flush=True,
            )
            if args.json:
                with open(args.json, "a") as fh:
                    fh.write(json.dumps(r) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
