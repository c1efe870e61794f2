"""What accuracy costs in time, for the shape dynamics (furrow_p4_a1 by default).

Runs the scene to ``t_end`` for each configuration (nodes, fit, scheme, dt), each in its
own process, and reports pole and furrow radius at ``t_end``, their error against the
reference configuration (the first one listed, meant to be the finest), the wall time
of the whole run, the number of steps and solves, and the time per solve split into
geometry, assembly and solve. Then it names the cheapest configuration within 1 % and
within 0.1 % (of R0) of the reference.

Usage::

    python benchmarks/dynamics_cost.py                      # the default set below (~1 h on 2 cores)
    python benchmarks/dynamics_cost.py --t-end 1 --configs 2562:quadratic:euler:2.5e-3 2562:quadratic:adaptive_euler:5e-4
    # a long reference run once, then the table against it:
    python benchmarks/dynamics_cost.py --one 10242:quadratic:adaptive_euler:5e-4 --file ref.h5 > ref.json
    python benchmarks/dynamics_cost.py --reference-json ref.json --configs 2562:quadratic:euler:2.5e-3 ...

A configuration is ``NODES:FIT:SCHEME:DT`` (for the adaptive schemes DT is the first step).
"""

from __future__ import annotations

import argparse
import csv
import json
import subprocess
import sys
import time
from pathlib import Path

DEFAULT = [
    "2562:quartic:adaptive_euler:5e-4",     # reference: the most accurate we can afford at 2562
    "2562:quadratic:adaptive_euler:5e-4",
    "2562:quadratic:euler:2.5e-3",
    "2562:quadratic:euler:1.25e-3",
    "2562:quadratic:heun:2.5e-3",
    "2562:quadratic:adaptive:5e-4",
    "642:quadratic:adaptive_euler:5e-4",    # expected to fail: the ring is not resolved at 642 nodes
]


def one(config: str, scene: str, t_end: float, out: Path) -> dict:
    from cortex_ti import runtime
    from cortex_ti.io import open_trajectory
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    nodes, fit, scheme, dt = config.split(":")
    runtime.init()
    sim = Simulation(load_scene(scene, [f"mesh.nodes={nodes}", f"numerics.fit={fit}", f"time.scheme={scheme}",
                                        f"time.dt={dt}", f"time.t_end={t_end}"]))
    t0 = time.perf_counter()
    sim.run(out, progress=False)
    wall = time.perf_counter() - t0
    with open_trajectory(out) as ds:
        pole, furrow = float(ds["pole_radius"].values[-1]), float(ds["furrow_radius"].values[-1])
        vol = ds["volume"].values
        drift = float(abs(vol[-1] / vol[0] - 1))
    s = sim.stats
    per = {f"ms_{k}": 1e3 * v / max(s.solves, 1) for k, v in sim.seconds.items()}
    return dict(config=config, nodes=int(nodes), fit=fit, scheme=scheme, dt=float(dt), pole=pole, furrow=furrow,
                volume_drift=drift, wall_s=wall, steps=s.steps, solves=s.solves, ms_per_step=1e3 * wall / max(s.steps, 1),
                **per)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="furrow_p4_a1")
    p.add_argument("--t-end", type=float, default=3.0)
    p.add_argument("--configs", nargs="+", default=DEFAULT, help="NODES:FIT:SCHEME:DT, the first is the reference")
    p.add_argument("--out", type=Path, default=Path("results/benchmarks/dynamics.csv"))
    p.add_argument("--reference-json", type=Path, default=None,
                   help="use a finished run as the reference: the JSON line that '--one CONFIG --file F' printed")
    p.add_argument("--one", help=argparse.SUPPRESS)
    p.add_argument("--file", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.one:
        print(json.dumps(one(args.one, args.scene, args.t_end, Path(args.file))))
        return 0
    args.out.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    for k, cfg in enumerate(args.configs):
        traj = args.out.parent / f"dynamics_{k}.h5"
        res = subprocess.run([sys.executable, __file__, "--scene", args.scene, "--t-end", str(args.t_end),
                              "--one", cfg, "--file", str(traj)], capture_output=True, text=True)
        if res.returncode != 0:
            reason = (res.stderr.strip().splitlines() or ["?"])[-1]
            print(f"# {cfg}: failed: {reason}", file=sys.stderr)
            rows.append(dict(config=cfg, failed=reason))
            continue
        rows.append(json.loads(res.stdout.strip().splitlines()[-1]))
        print(f"# {cfg}: {rows[-1]['wall_s']:.0f} s", file=sys.stderr)
    if args.reference_json:
        rows.insert(0, json.loads(args.reference_json.read_text().strip().splitlines()[-1]))
    ok = [r for r in rows if "failed" not in r]
    if not ok:
        return 1
    ref = ok[0]
    for r in ok:
        r["error"] = max(abs(r["pole"] - ref["pole"]), abs(r["furrow"] - ref["furrow"]))
    with open(args.out, "w", newline="") as fh:
        keys = sorted({k for r in rows for k in r})
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    print(f"{args.scene} to t = {args.t_end}; reference {ref['config']} (pole {ref['pole']:.6f}, furrow {ref['furrow']:.6f})\n")
    print("| nodes | fit | scheme | dt | pole | furrow | error vs ref (R0) | volume drift | wall (s) | steps | ms/step | per solve: geometry / assembly / solve (ms) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        if "failed" in r:
            print(f"| {r['config'].replace(':', ' | ')} | failed: {r['failed'][:80]} |")
            continue
        print(f"| {r['nodes']} | {r['fit']} | {r['scheme']} | {r['dt']:g} | {r['pole']:.5f} | {r['furrow']:.5f} | "
              f"{r['error']:.1e} | {r['volume_drift']:.1e} | {r['wall_s']:.0f} | {r['steps']} | {r['ms_per_step']:.0f} | "
              f"{r.get('ms_geometry', 0):.1f} / {r.get('ms_assembly', 0):.1f} / {r.get('ms_solve', 0):.1f} |")
    for limit in (1e-2, 1e-3):
        within = [r for r in ok[1:] if r["error"] <= limit]
        best = min(within, key=lambda r: r["wall_s"]) if within else None
        print(f"\ncheapest within {limit:g} R0: " + (f"{best['config']} ({best['wall_s']:.0f} s, error {best['error']:.1e})"
                                                     if best else "none"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
