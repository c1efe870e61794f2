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

Usage::

    python benchmarks/gauge_run.py                              # 642 nodes, t = 0.5, gradient
    python benchmarks/gauge_run.py --force balanced --nodes 2562
    python benchmarks/gauge_run.py --shift 0.3 -0.2 0.5 --t-end 0.05

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
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.t_end, args.frames = 162, 0.004, 2
    where = _bench.folder()
    data = scene_data(args.nodes, args.t_end, args.frames, args.force, args.sets)
    if args.shift is None:
        cases = [("mean_velocity", "mean_velocity", None), ("centroid", "centroid", None)]
    else:
        cases = [("mean_velocity", "here", None), ("mean_velocity", "shifted", np.array(args.shift))]
    out = []
    for gauge, name, shift in cases:
        t0 = time.perf_counter()
        out.append(run(data, gauge, where, name, shift))
        print(f"{name}: {out[-1][2]} steps, {time.perf_counter() - t0:.0f} s", flush=True)
    (times, xa, _), (_, xb, _) = out
    what = "start moved" if args.shift is not None else "gauges"
    print(f"\n{args.nodes} nodes, active_force {args.force}, {what}; {' '.join(args.sets)}")
    print("| t | centroid distance | largest difference, centred | after the best rotation |")
    print("|---|---|---|---|")
    for k, t in enumerate(times):
        d, c, r = compare(xa[k], xb[k])
        print(f"| {t:.4g} | {d:.3e} | {c:.2e} | {r:.2e} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
