"""What a step with the effect ``fluids`` costs (issue 36): per solve, by stage, and its memory, at
several node counts, for each ``fluid.solver`` (dense; direct and fmm, matrix-free); and whole runs.

One solve is one step of the scenes' schemes (bdf2, Euler: one solve a step; Heun and the adaptive
schemes: two). Stages of a solve of ``furrow_in_fluid`` on its initial shape: the geometry (fits,
normals), the fluids' operator (:func:`cortex_ti.physics.fluids.fluid_operator`: the single layer's
quadrature, its Cholesky factorisation and ``D = A V^-1 A``, timed on its own), the rest of the
assembly (the sparse cortex terms), the densification of ``K + D`` and the dense Cholesky solve with
its refinement (:mod:`cortex_ti.solve.dense`). Memory: the peak of NumPy's allocations over one solve
(``tracemalloc``: LAPACK's own workspace is not in it) and the process's peak resident size. Wall and
CPU seconds (the machine is shared: CPU seconds are the steadier number on one thread). The
matrix-free solvers (``--solvers direct fmm``): the operator is the near corrections and the
quadrature set-up (:class:`cortex_ti.physics.fluids_fast.FmmFluid`), the solve the preconditioner's
factorisation and the GMRES iterations (their count in the table).

``--run``: instead, ``furrow_in_fluid`` to ``--t-end`` (3) with each solver at each node count, as
``cortex-ti run`` in a child process (one thread): wall and CPU seconds, steps, the child's peak
resident memory, the GMRES iterations and factorisations (from the run summary) and the furrow radius at
the end (from the trajectory).

``--sediment``: instead (per solver), the bound of the run tests (``tests/simulation/test_fluids_run.py``): the
static error of the sedimentation velocity of ``sedimenting_cell`` (no tension change: t = 0) in the
measure a run gives, the rate of the enclosed polyhedron's volume centroid as the nodes move along
their normals by ``v_n``, against Boussinesq-Scriven; and the t = 0 flow's largest non-rigid normal
speed; and Faxén's rotation of ``cell_in_shear`` at t = 0 (mesh-moment normalisation: exact on any
mesh, so its error is the solve's).

Usage::

    OMP_NUM_THREADS=1 python benchmarks/fluids_cost.py --nodes 162 642 2562
    OMP_NUM_THREADS=1 python benchmarks/fluids_cost.py --nodes 642 2562 --solvers dense direct fmm
    OMP_NUM_THREADS=1 python benchmarks/fluids_cost.py --run --nodes 642 2562 --solvers dense direct
    OMP_NUM_THREADS=1 python benchmarks/fluids_cost.py --run --nodes 642 --solvers direct --t-end 0.5 --schemes heun
    OMP_NUM_THREADS=1 python benchmarks/fluids_cost.py --sediment --nodes 162 642 2562
    OMP_NUM_THREADS=1 python benchmarks/fluids_cost.py --nodes 642 2562 --solvers dense direct --set fluid.inner=0.1
    python benchmarks/fluids_cost.py --smoke
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
import tracemalloc

import _bench  # benchmarks/_bench.py: what the scripts share

from cortex_ti.surface.measures import volume_centroid


def clocks():
    return time.perf_counter(), time.process_time()


def since(start) -> tuple[float, float]:
    wall, cpu = clocks()
    return wall - start[0], cpu - start[1]


def measure(nodes: int, solver: str = "dense", extra: tuple[str, ...] = ()) -> dict:
    """The stages of one solve of furrow_in_fluid at ``nodes`` nodes (module docstring)."""
    from cortex_ti.physics.fluids import fluid_operator
    from cortex_ti.physics.fluids_fast import fmm_fluid
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    sim = Simulation(load_scene("furrow_in_fluid", [f"mesh.nodes={nodes}", f"fluid.solver={solver}", *extra]))
    fluid = sim.settings.fluid
    x = sim.mesh.points
    geo = sim.shape_geometry(x)  # compiles the kernels: not timed
    if nodes <= 162 or solver == "direct":  # warm-up of the code paths (the Taichi kernel's compilation)
        sim.solve(x)
        sim.solver.new_mesh()  # no warm start from the warm-up
    start = clocks()
    geo = sim.shape_geometry(x)
    geometry = since(start)
    start = clocks()
    if solver == "dense":
        fluid_operator(x, sim.mesh.faces, geo.normal, mu_in=fluid.inner, mu_out=fluid.outer, measure=False)
    else:
        fmm_fluid(x, sim.mesh.faces, geo.normal, mu_in=fluid.inner, mu_out=fluid.outer, backend=solver)
    operator = since(start)
    tracemalloc.start()
    start = clocks()
    sol = sim.solve(x)
    whole = since(start)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    s = sol.info.seconds
    return {
        "solver": solver,
        "iterations": sol.info.iterations,
        "nodes": nodes,
        "unknowns": 3 * nodes,
        "geometry": geometry[0],
        "operator": operator[0],
        "operator_cpu": operator[1],
        "assembly": sol.seconds["assembly"],
        "densify": s.get("normal_equations", 0.0),
        "factor_solve": s["factor_solve"],
        "solve_wall": whole[0],
        "solve_cpu": whole[1],
        "peak_numpy_gb": peak / 2**30,
        "peak_rss_gb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20,
        "residual": sol.info.relative_residual,
    }


def faxen(nodes: int, solver: str) -> float:
    """``cell_in_shear`` (G = 1) at t = 0: the largest error of the rotation (normalised by the mesh's
    own moment, exact for a rigid rotation) and the mean velocity against Faxén's ``-G/2 e_z`` and 0."""
    import numpy as np

    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    sim = Simulation(load_scene("cell_in_shear", [f"mesh.nodes={nodes}", f"fluid.solver={solver}"]))
    x = sim.mesh.points
    sol = sim.solve(x)
    a = sim.shape_geometry(x).area
    c = (a[:, None] * x).sum(0) / a.sum()
    r = x - c
    rr = np.einsum("nc,nc->n", r, r)[:, None, None] * np.eye(3) - r[:, :, None] * r[:, None, :]
    omega = np.linalg.solve((a[:, None, None] * rr).sum(0), (a[:, None] * np.cross(r, sol.velocity)).sum(0))
    mean = (a[:, None] * sol.velocity).sum(0) / a.sum()
    return float(max(np.abs(omega - [0.0, 0.0, -0.5]).max(), np.abs(mean).max()))


