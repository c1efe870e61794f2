"""What accuracy costs in time: the four analytic sphere scenes (paper Figs. 2, 3).

For every node count N and method (formulation and fit) this prints the time of the geometry, the
assembly and the solve, the peak memory, and the errors eps / eps_rel (paper Eqs.
57-58) of the four sphere scenes against their analytic solutions.

Each (N, method) runs in its own process so the peak memory is that
configuration's own (it includes the ~0.25 GB of the Python/Taichi runtime).
Times are wall-clock seconds of one solve of a new shape:

* ``cold``: the first solve in a process (symbolic analysis of the sparse matrix
  included; Taichi kernels are already compiled),
* ``warm``: a further solve on a slightly different shape with the same mesh
  topology, i.e. the cost of one step of a time-dependent run.

Usage::

    python benchmarks/accuracy_cost.py                       # 642 2562 10242
    python benchmarks/accuracy_cost.py --nodes 642 2562 10242 40962 --out results/benchmarks/static.csv

Expected cost: about 3 minutes for the default node counts on a 2-core machine.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares

SCENES = ("sphere_y20_full", "sphere_y20_tangential", "sphere_y21_full", "sphere_y21_tangential")


def one(nodes: int, method: str, backend: str) -> list[dict]:
    """Run the four scenes at one resolution with one method (``formulation:fit``); one record per scene."""
    import numpy as np

    from cortex_ti import runtime
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.truth import analytic

    runtime.init(threads=int(os.environ.get("CORTEX_TI_THREADS", "0")) or None)
    out = []
    for name in SCENES:
        formulation, scheme = method.split(":")
        scene = load_scene(
            name,
            [
                f"mesh.nodes={nodes}",
                f"numerics.formulation={formulation}",
                f"numerics.fit={scheme}",
                f"solver.backend={backend}",
                "solver.reuse=false",
            ],
        )
        sim = Simulation(scene)
        cold = sim.solve()
        jitter = 1e-4 * np.random.default_rng(0).standard_normal(sim.mesh.points.shape)
        warm = sim.solve(sim.mesh.points + jitter)
        sol = sim.solve()  # the accuracy is measured on the exact sphere
        eps, eps_rel = analytic.error_measures(sol.velocity, analytic.scene_solution(scene.settings, sim.mesh.points))
        out.append(
            dict(
                scene=name,
                nodes=nodes,
                method=method,
                backend=sim.solver.backend,
                eps=eps,
                eps_rel=eps_rel,
                **{f"cold_{k}": v for k, v in cold.seconds.items()},
                **{f"warm_{k}": v for k, v in warm.seconds.items()},
                residual=sol.info.relative_residual,
                constraint=sol.info.constraint_violation,
                peak_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
            )
        )
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562, 10242])
    p.add_argument(
        "--methods",
        nargs="+",
        default=["paper:quadratic", "paper:quartic", "rayleigh_p1:quadratic"],
        help="formulation:fit pairs",
    )
    p.add_argument("--backend", default="auto")
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/static.csv"))
    p.add_argument("--one", nargs=2, metavar=("NODES", "METHOD"), help=argparse.SUPPRESS)
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.methods, args.out = (
            [162],
            ["paper:quartic", "rayleigh_p1:quadratic"],
            _bench.folder() / "static.csv",
        )
    if args.one:
        print(json.dumps(one(int(args.one[0]), args.one[1], args.backend)))
        return 0
    rows = []
    for method in args.methods:
        for n in args.nodes:
            t0 = time.perf_counter()
            res = subprocess.run(
                [sys.executable, __file__, "--one", str(n), method, "--backend", args.backend],
                capture_output=True,
                text=True,
            )
            if res.returncode != 0:
                print(f"# {method} N={n} failed: {res.stderr.strip().splitlines()[-1:]}", file=sys.stderr)
                if args.smoke:
                    return 1
                continue
            rows += json.loads(res.stdout.strip().splitlines()[-1])
            print(f"# {method} N={n} done in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with open(args.out, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    print(_bench.header(note=f"backend {rows[0]['backend']}"))
    print("| formulation:fit | N | scene | eps | eps_rel | geometry s | assembly s | solve s (cold / warm) | peak MB |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['method']} | {r['nodes']} | {r['scene'].replace('sphere_', '')} | {r['eps']:.2e} | "
            f"{r['eps_rel']:.2e} | "
            f"{r['warm_geometry']:.3f} | {r['warm_assembly']:.3f} | {r['cold_solve']:.2f} / {r['warm_solve']:.2f} | "
            f"{r['peak_mb']:.0f} |"
        )
    print(f"\n(csv: {args.out})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
