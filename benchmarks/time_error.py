"""Time error against steps and CPU time: each time scheme and tolerance against a time-converged run.

For one furrow scene at each node count, the whole command ``cortex-ti run SCENE -o x.h5 --threads 1
--summary s.json`` runs once per ``SCHEME:TOL`` given (``--runs``; ``default`` for the scheme's own
tolerance at that mesh) and once for the reference (``--reference``, a much tighter tolerance), all
with the ``--set`` options, and the table gives per run:

* steps (rejected), solves, and the CPU seconds (user + system) and wall seconds of the command;
* the time error: the largest difference over all frames (every ``time.save_every``: the dense
  schemes interpolate them) of the pole and furrow radii (the run's diagnostics) from the
  reference's: the scheme's error in time, the mesh's being the same in both;
* the total error: the largest pole and furrow radius error over the run against the axisymmetric
  twin (:func:`cortex_ti.axisymmetric.compare.compare`, as ``furrow_cost.py``).

Usage::

    python benchmarks/time_error.py --nodes 642 2562 --set numerics.formulation=rayleigh_p2 \\
        --set numerics.fit=quartic --runs bdf2:default bdf3:default bdf3:1e-6 --reference bdf3:1e-9
    python benchmarks/time_error.py --smoke          # 162 nodes, t_end = 0.05 (seconds)
    python benchmarks/time_error.py ... --write docs/validation/time_schemes.md --block bdf3_furrow

``--write`` replaces the block between ``<!-- NAME:begin -->`` and ``<!-- NAME:end -->`` of that page
(``--block NAME``, default ``time_error``) with the table. Cost: the runs' own (seconds to a minute
each at 642-2562 nodes; the reference the most).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np
from _bench import header, run_command, timed_command, write_block


def run_one(scene: str, nodes: int, scheme: str, tol: str, workdir: Path, sets=(), t_end=None) -> dict:
    """One ``cortex-ti run`` in a child process: its summary, CPU time, radii over the frames and error vs the twin."""
    out = workdir / f"{scene}_{nodes}_{scheme}_{tol}.h5"
    summary = out.with_suffix(".json")
    own = [f"mesh.nodes={nodes}", f"time.scheme={scheme}"]
    own += [f"time.tol={tol}"] if tol != "default" else []
    own += [f"time.t_end={t_end}"] if t_end is not None else []
    wall, cpu = timed_command(run_command(scene, out, summary, [*own, *sets], force=True), "time_error")
    s = json.loads(summary.read_text())
    from cortex_ti.axisymmetric.compare import compare
    from cortex_ti.io import Trajectory

    tr = Trajectory(out, lazy=True)
    radii = np.stack([tr.ds["pole_radius"].values, tr.ds["furrow_radius"].values])
    times = np.asarray(tr.times)
    tr.close()
    c = compare(str(out), times=())
    return dict(
        nodes=nodes,
        scheme=scheme,
        tol=tol,
        steps=s["steps"],
        rejected=s.get("rejected", 0),
        solves=s["solves"],
        cpu_s=cpu,
        wall_s=wall,
        radii=radii,
        times=times,
        err=max(c["pole_radius"][0], c["furrow_radius"][0]),
    )


def time_errors(rows: list[dict], ref: dict) -> None:
    """Each row's largest radius difference from the reference over the frames (pole, furrow)."""
    for r in rows:
        same = r["times"].shape == ref["times"].shape and np.allclose(r["times"], ref["times"])
        d = np.abs(r["radii"] - ref["radii"]) if same else np.full((2, 1), np.nan)
        r["time_err"] = (float(np.nanmax(d)), float(np.nanmax(d[0])), float(np.nanmax(d[1])))


def table(rows: list[dict], scene: str, sets, t_end) -> str:
    load = os.getloadavg()
    head = (
        f"{header()}\n{scene} to t_end = {t_end if t_end is not None else 'the scene (3)'}, one thread; "
        f"{'; '.join(f'`--set {kv}`' for kv in sets) or 'the scene defaults'}; load average at the end "
        f"{load[0]:.1f} (`python benchmarks/time_error.py`).\n\n"
    )
    lines = [
        "| N | scheme | time.tol | steps (rejected) | solves | CPU s | wall s | time error (pole, furrow) "
        "| max radius error vs twin |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        te = r["time_err"]
        tcell = "ref." if r.get("reference") else f"{te[0]:.2e} ({te[1]:.1e}, {te[2]:.1e})"
        lines.append(
            f"| {r['nodes']} | {r['scheme']} | {r['tol']} | {r['steps']} ({r['rejected']}) | {r['solves']} | "
            f"{r['cpu_s']:.1f} | {r['wall_s']:.1f} | {tcell} | {r['err']:.2e} |"
        )
    return head + "\n".join(lines) + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scene", default="furrow_p4_a1")
    p.add_argument("--nodes", type=int, nargs="+", default=[642])
    p.add_argument("--runs", nargs="+", default=["bdf2:default", "bdf3:default"], metavar="SCHEME:TOL")
    p.add_argument("--reference", default="bdf3:1e-9", metavar="SCHEME:TOL")
    p.add_argument("--t-end", type=float, default=None, help="end time (default: the scene's)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="passed to every run")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    p.add_argument("--write", type=Path, default=None, help="markdown page whose block gets the table")
    p.add_argument("--block", default="time_error")
    p.add_argument("--keep", type=Path, default=None, help="keep the trajectories in this folder")
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.t_end, args.reference = [162], 0.05, "bdf3:1e-7"
    rows = []
    with tempfile.TemporaryDirectory(prefix="time-error-") as tmp:
        work = args.keep if args.keep is not None and not args.smoke else Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        for nodes in args.nodes:
            scheme, tol = args.reference.split(":")
            ref = {**run_one(args.scene, nodes, scheme, tol, work, args.sets, args.t_end), "reference": True}
            runs = [run_one(args.scene, nodes, *spec.split(":"), work, args.sets, args.t_end) for spec in args.runs]
            time_errors([ref, *runs], ref)
            rows += [ref, *runs]
            for r in (ref, *runs):
                print(f"N {nodes} {r['scheme']} tol {r['tol']}: {r['steps']} steps, {r['cpu_s']:.1f} CPU s, "
                      f"time error {r['time_err'][0]:.2e}, vs twin {r['err']:.2e}", flush=True)  # fmt: skip
    text = table(rows, args.scene, args.sets, args.t_end)
    print(text)
    if args.write is not None and not args.smoke:
        write_block(args.write, text, args.block)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
