"""Question: With a moving mesh (ale, lagrangian), do the two translation gauges give the same shapes up to
a rigid translation?

Answer: Yes for lagrangian nodes, to the solver's precision (largest distance of the shifted shapes
3.4e-13 / 1.8e-13 / 3.3e-12 at 162 / 642 / 2562 nodes); with ALE they converge to each other at first
order in h (1.11e-4 / 6.53e-5 / 3.42e-5, ratio 1.70, 1.91), the carried tension following the tangential
part of the translation through the first-order limited transport. docs/validation/material_cortex.md,
"The two translation gauges with a moving mesh".

The two translation gauges with a moving mesh: the same shapes up to a rigid translation?

The free translation of the cortex is fixed either by zero mean velocity or by holding the enclosed
volume's centroid (scene key ``translation``); the two velocities differ by a rigid translation
``U(t)``, so in the continuum the shapes differ by its integral. With ``mesh.motion: lagrangian``
the nodes follow ``v`` and the discrete shapes differ by exactly that translation (to the solver's
precision, ``tests/surface/test_transport.py``). With ``ale`` (and ``normal``) the nodes follow
``v_n n`` plus a tangential motion of their own, so the tangential part of ``U`` moves the cortex
*across* the nodes: the meshes differ, the carried tension is transported relative to them, and
the discrete shapes agree only up to the discretisation error, which must fall with N.

The scene: ``zeta = 1 + 0.3 Y_20 + 0.3 Y_30`` carried by the material (no up-down symmetry, so
``U`` is not zero), without bending viscosity and with the explicit tension and the exact pressure
weights (the terms whose discretisation is not translation invariant, see the test), Euler at
``--dt``. Measured at ``--t-end``: the centroid shift between the gauges, and the largest distance
of the nodes of one shape, moved by that shift, to the triangles of the other (point-to-triangle,
exact; so a slide of the nodes along the surface costs nothing), and its ratio per refinement.

Usage::

    python benchmarks/investigations/ale_gauge.py --nodes 162 642 2562 --motions ale lagrangian

Cost: two runs per (N, motion); 2562 nodes to t = 0.5 at dt = 2e-3 about a minute each.
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np

HARMONICS = [
    {"l": 0, "m": 0, "coeff": float(np.sqrt(4 * np.pi))},
    {"l": 2, "m": 0, "coeff": 0.3},
    {"l": 3, "m": 0, "coeff": 0.3},
]


def centroid(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The enclosed volume's centroid of a closed triangulated surface."""
    a, b, c = (points[faces[:, k]] for k in range(3))
    vol = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    return ((a + b + c) / 4.0 * vol[:, None]).sum(0) / vol.sum()


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The closest point to each ``p`` (M, 3) on the triangle ``(a, b, c)`` (M, 3 each): the
    projection onto the plane with its barycentric coordinates clamped to the triangle (the
    region tests of Ericson, Real-Time Collision Detection, Sec. 5.1.5, vectorised; written here
    because neither scipy nor numpy has it and the package keeps no mesh library)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = (ab * ap).sum(1), (ac * ap).sum(1)
    bp = p - b
    d3, d4 = (ab * bp).sum(1), (ac * bp).sum(1)
    cp = p - c
    d5, d6 = (ab * cp).sum(1), (ac * cp).sum(1)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    denom = va + vb + vc
    v, w = vb / denom, vc / denom
    out = a + ab * v[:, None] + ac * w[:, None]  # inside the face
    with np.errstate(divide="ignore", invalid="ignore"):
        cases = [
            ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + ab * (d1 / (d1 - d3))[:, None]),  # edge ab
            ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + ac * (d2 / (d2 - d6))[:, None]),  # edge ac
            (
                (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0),
                b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[:, None],
            ),  # edge bc
            ((d6 >= 0) & (d5 <= d6), c),
            ((d3 >= 0) & (d4 <= d3), b),
            ((d1 <= 0) & (d2 <= 0), a),
        ]
    for mask, point in cases:  # the vertex regions last: they take precedence
        out = np.where(mask[:, None], point, out)
    return out


