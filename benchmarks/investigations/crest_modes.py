"""Question: Where do the growing modes of a carried tension (tension_transport: material) come from?

Answer: From the transport alone, at the crest ring: with the flow frozen the transport has the whole
state's modes (eight at +0.0376 at 642 nodes, 184 up to +0.1877 at 2562), 77 % of the leading mode's
norm on eight nodes next to the crest, where the old face rule made a node's rate a downwind difference;
the face rule was changed (commit 88b2f4c). docs/validation/material_cortex.md, "The crest modes: cause
and fix".

The carried tension's transport alone at a stored state: its growing modes, where they live, and
whether the nonlinear scheme follows them.

For one frame of a 3D run with ``tension_transport: material`` (normal mesh motion: the tension is
carried by the tangential flow ``u``), the flow is frozen and the transport rate of the tension,
``advective_rate(q, PROPERTY, x, faces, u)``, is linearised by central differences, one node at a
time (``J``, no solves: the tension block of ``state_jacobian`` without the flow's response). For
each face rule (``--faces``; ``current`` is the scheme, the others are the comparisons):

* ``current``: the upwind value extrapolated to the edge midpoint, clipped between the upwind value
  and the edge average;
* ``old``: extrapolated to the dual edge's midpoint, clipped to ``[q_a, q_b]`` (the scheme before
  2026-12-03: a face could carry the downwind value);
* ``first``: the upwind value; ``unlimited``: the old extrapolation without the clip.

Printed: the number of eigenvalues with Re > 1e-3 and the largest, the largest excess of a mode over
its own compression bound ``(1/2) <div_h u>_v`` (docs/derivations/transport.md, "Energy"), the leading
mode's support (polar angles, tension, share of its norm on its six largest nodes) and the same
eigenvalue with other differencing steps (``--eps``). With ``--perturb`` the nonlinear check: ``q`` and
``q + delta v`` (v the leading mode, max-normalised) integrated with RK4 at the frozen flow, their
difference's growth against ``exp(Re lambda t)``.

Usage::

    cortex-ti run furrow_p4_a1 --set mesh.nodes=642 --set tension_transport=material --set time.t_end=1 -o m642.h5
    python benchmarks/investigations/crest_modes.py m642.h5 --faces current old first unlimited --perturb

Cost: 2N rate evaluations per rule and one dense eigendecomposition (642 nodes: ~10 s a rule).
"""

from __future__ import annotations

import argparse
import copy
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # benchmarks/: its _bench
import _bench  # noqa: E402  (benchmarks/_bench.py: the helpers every benchmark shares)
import numpy as np


def old_faces(values, grad, points, faces, flux, mids, clip=True):
    a, b = faces, faces[:, [1, 2, 0]]
    up = np.where(flux >= 0.0, a, b)
    rec = values[up] + np.einsum("tkc,tkc->tk", grad[up], mids - points[up])
    return np.clip(rec, np.minimum(values[a], values[b]), np.maximum(values[a], values[b])) if clip else rec


