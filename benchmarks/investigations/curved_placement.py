"""Question: What does placing a remeshing's new nodes on the old curved cells buy, against placing
them on the flat sub-triangles (rayleigh_p2)?

Answer: the geometry, by two orders of magnitude; on a deep furrow not the velocity jump, which is
the new mesh's own discrete equilibrium, not the placement. At 2562 velocity nodes (d9a6da2,
2026-12-07, docs/validation/remesh_constriction.md, "Curved cells"): on the sphere the volume a
remeshing changes before it is restored is -6.9e-6 (curved) against -1.4e-3 (flat), the area change
after the restoration 2.8e-9 against 5.0e-6, the velocity right after 3.9e-3 of max|v| from the old
flow against 0.44 (the flat nodes' sagitta bends the new mesh at its own scale), its error against
the exact sphere flow 5.9e-3 against 0.44 (the old mesh's 2.1e-3); on amplitude 12's furrow at
t = 0.6 the volume change is -3.4e-5 against -3.5e-3 and the area change -2.6e-5 against -8.6e-4,
but the velocity jumps by 1.7 (curved) and 2.0 (flat) of max|v| (rms 0.25 and 0.36), almost all of
it normal, in the furrow's flanks, and larger at 2562 nodes than at 642 (1.1, 1.6): the new mesh's
mesh-scale equilibrium differs from the old one's whatever the placement (the settling after a
remeshing, mesh.remesh.settle_steps, is there for it).

One remeshing of a shape with :func:`cortex_ti.surface.curved_remesh.remesh_curved`, its new nodes
placed on the old curved cells (``curved``) or on their flat sub-triangles (``flat``), the same new
corner mesh for both (MMG is deterministic). On two shapes: the initial sphere (the truth: volume
4 pi / 3, area 4 pi, and the exact sphere flow of the ring, :mod:`cortex_ti.truth.sphere_exact`)
and amplitude 12's furrow at ``--t`` (the scene run without remeshing to that time). Measured:

- the relative volume change of the curved cells before the volume is restored, and the normal
  offset that restores it;
- the relative change of the curved cells' area after the restoration;
- the velocity solved on the new mesh right after (no settling) against the old mesh's flow at the
  new nodes' feet on the old cells: the largest and the rms difference over max |v|; on the sphere
  also each mesh's error against the exact flow.

Usage::

    python benchmarks/investigations/curved_placement.py --nodes 642 2562 --t 1.0
    python benchmarks/investigations/curved_placement.py --smoke

Cost (one core): ~1 min at 2562 nodes (the run to t = 1 most of it).
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np  # noqa: E402

from cortex_ti.physics.fields import tension_of  # noqa: E402
from cortex_ti.scene import load_scene  # noqa: E402
from cortex_ti.simulation.core import Simulation  # noqa: E402
from cortex_ti.surface.curved_remesh import PLACEMENTS, curved_volume, interpolate_at, remesh_curved  # noqa: E402

SETS = ["numerics.formulation=rayleigh_p2", "mesh.remesh.min_angle=null", "active_stress.0.amplitude=12"]


def area(points, faces) -> float:
    from cortex_ti.analysis.curved_measures import curved_measures

    return curved_measures(points, faces)["area"]


def one(sim: Simulation, state, label: str, exact=None) -> list[str]:
    """The rows of one shape: one remeshing per placement."""
    rem = load_scene("constriction_p4", ["mesh.remesh.min_angle=25"]).settings.mesh.remesh
    from cortex_ti.surface.mesh import icosphere
    from cortex_ti.surface.remesh import mean_edge_length

    n0 = sim.mesh.n_nodes if label == "sphere" else sim.state0.points.shape[0]
    ico = icosphere(n0)
    options = rem.sized(mean_edge_length(ico.points, ico.faces), n0)
    kinds = {spec.name: spec.kind for spec in sim.fields}
    faces0 = state.faces
    v_old = sim.solve(state.points, 0.0, tension_of(state.fields, state.n_nodes, sim.settings)).velocity
    vol0, area0 = curved_volume(state.points, faces0), area(state.points, faces0)
    scale = float(np.abs(v_old).max())
    rows = []
    for placement in PLACEMENTS:
        args = (state.points, faces0, dict(state.fields), kinds, options)
        raw = remesh_curved(*args, placement=placement, restore=False)
        res = remesh_curved(*args, placement=placement)
        dvol = curved_volume(raw.points, raw.faces) / vol0 - 1.0
        darea = area(res.points, res.faces) / area0 - 1.0
        sim.use_mesh(res.points, res.faces)
        v_new = sim.solve(res.points, 0.0, tension_of(res.fields, len(res.points), sim.settings)).velocity
        sim.use_mesh(state.points, faces0)
        jump = np.linalg.norm(v_new - interpolate_at(state.points, faces0, v_old, res.points), axis=1)
        row = [
            label,
            placement,
            f"{len(res.points)}",
            f"{dvol:+.2e}",
            f"{res.offset:+.2e}",
            f"{darea:+.2e}",
            f"{jump.max() / scale:.2e}",
            f"{np.sqrt(np.mean(jump**2)) / scale:.2e}",
        ]
        if exact is not None:
            e_old = np.linalg.norm(v_old - exact(state.points), axis=1).max() / scale
            e_new = np.linalg.norm(v_new - exact(res.points), axis=1).max() / scale
            row += [f"{e_old:.2e}", f"{e_new:.2e}"]
        else:
            row += ["-", "-"]
        rows.append("| " + " | ".join(row) + " |")
    return rows


def exact_flow(sim: Simulation):
    from cortex_ti.physics.patterns import evaluate_active_stress
    from cortex_ti.truth.sphere_exact import sphere_flow

    pats = list(sim.settings.patterns)

    def flow(points):
        unit = points / np.linalg.norm(points, axis=1)[:, None]
        return sphere_flow(lambda p: evaluate_active_stress(p, pats), unit)[0]

    return flow


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    ap.add_argument("--t", type=float, default=1.0, help="the furrow's time (t_a)")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    logging.getLogger("cortex_ti").setLevel(logging.ERROR)
    if args.smoke:
        args.nodes, args.t = [162], 0.02
    where = _bench.folder()
    print(_bench.header())
    head = [
        "shape",
        "placement",
        "new nodes",
        "volume change (before restoring)",
        "restoring offset",
        "area change",
        "velocity jump max / max|v|",
        "rms / max|v|",
        "old mesh vs exact",
        "new mesh vs exact",
    ]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for n in args.nodes:
        sets = [*SETS, f"mesh.nodes={n}", f"time.t_end={args.t}"]
        sim = Simulation(load_scene("constriction_p4", sets))
        for row in one(sim, sim.state0, "sphere", exact_flow(sim)):
            print(row.replace("| sphere |", f"| sphere, {n} |"), flush=True)
        out = sim.run(where / f"a12_{n}.h5", progress=False)
        from cortex_ti.dynamics.state import State
        from cortex_ti.io.trajectory import Trajectory

        with Trajectory(out) as tr:
            k = tr.ds.sizes["time"] - 1
            points, faces = tr.mesh(k)
            fields = {spec.name: tr.nodal(spec.var, k) for spec in sim.fields if spec.var in tr.ds}
        sim = Simulation(load_scene("constriction_p4", sets))
        state = State(points, fields or dict(sim.state0.fields), faces)
        for row in one(sim, state, f"furrow t = {args.t:g}"):
            print(row.replace(f"| furrow t = {args.t:g} |", f"| furrow t = {args.t:g}, {n} |"), flush=True)
    for p in where.iterdir():
        p.unlink()
    where.rmdir()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
