"""Do the dynamic scenes run, and agree across time steps? The run matrix of issue 13.

Every scene given (default: every furrow, fold and shear scene) at each node count, with the
bending viscosity off and with the scene's own, by fixed-step Euler (the semi-implicit tension,
the default for Euler) at each step, to the scene's end time; each run in its own process
(``cortex-ti run``, its summary kept), finished runs skipped when the command is repeated. Then
one table row per run: how it ended, steps and wall time, the radii at the end (pole, furrow,
or the orientation for a sheared start), the largest difference over the run's frames from the
same configuration with the smallest step (the time error: it should fall in proportion to the
step), and for the axisymmetric scenes the largest radius error against the axisymmetric
solution of the same scene (:mod:`cortex_ti.axisymmetric.compare`).

Usage::

    python benchmarks/hard_runs.py --out runs/hard --jobs 2            # the whole matrix (hours)
    python benchmarks/hard_runs.py --out runs/hard --scenes furrow_p4_a1 --nodes 642 --dts 5e-3 1e-3
    python benchmarks/hard_runs.py --out runs/hard --table-only         # the table of what has run

``--set KEY=VALUE`` passes overrides to every run (e.g. ``numerics.formulation=paper``).
"""

from __future__ import annotations

import argparse
import itertools
import json
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

SCENES = (
    "furrow_p8_a1",
    "furrow_p4_a1",
    "furrow_p4_a3",
    "fold_narrow",
    "fold_broad",
    "shear_035",
    "shear_035_tilted",
    "shear_075",
)
NO_BENDING = ["viscosity.bending=0", "viscosity.bending_bulk=0"]


def label(scene, nodes, bending, dt) -> str:
    return f"{scene}_N{nodes}_b{'on' if bending else 'off'}_dt{dt:g}"


def command(scene, nodes, bending, dt, out: Path, overrides) -> list[str]:
    from cortex_ti.scene import load_scene

    ov = [f"mesh.nodes={nodes}", "time.scheme=euler", f"time.dt={dt:g}", "time.save_every=0.05", *overrides]
    if not bending:
        effects = sorted(e for e in load_scene(scene).effects if e != "bending_viscosity")
        ov += NO_BENDING + ["effects=[" + ",".join(effects) + "]"]
    name = label(scene, nodes, bending, dt)
    cmd = [
        sys.executable,
        "-m",
        "cortex_ti",
        "run",
        scene,
        "-o",
        str(out / f"{name}.h5"),
        "--summary",
        str(out / f"{name}.json"),
    ]
    for o in ov:
        cmd += ["--set", o]
    return cmd


def run_one(args) -> str:
    cmd, out, name = args
    if (out / f"{name}.json").exists() and json.loads((out / f"{name}.json").read_text()).get("status") == "ok":
        return f"{name}: done before"
    with open(out / f"{name}.log", "w") as log:
        rc = subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT).returncode
    return f"{name}: exit {rc}"


def measured(scene: str) -> tuple[str, ...]:
    """What a scene's run is compared by: the orientation for a sheared start, the fold depth
    for a fold, the pole and furrow radii for a ring."""
    if scene.startswith("shear"):
        return ("orientation_angle", "pole_radius_long_axis")
    if scene.startswith("fold"):
        return ("pole_radius", "fold_depth")
    return ("pole_radius", "furrow_radius")


def table(out: Path, scenes, nodes_list, dts) -> None:
    from cortex_ti.io import Trajectory
    from cortex_ti.studies.stores import fold_series

    print(
        "| scene | N | bending | dt | status | t reached | steps | wall s | at the end (ring: pole, furrow radius; "
        "fold: pole radius, depth; shear: angle deg, pole radius) | largest difference from the smallest dt | "
        "error against the axisymmetric solution |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for scene, nodes, bending in itertools.product(scenes, nodes_list, (False, True)):
        finest = None
        for dt in sorted(dts):
            name = label(scene, nodes, bending, dt)
            summary = out / f"{name}.json"
            if not summary.exists():
                continue
            s = json.loads(summary.read_text())
            path = out / f"{name}.h5"
            row = [
                scene,
                str(nodes),
                "on" if bending else "off",
                f"{dt:g}",
                s.get("status", "?"),
                f"{s.get('t_reached', float('nan')):.3g}",
                str(s.get("steps", "")),
                f"{s.get('wall_s', 0):.0f}",
            ]
            if s.get("status") != "ok" or not path.exists():
                print("| " + " | ".join(row + [s.get("error", "")[:80], "", ""]) + " |")
                continue
            with Trajectory(path, lazy=True) as tr:
                series = fold_series(tr) if scene.startswith("fold") else {}
                values = {v: np.asarray(series[v] if v in series else tr.ds[v].values) for v in measured(scene)}
                t = tr.times
            ends = ", ".join(f"{v[-1]:.5g}" for v in values.values())
            if finest is None:
                finest = (t, values)
                diff = "(reference)"
            else:
                common = np.intersect1d(np.round(t, 9), np.round(finest[0], 9))
                d = max(
                    float(np.max(np.abs(np.interp(common, t, values[v]) - np.interp(common, finest[0], finest[1][v]))))
                    for v in values
                )
                diff = f"{d:.2e}"
            twin = ""
            if scene.startswith("furrow"):
                from cortex_ti.axisymmetric.compare import compare

                r = compare(str(path))
                twin = f"{max(r['pole_radius'][0], r['furrow_radius'][0]):.2e}"
            print("| " + " | ".join(row + [ends, diff, twin]) + " |", flush=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, default=None, help="folder for the runs (created; required)")
    p.add_argument("--scenes", nargs="+", default=list(SCENES))
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    p.add_argument("--dts", type=float, nargs="+", default=[5e-3, 1e-3])
    p.add_argument("--bending", choices=["both", "on", "off"], default="both")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--jobs", type=int, default=1, help="runs side by side (one thread each)")
    p.add_argument("--table-only", action="store_true")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:  # one scene, the coarse mesh, one step, a few steps of it
        args.out, args.scenes, args.nodes, args.dts, args.bending = (
            _bench.folder(),
            ["furrow_p4_a1"],
            [162],
            [5e-3],
            "on",
        )
        args.overrides = [*args.overrides, "time.t_end=0.05"]
    if args.out is None:
        p.error("--out is required")
    args.out.mkdir(parents=True, exist_ok=True)
    bendings = {"both": (False, True), "on": (True,), "off": (False,)}[args.bending]
    if not args.table_only:
        work = []
        # cheapest first: coarse meshes and large steps
        for nodes, dt, scene, bending in itertools.product(
            sorted(args.nodes), sorted(args.dts, reverse=True), args.scenes, bendings
        ):
            name = label(scene, nodes, bending, dt)
            work.append((command(scene, nodes, bending, dt, args.out, args.overrides), args.out, name))
        with ThreadPoolExecutor(max_workers=args.jobs) as pool:
            for line in pool.map(run_one, work):
                print(line, flush=True)
    table(args.out, args.scenes, args.nodes, args.dts)
    return 0


if __name__ == "__main__":
    sys.exit(main())
