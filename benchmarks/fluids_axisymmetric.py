"""The furrow in fluid (``furrow_in_fluid``, issue 36) in the axisymmetric model and in 3D: the
axisymmetric run's convergence in its meridian points ``n``, and the 3D run against it (its
axisymmetric twin) at several node counts, with the observed order.

Both models run the scene as it is (to its ``time.t_end``, one thread); the axisymmetric one with
``--set model=axisymmetric --set axisymmetric.n=<n>``. Reported: the furrow radius at t = 1, 2, 3, its
difference from the finest ``n`` (the axisymmetric model's self-convergence) and the 3D run's
difference from the finest axisymmetric run, with the order ``log2(e_N / e_4N) / 1`` per quadrupling of
the nodes (``h`` halves: a second-order method gives 2), and each run's CPU seconds.

``--dir``: where the trajectories are written (``ax<n>.h5``, ``d3_<N>.h5``); a file already there is
read, not rerun (so the 2562-node run can be made once, apart).

``--swimmer``: instead, ``polarised_swimmer``'s speed: at t = 0 in 3D (``--nodes``) against Lamb's
degree-1 flow, and over the run (to its ``time.t_end``, the mean speed of the volume centroid) in 3D
(``--run-nodes``) against the axisymmetric model at the largest ``--n``.

Usage::

    OMP_NUM_THREADS=1 python benchmarks/fluids_axisymmetric.py --n 8 12 16 24 --nodes 162 642 2562 --dir /tmp/fa
    OMP_NUM_THREADS=1 python benchmarks/fluids_axisymmetric.py --swimmer --n 16 --nodes 162 642 2562 --dir /tmp/fa
    python benchmarks/fluids_axisymmetric.py --smoke
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import _bench  # benchmarks/_bench.py: what the scripts share

from cortex_ti.surface.measures import volume_centroid

TIMES = (1.0, 2.0, 3.0)


def run(path: Path, overrides: list[str], scene: str = "furrow_in_fluid") -> float | None:
    """Run ``scene`` with ``overrides`` into ``path`` unless it is there; its CPU seconds (None: reused)."""
    if path.exists():
        return None
    import cortex_ti as ct

    t0 = time.process_time()
    ct.run(scene, output=path, overrides=overrides, threads=1)
    return time.process_time() - t0


def furrow(path: Path, times) -> list[float]:
    """The furrow radius at the frames nearest ``times`` (NaN past the last frame)."""
    import h5py

    with h5py.File(path, "r") as f:
        t, fr = f["time"][:], f["furrow_radius"][:]
    return [_bench.at(t, fr, s) for s in times]


def swim_speed(nodes: int) -> tuple[float, float]:
    """The t = 0 swimming speed of ``polarised_swimmer`` in 3D at ``nodes`` (the rate of the enclosed
    polyhedron's volume centroid as the nodes move along their normals by ``v_n``, as
    ``fluids_cost.py --sediment`` measures the sedimentation) and the CPU seconds of its solve."""
    import numpy as np

    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    sim = Simulation(load_scene("polarised_swimmer", [f"mesh.nodes={nodes}"]))
    x, tri = sim.mesh.points, sim.mesh.faces
    t0 = time.process_time()
    sol = sim.solve(x)
    cpu = time.process_time() - t0
    move = 1e-6 * np.einsum("nc,nc->n", sol.velocity, sol.normal)[:, None] * sol.normal
    return float((volume_centroid(x + move, tri) - volume_centroid(x - move, tri))[2] / 2e-6), cpu


def centroid_speed(path: Path) -> float:
    """The mean speed along z of a trajectory's volume centroid (polyhedral) over the run."""
    import h5py

    with h5py.File(path, "r") as f:
        t, pts, tri = f["time"][:], f["points"], f["triangles"][:]
        z0, z1 = volume_centroid(pts[0], tri)[2], volume_centroid(pts[-1], tri)[2]
    return float((z1 - z0) / (t[-1] - t[0]))


