"""The myosin's total over a whole run (issue 20, bar 2): kept to round-off without turnover, and
following dM/dt = -k (M - c0 A(t)) with it, for every mesh motion.

Runs ``myosin_ring`` (bdf2, its default tolerance) to ``--t-end`` at each resolution and each mesh
motion of :data:`cortex_ti.dynamics.motion.MESH_MOTIONS`, once with ``turnover = 0`` and once with the
scene's ``k = 0.2``, in this process, and reads from every frame the total ``M`` and the area ``A`` on
the run's cells (:meth:`cortex_ti.dynamics.state.State.total`): ``M = sum_i c_i A_i`` with the dual areas
of the frame's nodes, or ``int c_h dA`` on the curved cells of ``rayleigh_p2`` (``--set
numerics.formulation=rayleigh_p2``), what each run keeps:

* without turnover: ``max |M - M(0)| / M(0)`` over the frames (the bar: 1e-12);
* with turnover: ``M`` against the solution of ``dM/dt = -k (M - c0 A(t))`` from ``M(0)``, with the
  run's ``A(t)`` (a cubic spline through the frames; ``scipy.integrate.solve_ivp``, rtol 1e-12):
  ``max |M - M_ode| / M(0)`` over the frames, and ``max |M - c0 A| / M(0)`` (how far the total is
  from the turnover's target at all, for scale). The run integrates the turnover by bdf2 with
  steps of its own, so this difference is the time error of the run, not round-off; it falls with
  ``time.tol`` (``--tols``) and, where the step is at its cap, with ``time.dt_max`` (``--dt-max``).

Usage::

    python benchmarks/myosin_total.py [--nodes 642 2562] [--t-end 36] [--tols default 1e-7]
    python benchmarks/myosin_total.py --nodes 642 --motions lagrangian --set numerics.formulation=rayleigh_p2
    python benchmarks/myosin_total.py --smoke
"""

from __future__ import annotations

import argparse
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np


def totals(path: Path, cells: str = "flat"):
    """Frame times, the myosin's total and the area per frame of a trajectory, measured on the run's
    ``cells`` (``FieldTransport.cells``): ``sum c_i A_i`` on the flat dual cells, ``int c_h dA`` on the
    curved cells of ``rayleigh_p2`` (:meth:`State.total`)."""
    import h5py

    from cortex_ti.dynamics.state import State

    with h5py.File(path, "r") as f:
        t, tri = f["time"][...], f["triangles"][...]
        frames = [
            State(f["points"][k], {"myosin": f["myosin"][k], "one": np.ones(len(f["myosin"][k]))}, tri)
            for k in range(len(t))
        ]
    m = np.array([s.total("myosin", cells) for s in frames])
    return t, m, np.array([s.total("one", cells) for s in frames])


def run(sim, out: Path):
    """Run ``sim`` to ``out``; the frames' times, totals and areas, and the steps (or, when the guard
    or a mesh the fit cannot take stops the run, the time reached) and the reason (empty if it ran
    to its end)."""
    from cortex_ti.errors import MeshError, StabilityError
    from cortex_ti.io.trajectory import partial_path

    cells = sim.transport["myosin"].cells
    try:
        path = sim.run(out, progress=False)
    except (StabilityError, MeshError) as exc:  # the guard, or a fit the distorted mesh defeats
        t, m, a = totals(partial_path(out), cells)
        return t, m, a, f"t = {t[-1]:g}", str(exc).split(":")[0]
    return (*totals(path, cells), sim.summary()["steps"], "")


def ode_total(t, area, m0: float, k: float, c0: float) -> np.ndarray:
    """``dM/dt = -k (M - c0 A(t))`` from ``M(0) = m0``, ``A`` the cubic spline through the frames."""
    from scipy.integrate import solve_ivp
    from scipy.interpolate import CubicSpline

    a = CubicSpline(t, area)
    sol = solve_ivp(lambda s, y: -k * (y - c0 * a(s)), (t[0], t[-1]), [m0], t_eval=t, rtol=1e-12, atol=1e-14)
    return sol.y[0]