def sediment(nodes: int, solver: str = "dense") -> str:
    """One row of ``--sediment`` (module docstring)."""
    import numpy as np

    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.truth import fluid_sphere as fs

    sim = Simulation(load_scene("sedimenting_cell", [f"mesh.nodes={nodes}", f"fluid.solver={solver}"]))
    x, tri = sim.mesh.points, sim.mesh.faces
    sol = sim.solve(x)
    vn = np.einsum("nc,nc->n", sol.velocity, sol.normal)
    eps = 1e-6
    move = eps * vn[:, None] * sol.normal
    rate = (volume_centroid(x + move, tri) - volume_centroid(x - move, tri)) / (2 * eps)
    exact = fs.sedimentation_velocity(1.0, mu_in=1.0, mu_out=1.0, eta_s=1.0, eta_b=1.0)
    n = x / np.linalg.norm(x, axis=1)[:, None]
    vn = np.einsum("nc,nc->n", sol.velocity, n)
    nonrigid = np.abs(vn - n @ np.linalg.lstsq(n, vn, rcond=None)[0]).max()
    fx = faxen(nodes, solver)
    return f"| {solver} | {nodes} | {-rate[2]:.5f} | {abs(-rate[2] / exact - 1):.2e} | {nonrigid:.2e} | {fx:.1e} |"


def table(rows: list[dict]) -> str:
    out = [
        "| solver | nodes | geometry (s) | operator (s, CPU s) | assembly incl. operator (s) | K + D dense (s) | "
        "factorisation + solve (s) | GMRES iterations | one solve (s, CPU s) | peak NumPy memory (GB) | "
        "peak RSS (GB) |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        out.append(
            f"| {r['solver']} | {r['nodes']} | {r['geometry']:.2f} | {r['operator']:.2f} ({r['operator_cpu']:.2f}) | "
            f"{r['assembly']:.2f} | {r['densify']:.2f} | {r['factor_solve']:.2f} | {r['iterations']} | "
            f"{r['solve_wall']:.2f} ({r['solve_cpu']:.2f}) | {r['peak_numpy_gb']:.3f} | {r['peak_rss_gb']:.2f} |"
        )
    return "\n".join(out) + "\n"


