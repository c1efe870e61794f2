"""bdf2's default tolerance against the mesh's own error: is the time error below the mesh's?

For ``furrow_p4_a1`` at each node count N, the whole command ``python -m cortex_ti run furrow_p4_a1
-o x.h5 --threads 1 --summary s.json`` runs with ``time.tol`` at the scheme's default for that mesh
(``4e-6 * 10242 / N``, :meth:`cortex_ti.dynamics.schemes.BDF2.default_tol_for`) times each factor
given, and the table gives per run:

* steps, rejected steps, solves and the CPU seconds of the command;
* the largest pole and furrow radius error over the whole run against the axisymmetric twin
  (:func:`cortex_ti.axisymmetric.compare.compare`): the total error, dominated by the mesh's;
* the time error: the largest difference of the pole and furrow radii over the run from those of
  the run at the smallest factor (the reference, whose own time error is left in: the column is a
  lower estimate for it and an upper-side one for the others);
* the mesh's error: the radius error of the initial polyhedron (t = 0, where there is no time error).

Usage::

    python benchmarks/bdf2_tolerance.py                          # 642, 2562, 10242 nodes; factors 1/16, 1/4, 1, 4
    python benchmarks/bdf2_tolerance.py --nodes 2562 --factors 0.0625 1 4
    python benchmarks/bdf2_tolerance.py --smoke                  # 162 nodes, t_end = 0.05 (seconds)
    python benchmarks/bdf2_tolerance.py --write docs/validation/time_schemes.md

``--write`` replaces the block between ``<!-- default_tol:begin -->`` and ``<!-- default_tol:end -->``
of that page with the table (date, commit, machine in its header). Expected cost on 2 cores: about
20 min for the default set, most of it the 10242-node runs at the smallest factors.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

import _bench  # benchmarks/_bench.py
import numpy as np
from _bench import header, run_command, timed_command, write_block

SCENE = "furrow_p4_a1"


def run_one(nodes: int, tol: float, t_end: float | None, workdir: Path) -> dict:
    out, summary = workdir / f"n{nodes}_tol{tol:.3g}.h5", workdir / f"n{nodes}_tol{tol:.3g}.json"
    sets = [f"mesh.nodes={nodes}", f"time.tol={tol!r}", *([f"time.t_end={t_end}"] if t_end is not None else [])]
    _, cpu = timed_command(run_command(SCENE, out, summary, sets, force=True), "bdf2_tolerance")
    s = json.loads(summary.read_text())
    from cortex_ti.axisymmetric.compare import twin_of
    from cortex_ti.io import Trajectory

    tr = Trajectory(out, lazy=True)
    twin = twin_of(tr)
    radii = np.stack([tr.ds["pole_radius"].values, tr.ds["furrow_radius"].values])
    dev = np.abs(radii - np.stack([twin.pole_radius, twin.furrow_radius]))
    times = np.asarray(tr.times)
    tr.close()
    return dict(
        nodes=nodes,
        tol=tol,
        steps=s["steps"],
        rejected=s.get("rejected", 0),
        solves=s["solves"],
        cpu_s=cpu,
        err=float(dev.max()),
        mesh_err=float(dev[:, 0].max()),  # the initial polyhedron's: no time error yet
        radii=radii,
        times=times,
    )


def table(rows: list[dict], t_end: float | None, command: str) -> str:
    load = os.getloadavg()
    head = (
        f"{header()}\n{SCENE} to t_end = {t_end if t_end is not None else 'the scene (3)'}, one thread; "
        f"load average at the end {load[0]:.1f} (`{command}`).\n\n"
    )
    lines = [
        "| N | time.tol | factor of the default | steps (rejected) | solves | CPU s | max radius error vs twin "
        "| time error (vs smallest factor) | mesh's error at t = 0 |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['nodes']} | {r['tol']:.3g} | {r['factor']:g} | {r['steps']} ({r['rejected']}) | {r['solves']} | "
            f"{r['cpu_s']:.1f} | {r['err']:.2e} | {r['time_err']} | {r['mesh_err']:.2e} |"
        )
    return head + "\n".join(lines) + "\n"


def main(argv=None) -> int:
    from cortex_ti.dynamics.schemes import SCHEMES

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562, 10242])
    p.add_argument("--factors", type=float, nargs="+", default=[1 / 16, 1 / 4, 1.0, 4.0])
    p.add_argument("--t-end", type=float, default=None, help="end time (default: the scene's, 3)")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    p.add_argument("--write", type=Path, default=None, help="markdown page whose default_tol block gets the table")
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.factors, args.t_end = [162], [0.25, 1.0], 0.05
    factors = sorted(args.factors)
    rows = []
    with tempfile.TemporaryDirectory(prefix="bdf2-tol-") as tmp:
        for nodes in args.nodes:
            default = SCHEMES["bdf2"].default_tol_for(nodes)
            runs = [run_one(nodes, default * f, args.t_end, Path(tmp)) for f in factors]
            ref = runs[0]
            for f, r in zip(factors, runs, strict=True):
                same = r["times"].shape == ref["times"].shape and np.allclose(r["times"], ref["times"])
                diff = float(np.nanmax(np.abs(r["radii"] - ref["radii"]))) if same else float("nan")
                rows.append({**r, "factor": f, "time_err": "ref." if r is ref else f"{diff:.2e}"})
                print(
                    f"N {nodes} tol {r['tol']:.3g}: {r['steps']} steps, err {r['err']:.2e}, "
                    f"time error {rows[-1]['time_err']}, mesh {r['mesh_err']:.2e}",
                    flush=True,
                )
    command = "python benchmarks/bdf2_tolerance.py" + (" --smoke" if args.smoke else "")
    if not args.smoke and (args.nodes != [642, 2562, 10242] or factors != sorted([1 / 16, 1 / 4, 1.0, 4.0])):
        command += f" --nodes {' '.join(map(str, args.nodes))} --factors {' '.join(f'{f:g}' for f in factors)}"
    text = table(rows, args.t_end, command)
    print(text)
    if args.write is not None and not args.smoke:
        write_block(args.write, text, "default_tol")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
