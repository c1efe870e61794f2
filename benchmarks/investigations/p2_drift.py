"""Question: Why does ``rayleigh_p2``'s furrow keep drifting away from its axisymmetric twin after
t = 0.5 (``furrow_p4_a1``, issue 32's bar), when its instantaneous flow on the twin's shapes converges
at third order?

Answer: a corner-midpoint mode of the curved cells. Moving the cells' corners against their edge
midpoints (a mesh-scale "scallop") is barely restored (its rate stays 59 / 83 / 74 per t_a at 642 /
2562 / 10242 nodes instead of growing like h^-2), yet it turns the midpoints' fitted curvature (the
quartic fit on the two-ring holds both kinds of nodes) by ~eps / h^2, and with it the smooth flow:
per unit of corner offset the smooth part of v_n grows 15 / 44 / 183 (rms). The O(h^3) static error
excites the mode within 0.01-0.03 t_a and its smooth pull is an O(h^2) velocity error that the late,
slowly settling furrow integrates. Started from the twin's exact shape at t = 1, the run reaches the
same error at t = 3 as the whole run (so it is not the early history), and the corner-midpoint offset
alone, put on the twin's shape, gives 68-80 % of the smooth velocity error of the run's own shape at
t = 1.03 (2562 nodes). Fitting the midpoints' surface through midpoints only (the 16 nearest of the
three-ring: what ``Simulation`` now does for curved cells with the quartic fit) removes the coupling
(15 -> 12, 44 -> 18, 183 -> 21 at 642 / 2562 / 10242) and the drift: started at t = 1 from the twin's
shape, the error at t = 3 is +6.3e-4 / +5.8e-5 at 642 / 2562 nodes (before -8.3e-4 / -3.4e-4).
Measured on 2026-12-07 (branch p2-drift, docs/validation/curved.md, "The late-furrow drift").

Two experiments (``--part``), each optionally with the stencils of before (``--stencils all``: every
node fitted through all the nodes of its ring):

* ``restart``: the 3D run started from the twin's shape at ``--t0`` (nodes at their labels' points of
  the twin's converged surface, the tension the labels'), to t = 3, pole and equator error against the
  twin at the nodes (time-converged: ``time.tol`` 6.4e-6 x 642 / N);
* ``dent``: on the twin's shape at ``--t``, every corner moved in by eps along the twin's normal: the
  corners' own normal speed per eps (the mode's rate) and the smooth part (a degree-16 Legendre fit in
  cos theta over all nodes) of the normal-velocity change per eps (its pull on the smooth shape).

Usage::

    python benchmarks/investigations/p2_drift.py --nodes 642 2562 [--stencils all]
    python benchmarks/investigations/p2_drift.py --part dent --nodes 642 2562 10242
    python benchmarks/investigations/p2_drift.py --smoke

Cost (one core): restart ~3 / 6 s at 642 / 2562 nodes; dent ~1 s per solve at 10242.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np  # noqa: E402


def _twin(times):
    from cortex_ti.axisymmetric.evolve import simulate
    from cortex_ti.axisymmetric.run import AxisymmetricRun, evolution_options, viscosities
    from cortex_ti.scene import load_scene

    run = AxisymmetricRun(load_scene("furrow_p4_a1", ["model=axisymmetric"]))
    s = run.settings
    return simulate(
        run.zeta,
        **viscosities(s),
        radius=s.mesh.radius,
        t_end=times[-1],
        save_times=np.asarray(times, dtype=float),
        n=s.axisymmetric.n,
        rtol=s.axisymmetric.rtol,
        interpolate=True,
        **dict(evolution_options(s), stop_neck=None, stop_ill_posed=False, bending_form="dissipation"),
    )


def _sim(nodes, stencils, extra=()):
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.surface.fits import StencilChooser

    sets = [f"mesh.nodes={nodes}", "numerics.formulation=rayleigh_p2", "numerics.fit=quartic", *extra]
    sim = Simulation(load_scene("furrow_p4_a1", sets))
    if stencils == "all":
        sim.stencils = StencilChooser(sim.topology, "quartic")
    return sim


def _on_twin(res, k, x0):
    """The twin's points and normals at the labels of the undeformed nodes ``x0``, save time ``k``."""
    label = np.arccos(np.clip(x0[:, 2] / np.linalg.norm(x0, axis=1), -1.0, 1.0))
    phi = np.arctan2(x0[:, 1], x0[:, 0])
    e = res.evaluate(k, label, coordinate="label")
    x = np.stack([e["r"] * np.cos(phi), e["r"] * np.sin(phi), e["z"]], axis=1)
    n = np.stack([e["n_r"] * np.cos(phi), e["n_r"] * np.sin(phi), e["n_z"]], axis=1)
    return x, n, label


