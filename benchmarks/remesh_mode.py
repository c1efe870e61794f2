"""The growing and the stiffest modes of a stored frame, on that frame's own mesh (a remeshed
run's too): the eigenvalues of the linearised normal dynamics (cortex_ti.dynamics.spectrum) of
largest real part and of most negative real part, and, for each, how localised it is, where, the
shortest edge there, and whether it alternates in sign between neighbouring nodes (a mesh-scale
mode) or not (a smooth one). With the semi-implicit tension the linearisation depends on the step
(it is in the matrix): ``--dt`` gives the steps to take it at (default: the frame's own). Usage::

    python benchmarks/remesh_mode.py run.h5.partial --time 2.2
    python benchmarks/remesh_mode.py run.h5 --time 2.5 2.6 --dt 1.3e-3 4.8e-3 --stiffest 2
    python benchmarks/remesh_mode.py --smoke        # a 162-node frame at t = 0.02

A growing mode (Re lambda > 0) grows at any time step: the step is not the cause. A stiff one
(Re lambda < 0) bounds the step of the extrapolated BDF2 at ``4/3 / |lambda|`` (its explicit
interval, cortex_ti.dynamics.schemes.BDF2.explicit_interval): the column "BDF2 step limit".

The last column is the smaller principal value of the state's surface stress (tension plus viscous,
cortex_ti.analysis.diagnostics.surface_stress) at the mode's largest entry: without bending
resistance a compressed cortex wrinkles at the mesh scale, so a growing mode on a few nodes where it
is negative is that (docs/validation/remesh_constriction.md, "The mode after a remeshing").
"""

from __future__ import annotations

import argparse

import _smoke  # benchmarks/_smoke.py: what the --smoke modes share
import numpy as np


def _describe(pts, tri, w, v, j, area, hmin, explicit, stress) -> str:
    """One table row: the eigenvalue, the step limit, and the mode's size, place, edge, sign flips and
    the smaller principal stress of the state at its largest entry (``stress``: per node, the least
    over its triangles)."""
    s = np.real(v[:, j])
    p = s * s * area / np.sum(s * s * area)
    top = int(np.argmax(p))
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    big = np.abs(s) > 0.1 * np.abs(s).max()
    pair = big[edges[:, 0]] & big[edges[:, 1]]
    flips = float(np.mean(np.sign(s[edges[pair, 0]]) != np.sign(s[edges[pair, 1]]))) if pair.any() else 0.0
    limit = f"{explicit / abs(w[j]):.3g}" if w[j].real < 0 else "-"
    return (
        f"| {w[j].real:.4g}{w[j].imag:+.2g}i | {limit} | {1.0 / np.sum(p * p):.0f} | "
        f"z = {pts[top, 2]:.3f}, r = {np.hypot(pts[top, 0], pts[top, 1]):.3f} | {hmin[top]:.4f} | "
        f"{100 * flips:.0f} % | {stress[top]:.3g} |"
    )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trajectory", nargs="?")
    ap.add_argument(
        "--time", type=float, nargs="+", default=None, help="the frames nearest these times (default: the last)"
    )
    ap.add_argument(
        "--dt", type=float, nargs="+", default=None, help="the steps to linearise at (default: the frame's)"
    )
    ap.add_argument("--modes", type=int, default=4, help="growing modes shown (largest real part)")
    ap.add_argument("--stiffest", type=int, default=0, help="stiff modes shown (most negative real part)")
    ap.add_argument("--smoke", action="store_true", help=_smoke.HELP)
    args = ap.parse_args(argv)
    if args.smoke:
        args.trajectory, args.stiffest = str(_smoke.tiny_run("furrow_p4_a1", t_end=0.02)), 1
    if not args.trajectory:
        ap.error("give a trajectory")
    from cortex_ti.analysis.diagnostics import surface_stress
    from cortex_ti.dynamics.schemes import BDF2
    from cortex_ti.dynamics.spectrum import normal_spectrum
    from cortex_ti.dynamics.state import State
    from cortex_ti.io.trajectory import Trajectory
    from cortex_ti.simulation import Simulation
    from cortex_ti.simulation.run import frame_fields
    from cortex_ti.surface.remesh import min_angles
    from cortex_ti.surface.transport import dual_areas

    tr = Trajectory(args.trajectory)
    frames = [len(tr.times) - 1] if args.time is None else [tr.frame_at(t) for t in args.time]
    for k in frames:
        pts, tri = tr.mesh(k)
        edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
        length = np.linalg.norm(pts[edges[:, 0]] - pts[edges[:, 1]], axis=1)
        hmin = np.full(len(pts), np.inf)
        np.minimum.at(hmin, edges[:, 0], length)
        np.minimum.at(hmin, edges[:, 1], length)
        area = dual_areas(pts, tri)
        own = float(tr.ds["dt"].values[k]) if "dt" in tr.ds else 0.0
        for dt in args.dt or [own]:
            sim = Simulation(tr.scene)
            sim.use_mesh(pts, tri)
            # the fields the frame's nodes carried (a myosin density too), so the tension is the frame's
            stored = {spec.var: tr.nodal(spec.var, k) for spec in sim.fields if spec.var in tr.ds}
            where = f"{args.trajectory} at frame {k}"
            sim.state0 = State(pts, frame_fields(sim, stored, tr.nodal("active_stress", k), where), tri)
            sp = normal_spectrum(sim, pts, dt=dt, modes=True, dense=True)
            w, v = np.asarray(sp.eigenvalues), np.asarray(sp.modes)
            phys = sim.physics
            principal = surface_stress(pts, tri, sim.solve(pts, dt=dt).velocity, sim.zeta, phys.eta_s, phys.eta_b)
            stress = np.full(len(pts), np.inf)
            for c in range(3):
                np.minimum.at(stress, tri[:, c], principal[:, 0])
            print(
                f"# t = {float(tr.times[k]):.4g}: {len(pts)} nodes, edges {length.min():.4f} - {length.max():.4f} R0, "
                f"smallest angle {min_angles(pts, tri).min():.1f} deg; linearised at dt = {dt:g}; surface stress "
                f"(tension + viscous) compressive on {int(np.sum(principal[:, 0] < 0))} of {len(tri)} triangles "
                f"(smallest principal value {principal[:, 0].min():.3g})\n"
            )
            print(
                "| lambda (1/t_a) | BDF2 step limit | effective nodes | where (z, r of its largest entry) | "
                "shortest edge there | sign changes between neighbours | smaller principal stress there |"
            )
            print("|---|---|---|---|---|---|---|")
            shown = list(range(min(args.modes, len(w))))
            shown += [j for j in range(len(w) - 1, len(w) - 1 - args.stiffest, -1) if j not in shown]
            for j in shown:
                print(_describe(pts, tri, w, v, j, area, hmin, BDF2.explicit_interval, stress))
            print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
