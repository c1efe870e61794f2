"""Time schemes on the dynamic paper scenes: what a run costs and how far its end state is from today's.

For each scene, node count and scheme configuration, the whole command ``python -m cortex_ti run
SCENE -o x.h5 --threads 1 --summary s.json`` runs in its own process (start-up included, as a user
sees it; the package of this checkout), and the table gives:

* wall and CPU seconds of the command, and the wall time as a ratio to a fixed SciPy workload
  timed before the runs (``furrow_cost.reference_seconds``), which carries across machines and loads;
* steps, rejected steps and solves;
* for the axisymmetric scenes (the furrows), the largest pole and furrow radius error over the
  whole run against the axisymmetric twin (:func:`cortex_ti.axisymmetric.compare.compare`);
* the end state against the Euler run of the same scene and mesh (``euler``, today's default:
  dt = 5e-3, semi-implicit tension): the largest node distance at t_end, and Euler's own time
  error there, estimated by Richardson from the Euler run at half the step (``euler_half``): a
  first-order scheme's error at dt is about twice its change when dt is halved.

The configurations are explicit (they do not depend on the scenes' defaults):

* ``euler``: ``time.scheme=euler, time.dt=5e-3`` (the scenes' default before bdf2);
* ``euler_half``: the same at ``time.dt=2.5e-3`` (for the Richardson estimate only);
* ``adaptive_euler``: ``time.scheme=adaptive_euler, time.dt=5e-3`` (its default tolerance 1e-4);
* ``bdf2``: ``time.scheme=bdf2, time.dt=1e-3, time.tol=4e-6, time.dt_max=0.2``;
* ``bdf2_default``: ``time.scheme=bdf2`` and the scene's defaults (``time.tol`` 4e-6 * 10242 / N).

Usage::

    python benchmarks/time_schemes.py --scenes furrow_p4_a1 --nodes 642 2562 --configs euler adaptive_euler bdf2
    python benchmarks/time_schemes.py --nodes 642 2562            # every dynamic paper scene, euler(+half) and bdf2
    python benchmarks/time_schemes.py --smoke                      # 162 nodes, t_end = 0.02, euler(+half) (seconds)
    python benchmarks/time_schemes.py ... --write docs/validation/time_schemes.md

``--write`` replaces the block between ``<!-- NAME:begin -->`` and ``<!-- NAME:end -->`` of that page,
NAME given by ``--block`` (default ``time_schemes``), with the table (date, commit, machine in its
header). Expected cost on 2 cores: ~1 min per scene at 642 nodes (all configurations), 2-3 min at 2562.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import _bench  # benchmarks/_bench.py
import numpy as np
from _bench import header, reference_seconds, write_block

ROOT = Path(__file__).resolve().parents[1]
SCENES = (
    "furrow_p8_a1",
    "furrow_p4_a1",
    "furrow_p4_a3",
    "fold_broad",
    "fold_narrow",
    "shear_035",
    "shear_035_tilted",
    "shear_075",
)
AXISYMMETRIC = ("furrow_p8_a1", "furrow_p4_a1", "furrow_p4_a3")
CONFIGS = {
    "euler": ("time.scheme=euler", "time.dt=5e-3"),
    "euler_half": ("time.scheme=euler", "time.dt=2.5e-3"),
    "adaptive_euler": ("time.scheme=adaptive_euler", "time.dt=5e-3"),
    "bdf2": ("time.scheme=bdf2", "time.dt=1e-3", "time.tol=4e-6", "time.dt_max=0.2"),
    "bdf2_default": ("time.scheme=bdf2",),  # the scene's own step control: tol 4e-6 * 10242 / N
}


def run_one(scene: str, nodes: int, config: str, t_end: float | None, workdir: Path, reuse: bool = False) -> dict:
    """One run in a child process: its summary, CPU time and (furrows) radius errors. A run that
    fails is a row too (``stopped``: its one-line error; nothing to compare). ``reuse``: take a run
    kept in ``workdir`` by an earlier call (its wall time from its summary, no CPU time)."""
    out = workdir / f"{scene}_{nodes}_{config}.h5"
    summary = out.with_suffix(".json")
    if reuse and summary.exists() and (out.exists() or json.loads(summary.read_text()).get("status") != "ok"):
        return _row(scene, nodes, config, out, json.loads(summary.read_text()), None, float("nan"))
    cmd = [sys.executable, "-m", "cortex_ti", "run", scene, "-o", str(out), "--threads", "1"]
    cmd += ["--summary", str(summary), "--set", f"mesh.nodes={nodes}"]
    for s in CONFIGS[config] + ((f"time.t_end={t_end}",) if t_end is not None else ()):
        cmd += ["--set", s]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t = time.perf_counter()
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=workdir)
    wall = time.perf_counter() - t
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if not summary.exists():
        raise SystemExit(f"time_schemes: {' '.join(cmd)} wrote no summary:\n{proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return _row(scene, nodes, config, out, json.loads(summary.read_text()), wall, cpu)


def _row(scene: str, nodes: int, config: str, out: Path, s: dict, wall: float | None, cpu: float) -> dict:
    failed = s.get("status") != "ok"
    row = dict(
        scene=scene,
        nodes=nodes,
        config=config,
        path=None if failed else out,
        wall_s=s.get("wall_s", float("nan")) if wall is None else wall,
        cpu_s=cpu,
        steps=s.get("steps", 0),
        rejected=s.get("rejected", 0),
        solves=s.get("solves", 0),
        t_reached=s.get("t_reached", float("nan")),
        stopped=f"failed ({s.get('stopped')})" if failed else s["stopped"],
        err=float("nan"),
    )
    if scene in AXISYMMETRIC and not failed:
        from cortex_ti.axisymmetric.compare import compare

        c = compare(str(out), times=())
        row.update(err=max(c["pole_radius"][0], c["furrow_radius"][0]), err_pole=c["pole_radius"][0])
    return row


def end_points(path: Path) -> np.ndarray:
    from cortex_ti.io import load_trajectory

    ds = load_trajectory(path)
    return np.asarray(ds["points"].values[-1])


def end_differences(rows: list[dict]) -> None:
    """Each row's end state against the Euler run of its scene and mesh, and Euler's own time error
    (Richardson: twice its change from dt to dt / 2), where those runs exist."""
    by = {(r["scene"], r["nodes"], r["config"]): r for r in rows}
    for r in rows:
        base = by.get((r["scene"], r["nodes"], "euler"))
        half = by.get((r["scene"], r["nodes"], "euler_half"))
        r["d_euler"] = float("nan")
        r["euler_error"] = float("nan")
        if r["path"] is None or (half is not None and half["path"] is None):
            continue
        if base is not None and base["path"] is not None:
            x = end_points(base["path"])
            r["d_euler"] = float(np.max(np.linalg.norm(end_points(r["path"]) - x, axis=1)))
            if half is not None:
                r["euler_error"] = 2.0 * float(np.max(np.linalg.norm(end_points(half["path"]) - x, axis=1)))


def table(rows: list[dict], ref: float, t_end: float | None, command: str) -> str:
    load = os.getloadavg()
    head = (
        f"{header()}\nOne thread; t_end = {t_end if t_end is not None else 'the scene'}; reference SciPy workload "
        f"{ref * 1e3:.0f} ms; load average at the end {load[0]:.1f} (`{command}`).\n\n"
    )
    lines = [
        "| scene | N | scheme | wall s | CPU s | wall / ref | steps (rejected) | solves | t reached | "
        "max radius error vs axisymmetric | end state vs euler | euler's time error at t_end |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r['scene']} | {r['nodes']} | {r['config']} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | "
            f"{r['wall_s'] / ref:.0f} | {r['steps']} ({r['rejected']}) | {r['solves']} | {r['t_reached']:.4g}"
            f"{'' if r['stopped'] in ('t_end', 'steady') else ', ' + r['stopped']} | "
            f"{r['err']:.2e} | {r['d_euler']:.2e} | {r['euler_error']:.2e} |"
        )
    return head + "\n".join(lines).replace("nan", "-") + "\n"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    p.add_argument("--scenes", nargs="+", default=list(SCENES), choices=SCENES)
    p.add_argument("--configs", nargs="+", default=["euler", "euler_half", "bdf2"], choices=list(CONFIGS))
    p.add_argument("--t-end", type=float, default=None, help="end time (default: the scene's)")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    p.add_argument("--write", type=Path, default=None, help="markdown page whose time_schemes block gets the table")
    p.add_argument("--keep", type=Path, default=None, help="keep the trajectories in this folder")
    p.add_argument("--block", default="time_schemes", help="name of the page's block to replace (default time_schemes)")
    p.add_argument("--reuse", action="store_true", help="with --keep: take the runs kept there by an earlier call")
    args = p.parse_args(argv)
    if args.smoke:
        # euler and euler_half run every path (the runs, the twin comparison, the end differences and
        # Euler's Richardson error); a third scheme would only repeat run_one in one more process
        args.nodes, args.t_end, args.scenes, args.configs = [162], 0.02, ["furrow_p4_a1"], ["euler", "euler_half"]
    ref = reference_seconds(1 if args.smoke else 5)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        work = args.keep or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        for n in args.nodes:
            for scene in args.scenes:
                for config in args.configs:
                    rows.append(run_one(scene, n, config, args.t_end, work, args.reuse and args.keep is not None))
                    print(f"{scene} {n} {config}: {rows[-1]['wall_s']:.1f} s", file=sys.stderr, flush=True)
        end_differences(rows)
    command = "python benchmarks/time_schemes.py " + " ".join(argv if argv is not None else sys.argv[1:])
    text = table(rows, ref, args.t_end, command.strip())
    print(text)
    if args.write:
        write_block(args.write, text, args.block)
    return 0


if __name__ == "__main__":
    sys.exit(main())