def restart(nodes_list, t0, t_end, stencils, folder):
    from cortex_ti.io.trajectory import Trajectory

    times = [t0] + [t for t in (t0 + 0.25, t0 + 0.5, 2.0, 2.5, 3.0) if t0 < t <= t_end + 1e-12]
    res = _twin(times)
    head = f"Started from the twin's shape at t = {t0:g}"
    print(f"\n**{head}** (stencils: {stencils}; error at the nodes: pole / equator)\n")
    print("| N | " + " | ".join(f"t = {t:g}" for t in times[1:]) + " | CPU s |")
    print("|---|" + "---|" * len(times))
    for nodes in nodes_list:
        extra = [f"time.t_end={times[-1] - t0}", "time.save_every=0.05", f"time.tol={6.4e-6 * 642 / nodes}"]
        sim = _sim(nodes, stencils, extra)
        x0 = sim.mesh.points
        start, _, _ = _on_twin(res, 0, x0)
        sim.state0 = sim.state0.with_points(start)
        c0 = time.process_time()
        tr = Trajectory(str(sim.run(folder / f"restart_{stencils}_{nodes}.h5", progress=False)), lazy=True)
        cpu = time.process_time() - c0
        tt, x = np.asarray(tr.times) + t0, tr.ds["points"].values
        pole, eq = int(np.argmax(x0[:, 2])), np.flatnonzero(np.abs(x0[:, 2]) < 1e-12)
        cells = []
        for k, t in enumerate(times[1:], start=1):
            i = int(np.argmin(abs(tt - t)))
            cells.append(
                f"{x[i, pole, 2] - res.pole_radius[k]:+.2e} / "
                f"{np.hypot(x[i, eq, 0], x[i, eq, 1]).mean() - res.furrow_radius[k]:+.2e}"
            )
        print(f"| {nodes} | " + " | ".join(cells) + f" | {cpu:.1f} |")


def dent(nodes_list, t, stencils, eps=1e-6):
    from cortex_ti.surface.curved import midpoint_mask

    res = _twin([0.0, t])
    print(f"\n**Every corner moved in by eps on the twin's shape at t = {t:g}** (stencils: {stencils}; per eps)\n")
    print("| N | corners' own normal speed (mean) | smooth normal-speed change: rms / pole / equator |")
    print("|---|---|---|")
    for nodes in nodes_list:
        sim = _sim(nodes, stencils, ["solver.reuse=false"])
        x0 = sim.mesh.points
        x, n, label = _on_twin(res, 1, x0)
        corner = ~midpoint_mask(sim.mesh.faces, sim.mesh.n_nodes)
        base = np.einsum("nc,nc->n", sim.solve(x).velocity, n)
        moved = np.einsum("nc,nc->n", sim.solve(x - eps * corner[:, None] * n).velocity, n)
        dv = (moved - base) / eps
        v = np.polynomial.legendre.legvander(np.cos(label), 16)
        smooth = v @ np.linalg.lstsq(v, dv, rcond=None)[0]
        pole, eq = int(np.argmax(x0[:, 2])), np.flatnonzero(np.abs(x0[:, 2]) < 1e-12)
        print(
            f"| {nodes} | {dv[corner].mean():+.1f} | {np.sqrt(np.mean(smooth**2)):.1f} / {smooth[pole]:+.1f} / "
            f"{smooth[eq].mean():+.1f} |"
        )


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--part", nargs="+", default=["restart", "dent"], choices=["restart", "dent"])
    p.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    p.add_argument("--stencils", default="apart", choices=["apart", "all"], help="the midpoints' fit stencils")
    p.add_argument("--t0", type=float, default=1.0, help="restart: the twin's time to start from")
    p.add_argument("--t-end", type=float, default=3.0, help="restart: end time")
    p.add_argument("--t", type=float, default=2.0, help="dent: the twin's time")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    from cortex_ti import runtime

    runtime.init(threads=args.threads)
    if args.smoke:
        args.nodes, args.t0, args.t_end, args.t = [162], 1.0, 1.3, 1.0
    if "restart" in args.part:
        restart(args.nodes, args.t0, args.t_end, args.stencils, _bench.folder())
    if "dent" in args.part:
        dent(args.nodes, args.t, args.stencils)
    return 0


if __name__ == "__main__":
    sys.exit(main())