def main(argv=None) -> int:
    from cortex_ti.dynamics.motion import MESH_MOTIONS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    ap.add_argument("--t-end", type=float, default=36.0)
    ap.add_argument(
        "--t-end-free", type=float, default=15.0, help="t_end without turnover (the ring then collapses into a spot)"
    )
    ap.add_argument("--motions", nargs="+", default=list(MESH_MOTIONS), choices=list(MESH_MOTIONS))
    ap.add_argument("--tols", nargs="+", default=["default"], help="time.tol of the runs")
    ap.add_argument("--dt-max", type=float, default=None, help="time.dt_max of the runs (default: the scene's)")
    ap.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="scene overrides")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    if args.smoke:
        args.nodes, args.t_end, args.t_end_free, args.tols = [162], 0.3, 0.3, ["default"]
    where = _bench.folder()

    from cortex_ti.scene import load_scene
    from cortex_ti.simulation.core import Simulation

    k, c0 = 0.2, 1.0  # myosin_ring's turnover and c0
    stops = []
    print(
        "## The myosin's total over myosin_ring\n\n"
        f"{' '.join(args.sets)} M = sum c_i A_i per frame (every 0.5 t_a; int c_h dA on curved cells). "
        f"Without turnover (to t = {args.t_end_free:g}: without it "
        "the myosin gathers into a spot the mesh cannot follow, near t = 17 at 642 nodes): max |M - M(0)| / M(0). "
        f"With the scene's turnover k = {k:g} (to t = {args.t_end:g}): max |M - M_ode| / M(0), M_ode the solution "
        "of dM/dt = -k (M - c0 A(t)) with the run's area; max |M - c0 A| / M(0) for scale.\n"
    )
    if args.dt_max is not None:
        print(f"Every run with time.dt_max = {args.dt_max:g}.\n")
    print(
        "| nodes | motion | time.tol | steps, k = 0 | no turnover: max abs(M - M(0)) / M(0) "
        "| steps, k = 0.2 | with turnover: max abs(M - M_ode) / M(0) | max abs(M - c0 A) / M(0) |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for nodes in args.nodes:
        for motion in args.motions:
            for tol in args.tols:
                base = [f"mesh.nodes={nodes}", f"mesh.motion={motion}", *args.sets]
                base += [] if tol == "default" else [f"time.tol={tol}"]
                base += [] if args.dt_max is None else [f"time.dt_max={args.dt_max:g}"]
                out = {}
                free = ["fields.myosin.turnover=0", f"time.t_end={args.t_end_free:g}"]
                for name, extra in (("free", free), ("turn", [f"time.t_end={args.t_end:g}"])):
                    sim = Simulation(load_scene("myosin_ring", base + extra))
                    out[name] = (*run(sim, where / f"{nodes}_{motion}_{tol}_{name}.h5"), sim.settings.time.tol)
                t, m, _, steps0, _, used = out["free"]
                drift = float(np.abs(m - m[0]).max() / m[0])
                t1, m1, area, steps1, _, _ = out["turn"]
                ode = ode_total(t1, area, m1[0], k, c0)
                print(
                    f"| {nodes} | {motion} | {used:.3g} | {steps0} | {drift:.1e} | {steps1} | "
                    f"{np.abs(m1 - ode).max() / m1[0]:.1e} | {np.abs(m1 - c0 * area).max() / m1[0]:.1e} |",
                    flush=True,
                )
                stops += [
                    f"{nodes} nodes, {motion}, {n}: {why}"
                    for n, why in ((0, out["free"][4]), (k, out["turn"][4]))
                    if why
                ]
    if stops:
        print(
            "\nRuns stopped early by the guard or the mesh (their frames up to the stop are in the table; "
            "steps: t reached):\n"
        )
        print("\n".join(f"- {s}" for s in stops))
    import shutil

    shutil.rmtree(where, ignore_errors=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