def swimmer(args, where: Path, extra: list[str]) -> None:
    """The swimmer's speed: at t = 0 against Lamb (3D at ``args.nodes``), over the run against the
    axisymmetric model (3D at ``args.run_nodes``)."""
    from cortex_ti.truth import fluid_sphere as fs

    _, beta = fs.flow_coefficients(1, mu_in=1.0, mu_out=1.0, eta_s=1.0, eta_b=1.0)
    exact = 0.5 * beta * math.sqrt(3.0 / (4.0 * math.pi))  # coeff 0.5 of Y_10 = sqrt(3 / 4 pi) cos
    print(f"\npolarised_swimmer, t = 0: Lamb's speed {exact:.6f}")
    print("| 3D nodes | speed | relative error | order | solve CPU s |\n|---|---|---|---|---|")
    prev = None
    for nodes in args.nodes:
        speed, cpu = swim_speed(nodes)
        err = abs(speed / exact - 1)
        order = "" if prev is None else f"{math.log2(prev / err):.2f}"
        print(f"| {nodes} | {speed:.6f} | {err:.2e} | {order} | {cpu:.1f} |")
        prev = err
    path = where / f"sw_ax{max(args.n)}.h5"
    run(path, ["model=axisymmetric", f"axisymmetric.n={max(args.n)}", *extra], "polarised_swimmer")
    ref = centroid_speed(path)
    print(f"\nover the run (mean centroid speed): axisymmetric n = {max(args.n)}: {ref:.6f}")
    print("| 3D nodes | speed | relative difference | CPU s |\n|---|---|---|---|")
    for nodes in args.run_nodes:
        path = where / f"sw_d3_{nodes}.h5"
        cpu = run(path, [f"mesh.nodes={nodes}", *extra], "polarised_swimmer")
        speed = centroid_speed(path)
        cell = "reused" if cpu is None else f"{cpu:.1f}"
        print(f"| {nodes} | {speed:.6f} | {abs(speed / ref - 1):.2e} | {cell} |")


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--n", type=int, nargs="+", default=[8, 12, 16, 24], help="axisymmetric meridian points")
    p.add_argument("--nodes", type=int, nargs="+", default=[162, 642], help="3D node counts")
    p.add_argument("--swimmer", action="store_true", help="the swimmer's speed instead (docstring)")
    p.add_argument("--run-nodes", type=int, nargs="+", default=[162, 642], help="3D runs of the swimmer")
    p.add_argument("--dir", type=Path, default=None, help="where the trajectories go (default: a temporary folder)")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    times, extra = TIMES, []
    if args.smoke:
        args.n, args.nodes, args.run_nodes = [8], [162], []
        times, extra = (0.01,), ["time.t_end=0.01"]
    where = args.dir or _bench.folder()
    where.mkdir(parents=True, exist_ok=True)
    print(_bench.header(sys.argv if argv is None else ["fluids_axisymmetric.py", *argv]))
    if args.swimmer or args.smoke:
        swimmer(args, where, extra)
    if args.swimmer:
        return
    ax = {}
    print("\n| axisymmetric n | " + " | ".join(f"R_f(t={s:g})" for s in times) + " | CPU s |")
    print("|---" * (len(times) + 2) + "|")
    for n in args.n:
        path = where / f"ax{n}.h5"
        cpu = run(path, ["model=axisymmetric", f"axisymmetric.n={n}", *extra])
        ax[n] = furrow(path, times)
        cell = "reused" if cpu is None else f"{cpu:.1f}"
        print(f"| {n} | " + " | ".join(f"{v:.9f}" for v in ax[n]) + f" | {cell} |")
    ref = ax[max(args.n)]
    print(f"\nself-convergence: |R_f(n) - R_f({max(args.n)})|")
    for n in sorted(args.n)[:-1]:
        print(f"  n = {n}: " + ", ".join(f"{abs(a - b):.2e}" for a, b in zip(ax[n], ref, strict=True)))
    print("\n| 3D nodes | " + " | ".join(f"e(t={s:g})" for s in times) + " | order | CPU s |")
    print("|---" * (len(times) + 3) + "|")
    prev = None
    for nodes in args.nodes:
        path = where / f"d3_{nodes}.h5"
        cpu = run(path, [f"mesh.nodes={nodes}", *extra])
        err = [abs(a - b) for a, b in zip(furrow(path, times), ref, strict=True)]
        order = "" if prev is None else f"{math.log2(prev[-1] / err[-1]):.2f}"
        cell = "reused" if cpu is None else f"{cpu:.1f}"
        print(f"| {nodes} | " + " | ".join(f"{e:.3e}" for e in err) + f" | {order} | {cell} |")
        prev = err


if __name__ == "__main__":
    main()