def whole_run(nodes: int, solver: str, t_end: float, scheme: str | None = None, extra: tuple[str, ...] = ()) -> str:
    """One row of ``--run`` (module docstring): ``cortex-ti run furrow_in_fluid`` in a child process."""
    import json
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        out, summary = os.path.join(tmp, "f.h5"), os.path.join(tmp, "f.json")
        cmd = [sys.executable, "-m", "cortex_ti", "run", "furrow_in_fluid", "-o", out, "--threads", "1"]
        cmd += ["--summary", summary, "--set", f"mesh.nodes={nodes}", "--set", f"fluid.solver={solver}"]
        cmd += ["--set", f"time.t_end={t_end:g}"] + ([] if scheme is None else ["--set", f"time.scheme={scheme}"])
        cmd += [a for kv in extra for a in ("--set", kv)]
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        wall = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
        wall = time.perf_counter() - wall
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        data = json.loads(open(summary).read())
        import h5py

        with h5py.File(out, "r") as h5:
            furrow = float(h5["furrow_radius"][-1])
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    steps = data.get("steps", data.get("stats", {}).get("steps", "?"))
    steps = f"{steps} ({data.get('solves', '?')})"
    return (
        f"| {solver} | {scheme or 'bdf2'} | {nodes} | {t_end:g} | {steps} | {wall:.0f} | {cpu:.0f} | "
        f"{after.ru_maxrss / 2**20:.2f} | {data.get('krylov_iterations', '-')} | {data.get('factorizations', '-')} | "
        f"{furrow:.7f} | {data.get('solver_backend', '?')} |"
    )


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nodes", type=int, nargs="+", default=[162, 642, 2562])
    parser.add_argument("--sediment", action="store_true", help="the run tests' static bound instead (docstring)")
    parser.add_argument("--solvers", nargs="+", default=["dense"], help="fluid.solver values (dense direct fmm)")
    parser.add_argument("--run", action="store_true", help="whole runs of furrow_in_fluid instead (docstring)")
    parser.add_argument("--t-end", type=float, default=3.0, help="the runs' end time (--run)")
    parser.add_argument("--schemes", nargs="+", help="time.scheme values for --run (default: the scene's, bdf2)")
    parser.add_argument(
        "--lump", type=float, help="the matrix-free solvers' exact radius (fluids_fast.LUMP_RADIUS; inf: every pair)"
    )
    parser.add_argument(
        "--set", dest="extra", action="append", default=[], help="a further scene override (e.g. fluid.inner=0.1)"
    )
    parser.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = parser.parse_args(argv)
    if args.lump is not None:  # in this process (the --run children keep the default)
        import cortex_ti.physics.fluids_fast as ff

        ff.LUMP_RADIUS = args.lump
    nodes = [162] if args.smoke else args.nodes
    threads = os.environ.get("OMP_NUM_THREADS", "unset")
    lump = "" if args.lump is None else f", LUMP_RADIUS={args.lump:g}"
    print(_bench.header(note=f"OMP_NUM_THREADS={threads}, load average {os.getloadavg()[0]:.1f}{lump}"))
    if args.sediment or args.smoke:
        print(
            "| solver | nodes | centroid rate | error against Boussinesq-Scriven | non-rigid normal speed | "
            "Faxén error (mesh moment) |"
        )
        print("|---|---|---|---|---|---|")
        for n in nodes:
            for s in ["dense"] if args.smoke else args.solvers:
                print(sediment(n, s), flush=True)
        if args.sediment:
            return
    solvers = ["dense", "direct"] if args.smoke else args.solvers
    if args.run:
        print(
            "| solver | scheme | nodes | t_end | steps (solves) | wall (s) | CPU (s) | "
            "peak RSS of the runs so far (GB) | GMRES iterations | factorisations | R_f(t_end) | solver_name |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|---|")
        for n in nodes:
            for s in solvers:
                for scheme in args.schemes or [None]:
                    print(whole_run(n, s, 0.1 if args.smoke else args.t_end, scheme, tuple(args.extra)), flush=True)
        return
    rows = []
    for n in nodes:
        for s in solvers:
            rows.append(measure(n, s, tuple(args.extra)))
            r = rows[-1]  # the row as a comment at once (a long measurement stopped keeps what it had)
            print(
                f"<!-- {s}, {n} nodes: relative residual {r['residual']:.1e}; {table([r]).splitlines()[-1]} -->",
                flush=True,
            )
    print(table(rows))


if __name__ == "__main__":
    main(sys.argv[1:])
