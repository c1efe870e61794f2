"""Question: Where should a node budget put its nodes: does a mesh finer at the ring lower the 3D neck
error?

Answer: No: an irregular uniform MMG mesh matches the icosphere (deviation from the twin at t = 1:
3.15e-3 vs 3.19e-3, about 2562 nodes), and meshes graded toward the ring's flanks or into a band around
it raise it by 40-50 % (4.45e-3, 4.87e-3); the neck's error is a global error of the discretisation.
docs/validation/remesh_graded_start.md.

Where should a node budget put its nodes? The ring furrow (constriction_p4, amplitude 6) from
initial meshes of about the same node count graded differently, run without remeshing, against
the axisymmetric twin: if the 3D neck error came from the neck's resolution, meshes finer at the
ring would beat the uniform ones.

Meshes (unit sphere, nodes projected onto it; MMG remeshes to h = clip(s / k, h_min, 3 mean edges),
s chosen for the node budget by cortex_ti.surface.remesh.budget_scale and corrected by MMG's count):

* ``icosphere``: the run's default mesh;
* ``uniform``: MMG's uniform mesh of the same budget from the 642-node icosphere (irregular);
* ``ring flanks``: k = max(1, 0.5 |d ln zeta / d theta|), finer where the ring's tension varies;
* ``ring band``: k = 2 within |theta - pi/2| < 0.8 (the ring and its flanks), 1 elsewhere.

Per mesh: nodes, mean edge length at the ring (|z| < 0.2), on its flanks (0.4 < |z| < 0.7) and at
the poles (|z| > 0.9), and the |3D - twin| neck radius at t = 0.5, 1 (and 2 with ``--t-end 2``).
Usage::

    python benchmarks/investigations/graded_start.py --nodes 2562            # minutes on 2 cores
    python benchmarks/investigations/graded_start.py --smoke
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np
from _bench import at, twin

AMPLITUDE, SIGMA, P = 6.0, 10.0, 4  # constriction_p4's ring


def _kappas(p: np.ndarray) -> dict:
    x = np.arccos(np.clip(p[:, 2], -1.0, 1.0)) - 0.5 * math.pi
    zeta = 1.0 + AMPLITUDE * np.exp(-SIGMA * np.abs(x) ** P)
    dz = np.abs(AMPLITUDE * SIGMA * P * np.abs(x) ** (P - 1) * np.exp(-SIGMA * np.abs(x) ** P))
    return {
        "uniform": np.ones(len(p)),
        "ring flanks": np.maximum(1.0, 0.5 * dz / zeta),
        "ring band": np.where(np.abs(x) < 0.8, 2.0, 1.0),
    }


def graded(nodes: int, kind: str):
    """A unit sphere meshed by MMG to the budget ``nodes`` with the indicator ``kind``."""
    from mmgpy._mmgpy import MmgMeshS

    from cortex_ti.surface.mesh import icosphere
    from cortex_ti.surface.remesh import budget_scale, enclosed_volume, grade, mean_edge_length, sizes

    base = icosphere(642 if nodes >= 2562 else 42)  # MMG refines it about 4-fold (--smoke: coarse, meaningless)
    p, f = base.points, base.faces
    kappa = _kappas(p)[kind]
    h_max = 3.0 * mean_edge_length(p, f) / 2.0
    s = budget_scale(p, f, nodes, 0.005, h_max, 1.3, kappa)
    best = None
    for _ in range(4):
        mesh = MmgMeshS(np.ascontiguousarray(p), np.ascontiguousarray(f, dtype=np.int32))
        mesh.set_field("metric", grade(p, f, sizes(kappa, s, 0.005, h_max), 1.3)[:, None])
        mesh.remesh(hausd=0.01 if nodes >= 2562 else 0.2, hgrad=1.3, angle=0, verbose=-1)
        q, t = np.asarray(mesh.get_vertices(), dtype=float), np.asarray(mesh.get_triangles(), dtype=np.int64)
        if best is None or abs(len(q) - nodes) < abs(len(best[0]) - nodes):
            best = q, t
        if abs(len(q) / nodes - 1.0) < 0.05:
            break
        s *= math.sqrt(len(q) / nodes)
    q, t = best
    q = q / np.linalg.norm(q, axis=1)[:, None]
    if enclosed_volume(q, t) < 0:
        t = t[:, [0, 2, 1]]
    return q, t


def edges_by_zone(q, t) -> tuple[float, float, float]:
    length = np.linalg.norm(q[t] - q[t][:, [1, 2, 0]], axis=2)
    z = np.abs(q[t].mean(axis=1)[:, 2])
    return tuple(float(length[m].mean()) for m in (z < 0.2, (z > 0.4) & (z < 0.7), z > 0.9))


def run(points, faces, nodes: int, t_end: float, where, name: str) -> dict:
    from cortex_ti.io.trajectory import Trajectory
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    sets = [f"time.t_end={t_end}", "time.save_every=0.05", "mesh.remesh.min_angle=null"]
    if points is None:
        sets.append(f"mesh.nodes={nodes}")
    else:
        path = where / f"{name.replace(' ', '_')}.obj"
        with open(path, "w") as fh:
            fh.writelines(f"v {a[0]:.17g} {a[1]:.17g} {a[2]:.17g}\n" for a in points)
            fh.writelines(f"f {a[0] + 1} {a[1] + 1} {a[2] + 1}\n" for a in faces)
        sets += ["mesh.nodes=null", f"mesh.file={path}"]
    sim = Simulation(load_scene("constriction_p4", sets))
    out = where / f"{name.replace(' ', '_')}.h5"
    sim.run(out, progress=False)
    ds = Trajectory(out).ds
    return {"times": ds["time"].values, "furrow": ds["furrow_radius"].values}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, default=2562)
    ap.add_argument("--t-end", type=float, default=1.0)
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    if args.smoke:
        args.nodes, args.t_end = 162, 0.02
    logging.getLogger("cortex_ti").setLevel(logging.ERROR)
    from cortex_ti.surface.mesh import icosphere

    where = _bench.folder()
    tw = twin(AMPLITUDE, args.t_end, where, "constriction_p4")
    times = [t for t in (0.5, 1.0, 2.0) if t <= args.t_end + 1e-9] or [args.t_end]
    print(f"# Graded initial meshes, constriction_p4 amplitude 6, about {args.nodes} nodes, no remeshing\n")
    print(
        "| mesh | nodes | mean edge at the ring | on its flanks | at the poles | "
        + " | ".join(f"deviation at t = {t:g}" for t in times)
        + " |"
    )
    print("|---|---|---|---|---|" + "---|" * len(times))
    ico = icosphere(args.nodes)
    for name in ("icosphere", "uniform", "ring flanks", "ring band"):
        q, t = (ico.points, ico.faces) if name == "icosphere" else graded(args.nodes, name)
        r = run(None if name == "icosphere" else q, t, args.nodes, args.t_end, where, name)
        dev = [abs(at(r["times"], r["furrow"], s) - float(np.interp(s, tw["times"], tw["furrow"]))) for s in times]
        ring, flank, pole = edges_by_zone(q, t)
        print(
            f"| {name} | {len(q)} | {ring:.4f} | {flank:.4f} | {pole:.4f} | "
            + " | ".join(f"{d:.2e}" for d in dev)
            + " |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
