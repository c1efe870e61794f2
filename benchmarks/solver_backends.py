"""The sparse factorisations on the furrow's matrix, and the rule that decides when to refactorise.

Part 1, backends: the matrix ``K_s`` the constrained solver factorises (``furrow_p4_a1``, the
first step's, rayleigh_p1) and the next step's, for every installed backend of
:data:`cortex_ti.solve.factorizations.FACTORIZATIONS` (plus cholespy, if installed, which is not
registered: it has no numerical refactorisation that keeps the analysis): the cold
factorisation (analysis included), a refactorisation of the next matrix with the analysis kept,
one back-substitution, 15 at once (a solve's right-hand side and the 14 border columns), and the
relative residual. CPU milliseconds (``time.process_time``, best of the repeats), one thread.

Part 2, reuse policies: the first ``--steps`` Euler steps of the furrow solved (a) with a fresh
factorisation every step, (b) with reuse and :class:`cortex_ti.solve.constrained.RefactorRule`
(the default), (c) with reuse and refactorisation only when GMRES fails in 30 iterations; for
each the factorisations, GMRES iterations and CPU time of the solve stage. The trajectories agree
to the GMRES tolerance (the largest difference of the velocities is printed).

Usage::

    python benchmarks/solver_backends.py               # 2562 nodes, 60 steps (~1-2 min)
    python benchmarks/solver_backends.py --smoke       # 642 nodes, 12 steps (~20 s)
"""

from __future__ import annotations

import argparse
import os
import sys
import time

os.environ.setdefault("MKL_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ["CORTEX_TI_THREADS"] = "1"

import _bench  # noqa: E402  (benchmarks/_bench.py)
import numpy as np  # noqa: E402


def cpu_ms(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return 1e3 * best


def bordered_matrices(nodes: int):
    """The bordered systems of the furrow's first two steps (the second after one Euler step)."""
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation

    sim = Simulation(load_scene("furrow_p4_a1", [f"mesh.nodes={nodes}", "solver.reuse=false"]))
    dt = sim.settings.time.dt
    x = sim.mesh.points
    out = []
    for _ in range(2):
        system = sim.system(sim.shape_geometry(x), dt)
        out.append(sim.solver._bordered_system(system, x))
        sol = sim.solve(x, dt)
        x = x + dt * np.einsum("nc,nc->n", sol.velocity, sol.normal)[:, None] * sol.normal
    return out


def backends(nodes: int, repeats: int) -> list[str]:
    from cortex_ti.solve.factorizations import FACTORIZATIONS

    b0, b1 = bordered_matrices(nodes)
    a0, a1 = b0.ks, b1.ks
    rhs = b0.rhs[: b0.n]
    cols = np.column_stack([rhs, b0.border])
    lines = [
        f"Matrix: {a0.shape[0]} unknowns, {a0.nnz} nonzeros, {cols.shape[1]} right-hand sides at once.",
        "",
        "| backend | cold factorisation (analysis + numeric) | refactorisation, analysis kept | 1 solve | "
        f"{cols.shape[1]} solves | relative residual |",
        "|---|---|---|---|---|---|",
    ]
    for name, cls in FACTORIZATIONS.items():
        if not cls.available():
            lines.append(f"| {name} | not installed | | | | |")
            continue
        cls().factorize(a0)  # the library's own start-up (MKL loads its kernels on first use) is not counted
        cold = cpu_ms(lambda cls=cls: cls().factorize(a0), max(1, repeats // 2))
        f = cls()
        f.factorize(a0)
        warm = cpu_ms(lambda f=f: f.factorize(a1), repeats)
        one = cpu_ms(lambda f=f: f.solve(rhs), repeats)
        many = cpu_ms(lambda f=f: f.solve(cols), repeats)
        res = np.linalg.norm(a1 @ f.solve(rhs) - rhs) / np.linalg.norm(rhs)
        lines.append(f"| {name} | {cold:.1f} | {warm:.1f} | {one:.2f} | {many:.1f} | {res:.1e} |")
    try:
        import cholespy
    except ImportError:
        lines.append("| cholespy (not registered) | not installed | | | | |")
    else:
        low = a0.tocoo()

        def factor(m=low):
            return cholespy.CholeskySolverD(
                m.shape[0],
                m.row.astype(np.int32),
                m.col.astype(np.int32),
                m.data.astype(np.float64),
                cholespy.MatrixType.COO,
            )

        cold = cpu_ms(factor, max(1, repeats // 2))
        ch = factor()
        x1 = np.zeros_like(rhs)
        one = cpu_ms(lambda: ch.solve(rhs, x1), repeats)
        c = np.ascontiguousarray(cols)
        xc = np.zeros_like(c)
        many = cpu_ms(lambda: ch.solve(c, xc), repeats)
        res = np.linalg.norm(a0 @ x1 - rhs) / np.linalg.norm(rhs)
        lines.append(
            f"| cholespy (not registered) | {cold:.1f} | {cold:.1f} (no refactorisation) | {one:.2f} | "
            f"{many:.1f} | {res:.1e} |"
        )
    return lines


def policies(nodes: int, steps: int) -> list[str]:
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.solve.constrained import RefactorRule

    runs = {}
    for label, reuse, cost in (
        ("fresh factorisation every step", False, None),
        ("reuse, RefactorRule (default)", True, None),
        ("reuse, refactorise only when GMRES fails (30 it.)", True, 1e12),
    ):
        sim = Simulation(load_scene("furrow_p4_a1", [f"mesh.nodes={nodes}", f"solver.reuse={str(reuse).lower()}"]))
        if cost is not None:
            sim.solver.rule = RefactorRule(cost)
        dt = sim.settings.time.dt
        x = sim.mesh.points
        spent, v = 0.0, []
        for _ in range(steps):
            geometry = sim.shape_geometry(x)
            system = sim.system(geometry, dt)
            t = time.process_time()
            u, _, info = sim.solver.solve(system, x)
            spent += time.process_time() - t
            vel = system.velocity(u)
            normal = geometry.normal
            v.append(vel)
            x = x + dt * np.einsum("nc,nc->n", vel, normal)[:, None] * normal
        runs[label] = (sim.solver.n_factorizations, sim.solver.n_iterations, 1e3 * spent / steps, np.array(v))
    ref = runs["fresh factorisation every step"][3]
    lines = [
        f"{steps} Euler steps of furrow_p4_a1 at {nodes} nodes (dt = 5e-3):",
        "",
        "| policy | factorisations | GMRES iterations | CPU ms per solve | max velocity difference to fresh |",
        "|---|---|---|---|---|",
    ]
    for label, (nf, it, ms, v) in runs.items():
        d = np.abs(v - ref).max() / np.abs(ref).max()
        lines.append(f"| {label} | {nf} | {it} | {ms:.1f} | {d:.1e} |")
    return lines


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--nodes", type=int, default=2562)
    p.add_argument("--steps", type=int, default=60)
    p.add_argument("--repeats", type=int, default=7)
    p.add_argument("--smoke", action="store_true", help="642 nodes, 12 steps, 2 repeats")
    args = p.parse_args(argv)
    if args.smoke:
        args.nodes, args.steps, args.repeats = 642, 12, 2
    from cortex_ti import runtime

    runtime.init(threads=1)
    print(_bench.header(note=f"one thread; load average {os.getloadavg()[0]:.1f}"))
    print("\n".join(backends(args.nodes, args.repeats)))
    print()
    print("\n".join(policies(args.nodes, args.steps)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
