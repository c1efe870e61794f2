"""What a paper furrow costs: wall time, steps, solves and time per stage, with the error of the radii.

For the three furrows of the paper (``furrow_p8_a1``, ``furrow_p4_a1``, ``furrow_p4_a3``) at each
node count, the whole command ``cortex-ti run SCENE -o x.h5 --threads 1 --summary s.json`` is run
in its own process (start-up and Taichi's cached kernels included, as a user sees it) with the
scene's defaults, and the table gives:

* wall and CPU seconds of the command (CPU: user + system of the child; on a shared machine the
  CPU time is the steadier number), and the wall time as a ratio to a fixed SciPy workload timed
  just before (:func:`reference_seconds`: SuperLU of a 2D Laplacian), which carries from one
  machine or load to another better than seconds;
* steps, solves, factorisations and GMRES iterations of the run;
* milliseconds per solve of geometry, assembly and solve (wall, from the run's summary);
* the largest radius error (pole and furrow) over the whole run against the axisymmetric twin
  (:func:`cortex_ti.axisymmetric.compare.compare`, the same model solved along the meridian), from
  the trajectory's section radii, and at the nodes (the pole node's height, the equator nodes' mean
  radius): a flat section of ``rayleigh_p1`` lies O(h^2) inside the surface its nodes are on, so the
  nodes' column is the one that compares flat and curved cells fairly.

Usage::

    python benchmarks/furrow_cost.py                            # 642 and 2562 nodes, t_end = 3
    python benchmarks/furrow_cost.py --nodes 10242 --scenes furrow_p4_a1
    python benchmarks/furrow_cost.py --smoke                    # furrow_p8_a1, 162 nodes, t_end = 0.02
    python benchmarks/furrow_cost.py --write docs/validation/speed.md
    python benchmarks/furrow_cost.py --scenes furrow_p4_a1 --nodes 642 2562 10242 \
        --set numerics.formulation=rayleigh_p2 --set numerics.fit=quartic --write docs/validation/curved_cost.md \
        --block curved_cost                                   # the curved cells (docs/validation/curved_cost.md)

``--set KEY=VALUE`` (repeatable) is passed to every run (the formulation and fit are in the table).
``--write`` replaces the block between ``<!-- furrow_cost:begin -->`` and
``<!-- furrow_cost:end -->`` (``--block NAME``: ``<!-- NAME:begin -->`` ...) of that page with the
table (date, commit, machine in its header).
Expected cost on a 2-core machine: ~1 min per furrow at 642 nodes and ~1-2 min at 2562 nodes,
with Euler at dt = 5e-3 (600 steps); minutes per furrow at 10242.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
from _bench import header, reference_seconds, run_command, timed_command, write_block

SCENES = ("furrow_p8_a1", "furrow_p4_a1", "furrow_p4_a3")


def run_one(scene: str, nodes: int, t_end: float | None, workdir: Path, sets=()) -> dict:
    """One ``cortex-ti run`` in a child process, its summary, CPU time and radius error."""
    out = workdir / f"{scene}_{nodes}.h5"
    summary = workdir / f"{scene}_{nodes}.json"
    own = [f"mesh.nodes={nodes}", *([f"time.t_end={t_end}"] if t_end is not None else [])]
    wall, cpu = timed_command(run_command(scene, out, summary, [*own, *sets]), "furrow_cost")
    s = json.loads(summary.read_text())
    from cortex_ti.axisymmetric.compare import compare

    c = compare(str(out), times=())
    return dict(
        scene=scene,
        nodes=nodes,
        formulation=f"{s.get('formulation', '?')}, {s.get('fit', '?')}",
        wall_s=wall,
        cpu_s=cpu,
        steps=s["steps"],
        solves=s["solves"],
        factorizations=s.get("factorizations"),
        iterations=s.get("krylov_iterations"),
        t_reached=s["t_reached"],
        ms=[s.get(f"ms_{k}_per_solve", float("nan")) for k in ("geometry", "assembly", "solve")],
        err=max(c["pole_radius"][0], c["furrow_radius"][0]),
        err_pole=c["pole_radius"][0],
        err_furrow=c["furrow_radius"][0],
        err_nodes=c["node_radii"],
    )


def table(rows: list[dict], ref: float, t_end: float | None, sets=()) -> str:
    load = os.getloadavg()
    head = (
        f"{header()}\nOne thread (`--threads 1`, MKL/OpenBLAS 1 thread); "
        f"t_end = {t_end if t_end is not None else 'scene (3)'}; "
        + "".join(f"`--set {kv}`; " for kv in sets)
        + f"reference SciPy workload {ref * 1e3:.0f} ms; load average at the end {load[0]:.1f} "
        f"(`python benchmarks/furrow_cost.py{' --smoke' if t_end is not None else ''}`).\n\n"
    )
    lines = [
        "| scene | formulation, fit | N | wall s | CPU s | wall / ref | steps | solves | factorisations | GMRES it. | "
        "ms geometry / assembly / solve per solve | max radius error (pole, furrow) | at the nodes (pole, equator) |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        g, a, s = r["ms"]
        lines.append(
            f"| {r['scene']} | {r['formulation']} | {r['nodes']} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | "
            f"{r['wall_s'] / ref:.0f} | "
            f"{r['steps']} | {r['solves']} | {r['factorizations']} | {r['iterations']} | "
            f"{g:.1f} / {a:.1f} / {s:.1f} | {r['err']:.2e} ({r['err_pole']:.1e}, {r['err_furrow']:.1e}) | "
            f"{max(r['err_nodes']):.2e} ({r['err_nodes'][0]:.1e}, {r['err_nodes'][1]:.1e}) |"
        )
    return head + "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    p.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES)
    p.add_argument("--t-end", type=float, default=None, help="end time (default: the scene's, 3)")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    p.add_argument("--write", type=Path, default=None, help="markdown page whose furrow_cost block gets the table")
    p.add_argument("--keep", type=Path, default=None, help="keep the trajectories in this folder")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="passed to every run")
    p.add_argument("--block", default="furrow_cost", help="the block of the --write page that gets the table")
    args = p.parse_args(argv)
    nodes, t_end = ([162], 0.02) if args.smoke else (args.nodes, args.t_end)
    if args.smoke:  # one run: the others take the same code path
        args.scenes = args.scenes[:1]
    ref = reference_seconds()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        for n in nodes:
            for scene in args.scenes:
                rows.append(run_one(scene, n, t_end, work, args.sets))
                print(f"{scene} {n}: {rows[-1]['wall_s']:.1f} s", file=sys.stderr, flush=True)
    text = table(rows, ref, t_end, args.sets)
    print(text)
    if args.write:
        write_block(args.write, text, args.block)
    return 0


if __name__ == "__main__":
    sys.exit(main())
