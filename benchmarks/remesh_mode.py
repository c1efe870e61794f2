"""The growing modes of a stored frame, on that frame's own mesh (a remeshed run's too): the
eigenvalues of the linearised normal dynamics of largest real part (cortex_ti.dynamics.spectrum)
and, for each, how localised it is and whether it alternates in sign between neighbouring nodes
(a mesh-scale mode) or not (a smooth one). Usage::

    python benchmarks/remesh_mode.py run.h5.partial --time 2.2
    python benchmarks/remesh_mode.py --smoke        # a 162-node frame at t = 0.02

A growing mode (Re lambda > 0) grows at any time step: the step is not the cause.
"""

from __future__ import annotations

import argparse

import _smoke  # benchmarks/_smoke.py: what the --smoke modes share
import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trajectory", nargs="?")
    ap.add_argument("--time", type=float, default=None, help="the frame nearest this time (default: the last)")
    ap.add_argument("--modes", type=int, default=4)
    ap.add_argument("--smoke", action="store_true", help=_smoke.HELP)
    args = ap.parse_args(argv)
    if args.smoke:
        args.trajectory = str(_smoke.tiny_run("furrow_p4_a1", t_end=0.02))
    if not args.trajectory:
        ap.error("give a trajectory")
    from cortex_ti.dynamics.spectrum import normal_spectrum
    from cortex_ti.io.trajectory import Trajectory
    from cortex_ti.simulation import Simulation
    from cortex_ti.surface.transport import dual_areas

    tr = Trajectory(args.trajectory)
    k = len(tr.times) - 1 if args.time is None else tr.frame_at(args.time)
    pts, tri = tr.mesh(k)
    sim = Simulation(tr.scene)
    sim.use_mesh(pts, tri)
    sim.zeta = tr.nodal("active_stress", k)  # the tension the frame's nodes carried
    dt = float(tr.ds["dt"].values[k]) if "dt" in tr.ds else 0.0
    sp = normal_spectrum(sim, pts, dt=dt, modes=True, dense=True)
    w, v = np.asarray(sp.eigenvalues), np.asarray(sp.modes)
    area = dual_areas(pts, tri)
    radius = np.hypot(pts[:, 0], pts[:, 1])
    edges = np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]])
    print(f"# Growing modes at t = {float(tr.times[k]):.4g} ({len(pts)} nodes, step dt = {dt:g})\n")
    print("| lambda (1/t_a) | effective nodes | where (z, r of its largest entry) | sign changes between neighbours |")
    print("|---|---|---|---|")
    for j in range(min(args.modes, len(w))):
        s = np.real(v[:, j])
        p = s * s * area / np.sum(s * s * area)
        top = int(np.argmax(p))
        big = np.abs(s) > 0.1 * np.abs(s).max()
        pair = big[edges[:, 0]] & big[edges[:, 1]]
        flips = float(np.mean(np.sign(s[edges[pair, 0]]) != np.sign(s[edges[pair, 1]]))) if pair.any() else 0.0
        print(
            f"| {w[j].real:.4g}{w[j].imag:+.2g}i | {1.0 / np.sum(p * p):.0f} | "
            f"z = {pts[top, 2]:.3f}, r = {radius[top]:.3f} | {100 * flips:.0f} % |"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
