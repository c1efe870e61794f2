"""The two translation gauges over a whole run: the same shapes up to a rigid motion?

With the tension carried by the material and lagrangian nodes, the two ways of fixing the free
translation (scene key ``translation``: ``mean_velocity`` / ``centroid``) give flows that differ by a
rigid translation, so the runs' nodes differ by one vector per frame. Measured per frame: the
distance between the gauges' centroids of the nodes, the largest difference of the centred nodes,
and that difference after the best rotation (Kabsch), which a rotation would explain. ``--shift``
compares instead one gauge's run with the same run started translated by a vector (the tension
assigned before, so it moves with its nodes): a run must not depend on where the cell is.

The scene (issue 33): ``furrow_p4_a1``'s ring plus ``0.3 Y_10`` (no up-down symmetry, so the
gauges differ), ``tension_transport: material``, ``mesh.motion: lagrangian``, no bending viscosity,
``numerics.active_force`` from ``--force`` (default ``gradient``), ``bdf2`` with ``time.tol`` 1e-10
(``solver.rtol`` 1e-12 so the tolerance is allowed). ``--set`` changes anything (a scheme, a step).

``--keep DIR --gauges centroid`` runs one gauge into ``DIR/centroid.h5`` (so the two gauges can run
as two processes), and ``--compare DIR`` compares the frames the two trajectories in ``DIR`` have in
common, finished or still being written (``.partial``).

Usage::

    python benchmarks/gauge_run.py                              # 642 nodes, t = 0.5, gradient
    python benchmarks/gauge_run.py --force balanced --nodes 2562
    python benchmarks/gauge_run.py --shift 0.3 -0.2 0.5 --t-end 0.05
    python benchmarks/gauge_run.py --force balanced --nodes 2562 --keep d --gauges centroid   # and mean_velocity
    python benchmarks/gauge_run.py --compare d

Cost (one core): 642 nodes to t = 0.5 about 15 s a run (1650 steps), 2562 nodes about 2.5 min.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

Y10 = {"type": "harmonics", "terms": [{"l": 1, "m": 0, "coeff": 0.3}]}


def scene_data(nodes, t_end, frames, force, sets):
    from cortex_ti.scene import load_scene

    over = [
        f"mesh.nodes={nodes}",
        f"time.t_end={t_end}",
        f"time.save_every={t_end / frames}",
        "mesh.motion=lagrangian",
        "tension_transport=material",
        "time.tol=1e-10",
        "solver.rtol=1e-12",
        f"numerics.active_force={force}",
        *sets,
    ]
    data = copy.deepcopy(load_scene("furrow_p4_a1", over).data)
    data["effects"] = [e for e in data["effects"] if e != "bending_viscosity"]
    data["viscosity"].update(bending=0.0, bending_bulk=0.0)
    data["active_stress"] = data["active_stress"] + [Y10]
    return data


def frames(path):
    """Times and points of the committed frames of a trajectory, finished or being written."""
    from cortex_ti.io.readers import load_trajectory

    ds = load_trajectory(path)
    return ds["time"].values.copy(), ds["points"].values.copy()


def table(times, xa, xb, header: str) -> None:
    print(f"\n{header}")
    print("| t | centroid distance | largest difference, centred | after the best rotation |")
    print("|---|---|---|---|")
    for k in range(min(len(xa), len(xb))):
        d, c, r = compare(xa[k], xb[k])
        print(f"| {times[k]:.4g} | {d:.3e} | {c:.2e} | {r:.2e} |")


def run(data, gauge, where, name, shift=None):
    """The frames (times, points) of one run and its steps."""
    from cortex_ti.dynamics.state import State
    from cortex_ti.io import Trajectory
    from cortex_ti.scene import scene_from_dict
    from cortex_ti.simulation import Simulation

    data = copy.deepcopy(data)
    data["translation"] = gauge
    sim = Simulation(scene_from_dict(data))
    if shift is not None:  # the start translated, the tension (assigned already) with its nodes
        sim.use_mesh(sim.mesh.points + shift, sim.mesh.faces)
        sim.state0 = State(sim.state0.points + shift, sim.state0.fields, sim.state0.faces)
    path = sim.run(where / f"{name}.h5", progress=False)
    with Trajectory(path) as tr:
        return tr.ds["time"].values.copy(), tr.ds["points"].values.copy(), sim.stats.steps


def compare(a: np.ndarray, b: np.ndarray) -> tuple[float, float, float]:
    """Centroid distance, largest difference of the centred nodes, and the same after the best
    rotation of ``a`` onto ``b``."""
    p, q = a - a.mean(0), b - b.mean(0)
    u, _, vt = np.linalg.svd(p.T @ q)
    rot = u @ np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))]) @ vt
    return float(np.linalg.norm(a.mean(0) - b.mean(0))), float(np.abs(p - q).max()), float(np.abs(p @ rot - q).max())


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, default=642)
    p.add_argument("--t-end", type=float, default=0.5)
    p.add_argument("--frames", type=int, default=5, help="frames compared after t = 0")
    p.add_argument("--force", default="gradient", help="numerics.active_force")
    p.add_argument("--shift", type=float, nargs=3, default=None, help="compare with the start moved by this vector")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--gauges", nargs="+", default=None, help="run only these gauges (with --keep)")
    p.add_argument("--keep", default=None, help="write the trajectories into this folder and keep them")
    p.add_argument("--compare", default=None, metavar="DIR", help="compare the two gauges' trajectories in DIR")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.compare is not None:
        from pathlib import Path

        (ta, xa), (tb, xb) = (frames(Path(args.compare) / f"{g}.h5") for g in ("mean_velocity", "centroid"))
        n = min(len(ta), len(tb))
        if not np.allclose(ta[:n], tb[:n]):
            raise SystemExit("the two trajectories' frame times differ")
        table(ta[:n], xa, xb, f"gauges, {args.compare}: the frames both runs have reached")
        return 0
    if args.smoke:
        args.nodes, args.t_end, args.frames = 162, 0.004, 2
    if args.keep is not None:
        from pathlib import Path

        where = Path(args.keep)
        where.mkdir(parents=True, exist_ok=True)
    else:
        where = _bench.folder()
    data = scene_data(args.nodes, args.t_end, args.frames, args.force, args.sets)
    if args.shift is None:
        cases = [(g, g, None) for g in (args.gauges or ["mean_velocity", "centroid"])]
    else:
        cases = [("mean_velocity", "here", None), ("mean_velocity", "shifted", np.array(args.shift))]
    out = []
    for gauge, name, shift in cases:
        t0 = time.perf_counter()
        out.append(run(data, gauge, where, name, shift))
        print(f"{name}: {out[-1][2]} steps, {time.perf_counter() - t0:.0f} s", flush=True)
    if len(out) != 2:
        return 0
    (times, xa, _), (_, xb, _) = out
    what = "start moved" if args.shift is not None else "gauges"
    table(times, xa, xb, f"{args.nodes} nodes, active_force {args.force}, {what}; {' '.join(args.sets)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
