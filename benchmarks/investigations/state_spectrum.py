"""Question: Which modes of the whole state (shape and carried tension) grow, in 3D and in the axisymmetric
twin?

Answer: At 642 nodes, t = 1, mean-velocity gauge: the free translation (+0.2787, 98 % a translation
along z; the twin +0.2397) and eight tension-only modes at +0.0374 to +0.0379 (the crest modes, see
crest_modes.py); with the centroid gauge no shape mode at t = 1. At 2562 nodes: +0.2777 and 184 tension-
only modes up to +0.187. docs/validation/material_cortex.md.

Which modes of the whole state grow: the shape and the tension it carries, in 3D and in the
axisymmetric twin.

For frames of a stored 3D run with ``tension_transport: material`` (its scene, its state: node
positions and the carried tension), :func:`cortex_ti.dynamics.spectrum.state_spectrum` gives every
eigenvalue of the linearised dynamics of the state (normal displacement of each node, tension at
each node). The axisymmetric twin (the same scene, ``tension='material'``: the state carries the
material label of each meridian point, the tension is its function) is solved to the same times on
the full meridian (no up-down reduction), its exact Jacobian restricted to normal displacements and
labels (``E^T J E``, ``E = diag(N, 1)``; a label change ``du`` is a tension change ``zeta'(u) du``,
which leaves the eigenvalues as they are). Each growing 3D mode (Re > ``--above``) is listed with the
share of its norm in the tension block, the share of its normal part that is a rigid translation
seen through the normals, and the nearest axisymmetric rate. Both translation gauges (scene key
``translation``) are measured: the 3D scene rebuilt with the other gauge on the same state, the
axisymmetric Jacobian with the other gauge on the same state.

Usage::

    cortex-ti run furrow_p4_a1 --set mesh.nodes=642 --set tension_transport=material -o m642.h5
    python benchmarks/investigations/state_spectrum.py m642.h5 --times 1 3

Cost (one core): 642 nodes about two minutes per frame and gauge (2 x 1284 solves), the
axisymmetric part seconds.
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

GAUGES = {"mean_velocity": "velocity", "centroid": "centroid"}  # 3D scene key -> axisymmetric gauge


def axisymmetric_rates(settings, times, gauge, n):
    """{t: eigenvalues of E^T J E} of the axisymmetric twin with the carried tension, largest real part first."""
    from cortex_ti.axisymmetric.evolve import full_meridian_dynamics, normal_embedding, simulate
    from cortex_ti.axisymmetric.run import axisymmetric_tension, viscosities

    zeta, visc = axisymmetric_tension(settings), viscosities(settings)
    res = simulate(
        zeta,
        **visc,
        t_end=max(times),
        save_times=[0.0, *times],
        n=n,
        rtol=1e-10,
        symmetric=False,
        parametrization="lagrangian",
        gauge="velocity",  # the run's gauge: the shapes differ between gauges only by a translation
        tension="material",
    )
    out = {}
    for t in times:
        i = res.index(t)
        y = np.concatenate([res.r[i], res.z[i], res.u[i]])
        dyn = full_meridian_dynamics(zeta, n, **visc, gauge=GAUGES[gauge], tension="material")
        e = np.zeros((3 * n, 2 * n))
        e[: 2 * n, :n] = normal_embedding(dyn, y)
        e[2 * n :, n:] = np.eye(n)
        w = np.linalg.eigvals(e.T @ dyn.jac(t, y) @ e)
        out[t] = w[np.argsort(-w.real)]
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("trajectory", nargs="?", help="a 3D run with tension_transport: material")
    p.add_argument("--times", type=float, nargs="*", default=[1.0, 3.0])
    p.add_argument("--above", type=float, default=0.01, help="list the modes with Re lambda above this (1/t_a)")
    p.add_argument("--axisym-n", type=int, default=64, help="full-meridian points of the axisymmetric twin")
    p.add_argument("--gauges", nargs="*", default=list(GAUGES), choices=list(GAUGES))
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:  # a 162-node carried-tension furrow to t = 0.05, one frame, a coarse twin
        args.trajectory = str(_bench.tiny_run("furrow_p4_a1", t_end=0.05, overrides=["tension_transport=material"]))
        args.times, args.axisym_n, args.gauges = [0.05], 16, ["mean_velocity"]
    if not args.trajectory:
        p.error("give a trajectory")

    from cortex_ti import runtime
    from cortex_ti.dynamics.spectrum import state_spectrum, translation_share
    from cortex_ti.dynamics.state import State
    from cortex_ti.io import Trajectory
    from cortex_ti.scene import scene_from_dict
    from cortex_ti.simulation import Simulation

    runtime.init(threads=1)
    with Trajectory(args.trajectory) as tr:
        ds = tr.ds
        data = copy.deepcopy(tr.scene.data)
        t_all = ds["time"].values
        frames = {}
        for want in args.times:
            k = tr.frame_at(want)
            var = "prescribed_tension" if "prescribed_tension" in ds else "active_stress"  # the whole tension
            frames[float(t_all[k])] = (ds["points"].values[k].copy(), ds[var].values[k].copy())
    print(
        "| gauge | t | N | 3D: growing eigenvalues (tension share, translation share of the normal part) | "
        f"axisymmetric (n = {args.axisym_n}): Re > {args.above:g} | 3D / axisym. next below | s |"
    )
    print("|---|---|---|---|---|---|---|")
    for gauge in args.gauges:
        scene = scene_from_dict(copy.deepcopy(data), [f"translation={gauge}"])
        if scene.settings.tension_transport != "material":
            p.error("the run must carry its tension (tension_transport: material)")
        ax = axisymmetric_rates(scene.settings, list(frames), gauge, args.axisym_n)
        for t, (points, tension) in frames.items():
            t0 = time.perf_counter()
            sim = Simulation(scene)
            state = State(points, {"prescribed_tension": tension}, sim.mesh.faces)
            spec = state_spectrum(sim, state, modes=True)
            geo = sim.shape_geometry(points)
            n = spec.n_nodes
            listed = []
            for k in np.flatnonzero(spec.eigenvalues.real > args.above):
                v = spec.modes[:, k]
                v = np.real(v * np.exp(-1j * np.angle(v[np.argmax(np.abs(v))])))
                share, u = translation_share(v[:n], geo.normal, np.asarray(geo.area))
                w = spec.eigenvalues[k]
                listed.append(
                    f"{w.real:+.4f}{w.imag:+.1e}j ({spec.share(k, 'prescribed_tension'):.2f}, {share:.2f} along "
                    f"[{u[0]:+.2f} {u[1]:+.2f} {u[2]:+.2f}])"
                )
            wa = ax[t]
            grow = ", ".join(f"{x.real:+.4f}" for x in wa[wa.real > args.above]) or "none"
            below3 = spec.eigenvalues.real[spec.eigenvalues.real <= args.above][:1]
            belowa = wa.real[wa.real <= args.above][:1]
            print(
                f"| {gauge} | {t:g} | {n} | {'; '.join(listed) or 'none'} | {grow} | "
                f"{below3[0]:+.4f} / {belowa[0]:+.4f} | {time.perf_counter() - t0:.0f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