def surface_distance(x: np.ndarray, y: np.ndarray, faces: np.ndarray, k: int = 4) -> np.ndarray:
    """Distance of each point ``x`` to the surface ``(y, faces)``: the nearest of the triangles
    around its ``k`` nearest nodes of ``y`` (enough while the shapes are closer than an edge)."""
    from scipy.spatial import cKDTree

    _, near = cKDTree(y).query(x, k=k)
    best = np.full(x.shape[0], np.inf)
    incident = [[] for _ in range(y.shape[0])]
    for t, f in enumerate(faces):
        for v in f:
            incident[v].append(t)
    for j in range(k):
        width = max(len(incident[v]) for v in near[:, j])
        tri = np.array([incident[v] + [incident[v][0]] * (width - len(incident[v])) for v in near[:, j]])
        for m in range(width):
            f = faces[tri[:, m]]
            q = closest_on_triangles(x, y[f[:, 0]], y[f[:, 1]], y[f[:, 2]])
            best = np.minimum(best, np.linalg.norm(q - x, axis=1))
    return best


def gauge_runs(nodes, motion, t_end, dt, where):
    """The last frames (points) of the two gauges and the mesh's faces."""
    from cortex_ti.io import Trajectory
    from cortex_ti.scene import load_scene, scene_from_dict
    from cortex_ti.simulation import Simulation

    base = copy.deepcopy(
        load_scene(
            "furrow_p4_a1",
            [
                f"mesh.nodes={nodes}",
                f"time.t_end={t_end}",
                f"time.dt={dt}",
                f"time.save_every={t_end}",
                f"mesh.motion={motion}",
                "tension_transport=material",
                "time.implicit_tension=false",
                "numerics.pressure_weights=exact",
            ],
        ).data
    )
    base["effects"] = [e for e in base["effects"] if e != "bending_viscosity"]
    base["viscosity"].update(bending=0.0, bending_bulk=0.0)
    base["active_stress"] = [{"type": "harmonics", "terms": HARMONICS}]
    out = {}
    for gauge in ("mean_velocity", "centroid"):
        data = copy.deepcopy(base)
        data["translation"] = gauge
        sim = Simulation(scene_from_dict(data))
        path = sim.run(where / f"{motion}_{nodes}_{gauge}.h5", progress=False)
        with Trajectory(path) as tr:
            out[gauge] = tr.ds["points"].isel(time=-1).values.copy()
    return out, sim.mesh.faces


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, nargs="*", default=[162, 642, 2562])
    p.add_argument("--motions", nargs="*", default=["ale", "lagrangian"])
    p.add_argument("--t-end", type=float, default=0.5)
    p.add_argument("--dt", type=float, default=2e-3)
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.motions, args.t_end, args.dt = [162], ["ale"], 0.01, 5e-3
    where = _bench.folder()
    print(
        f"| motion | N | centroid shift between the gauges at t = {args.t_end:g} | largest distance of the "
        "shifted shapes | ratio to the next coarser | s |"
    )
    print("|---|---|---|---|---|---|")
    for motion in args.motions:
        prev = None
        for nodes in args.nodes:
            t0 = time.perf_counter()
            pts, faces = gauge_runs(nodes, motion, args.t_end, args.dt, where)
            a, b = pts["mean_velocity"], pts["centroid"]
            shift = centroid(a, faces) - centroid(b, faces)
            dist = max(surface_distance(a - shift, b, faces).max(), surface_distance(b + shift, a, faces).max())
            ratio = "" if prev is None else f"{prev / dist:.2f}"
            print(
                f"| {motion} | {nodes} | {np.linalg.norm(shift):.3e} | {dist:.2e} | {ratio} | "
                f"{time.perf_counter() - t0:.0f} |",
                flush=True,
            )
            prev = dist
    return 0


if __name__ == "__main__":
    sys.exit(main())