def first_faces(values, grad, points, faces, flux, mids):
    return values[np.where(flux >= 0.0, faces, faces[:, [1, 2, 0]])]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trajectory", nargs="?", help="a 3D run with tension_transport: material, normal motion")
    p.add_argument("--time", type=float, default=1.0)
    p.add_argument("--faces", nargs="*", default=["current", "old"], choices=["current", "old", "first", "unlimited"])
    p.add_argument("--eps", type=float, nargs="*", default=[1e-8, 1e-3], help="other steps (times max |q|)")
    p.add_argument("--perturb", action="store_true", help="the nonlinear check along the leading mode")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:
        args.trajectory = str(_bench.tiny_run("furrow_p4_a1", t_end=0.05, overrides=["tension_transport=material"]))
        args.time, args.eps = 0.05, [1e-3]
    if not args.trajectory:
        p.error("give a trajectory")

    from cortex_ti import runtime
    from cortex_ti.dynamics.state import State
    from cortex_ti.io import Trajectory
    from cortex_ti.scene import scene_from_dict
    from cortex_ti.simulation import Simulation
    from cortex_ti.surface import transport as tp

    runtime.init(threads=1)
    with Trajectory(args.trajectory) as tr:
        ds = tr.ds
        data = copy.deepcopy(tr.scene.data)
        k = tr.frame_at(args.time)
        var = "prescribed_tension" if "prescribed_tension" in ds else "active_stress"
        x, q, t = ds["points"].values[k].copy(), ds[var].values[k].copy(), float(ds["time"].values[k])
    sim = Simulation(scene_from_dict(data))
    if sim.motion.name != "normal":
        p.error("the run must move its nodes normally (mesh.motion: normal)")
    ev = sim.evaluate(State(x, {"prescribed_tension": q}, sim.mesh.faces))
    u = ev.velocity - ev.normal_speed[:, None] * ev.normal
    f, n = sim.mesh.faces, q.size
    tri = tp.triangle_gradients(x, f)
    area = tp.dual_areas(x, f)
    flux, _ = tp.dual_fluxes(x, f, u, tri)
    a, b = f, np.roll(f, -1, axis=1)
    div = np.bincount(np.concatenate([a.ravel(), b.ravel()]), weights=np.concatenate([flux.ravel(), -flux.ravel()]))
    div /= area
    polar = np.degrees(np.arccos(np.clip(x[:, 2] / np.linalg.norm(x, axis=1), -1, 1)))
    current = tp._face_values
    rules = {
        "current": current,
        "old": old_faces,
        "first": first_faces,
        "unlimited": lambda *z: old_faces(*z, clip=False),
    }

    def rate(vals):
        return tp.advective_rate(vals, tp.PROPERTY, x, f, u, tri)

    def jacobian(eps):
        jac = np.empty((n, n))
        for j in range(n):
            d = np.zeros(n)
            d[j] = eps
            jac[:, j] = (rate(q + d) - rate(q - d)) / (2 * eps)
        return jac

    scale = max(1.0, float(np.abs(q).max()))
    print(f"{args.trajectory}, t = {t:g}, {n} nodes; (1/2) max div_h u = {0.5 * div.max():+.4f}")
    try:
        for name in args.faces:
            tp._face_values = rules[name]
            w, v = np.linalg.eig(jacobian(1e-5 * scale))
            order = np.argsort(-w.real)
            w, v = w[order], v[:, order]
            weight = area[:, None] * np.abs(v) ** 2
            excess = w.real - 0.5 * (div @ weight) / weight.sum(0)
            lead = np.abs(v[:, 0])
            top = np.argsort(-lead)[:6]
            others = ", ".join(f"eps {e:g}: {np.linalg.eigvals(jacobian(e * scale)).real.max():+.4f}" for e in args.eps)
            print(
                f"{name}: Re > 1e-3: {int(np.sum(w.real > 1e-3))}, largest {w[0].real:+.4f}; "
                f"largest excess over (1/2)<div_h u>_v {excess.max():+.4f}; leading mode on polar "
                f"{np.unique(polar[top].round(1))} deg, q {np.unique(q[top].round(4))}, "
                f"share {np.sum(lead[top] ** 2) / np.sum(lead**2):.2f}; {others}",
                flush=True,
            )
            if args.perturb:
                mode = np.real(v[:, 0] * np.exp(-1j * np.angle(v[np.argmax(lead), 0])))
                mode /= np.abs(mode).max()

                def rk4(vals, dt):
                    k1 = rate(vals)
                    k2 = rate(vals + dt / 2 * k1)
                    k3 = rate(vals + dt / 2 * k2)
                    return vals + dt / 6 * (k1 + 2 * k2 + 2 * k3 + rate(vals + dt * k3))

                for delta in (1e-8, 1e-4):
                    base, pert, row = q.copy(), q + delta * mode, []
                    for step in range(1, 201):
                        base, pert = rk4(base, 0.01), rk4(pert, 0.01)
                        if step in (5, 50, 100, 200):
                            growth = np.abs(pert - base).max() / delta
                            row.append(f"t {step / 100:g}: {growth:.4f} (linear {np.exp(w[0].real * step / 100):.4f})")
                    print(f"  perturbed by {delta:g} x mode, max|dq|/delta: " + "; ".join(row), flush=True)
    finally:
        tp._face_values = current
    return 0


if __name__ == "__main__":
    sys.exit(main())
