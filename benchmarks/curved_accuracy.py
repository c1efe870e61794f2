"""Curved cells (``rayleigh_p2``) against flat triangles (``rayleigh_p1``) beyond t = 0: sphere flows
with a tangential part, instantaneous flows on deformed shapes, and the furrow's dynamics.

Three parts (``--parts``), each a table of both formulations at each node count:

* ``spheres``: the four analytic sphere scenes (paper Figs. 2, 3: ``sphere_y20_full``,
  ``sphere_y20_tangential``, ``sphere_y21_tangential``), eps_rel against their closed forms;
* ``deformed``: the instantaneous flow on the axisymmetric twin's shape of ``furrow_p4_a1`` at
  ``--times``: every node placed at its label's point of the twin's converged surface (the twin's
  own run to that time), the 3D solve's velocity against the twin's at the labels: largest and rms
  error of the normal speed, over the nodes and at the pole node. The twin's velocity at a saved
  time is interpolated from its steps: at early times (t < 1, where v_n changes fast) that reference
  carries errors of ~1e-4 at the pole, which both formulations then share; the rms over the nodes is
  the measure to read;
* ``furrow``: ``furrow_p4_a1`` run to ``--t-end`` with the scene's defaults (``--set`` adds keys,
  e.g. ``time.tol=1e-7`` for a time-converged run) and compared with its twin at the nodes: the pole
  node's height and the mean radius of the equator's nodes (no flat or curved section needed), largest
  deviation over the run, and the wall time of the run (one thread).

The twin's bending viscosity (``--twin-bending``): ``paper`` (Eq. 45, the twin of every other page)
or ``dissipation``, the force of the dissipation both 3D formulations integrate. They differ by
``(nabla_c beta^cd) d_d v_n``, zero on a sphere: at t = 0.5 the pole by 4.9e-5, and ``rayleigh_p1``
converges at second order to the ``dissipation`` twin (limit 3e-6), to the ``paper`` one with an
offset of -4.5e-5 (time-converged runs, ``--set time.tol=1e-7 --set time.dt=1e-5``).

Usage::

    python benchmarks/curved_accuracy.py                          # all parts, 642 2562
    python benchmarks/curved_accuracy.py --parts furrow --nodes 642 2562 10242 --set time.tol=1e-7
    python benchmarks/curved_accuracy.py --smoke

Cost: ``spheres`` and ``deformed`` a minute at 642 and 2562 nodes; ``furrow`` ~15 s (642) and ~1 min
(2562) per formulation, ~6 min for rayleigh_p2 at 10242 nodes.
"""

from __future__ import annotations

import argparse
import sys
import time

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

METHODS = {"rayleigh_p1": "quadratic", "rayleigh_p2": "quartic"}
SPHERES = ("sphere_y20_full", "sphere_y20_tangential", "sphere_y21_tangential")


def _scene(name, nodes, form, extra=()):
    from cortex_ti.scene import load_scene

    return load_scene(
        name, [f"mesh.nodes={nodes}", f"numerics.formulation={form}", f"numerics.fit={METHODS[form]}", *extra]
    )


def spheres(nodes_list, forms):
    from cortex_ti.simulation import Simulation
    from cortex_ti.truth import analytic

    rows = []
    for name in SPHERES:
        for form in forms:
            errs = []
            for nodes in nodes_list:
                scene = _scene(name, nodes, form, ["solver.reuse=false"])
                sim = Simulation(scene)
                sol = sim.solve()
                exact = analytic.scene_solution(scene.settings, sim.mesh.points)
                errs.append(analytic.error_measures(sol.velocity, exact)[1])
            rows.append((name, form, errs))
    print("\n**Analytic sphere scenes** (eps_rel, ratio to the previous node count)\n")
    print("| scene | formulation | " + " | ".join(f"N = {n}" for n in nodes_list) + " |")
    print("|---|---|" + "---|" * len(nodes_list))
    for name, form, errs in rows:
        print(f"| {name} | {form} | " + " | ".join(_with_ratio(errs)) + " |")


def _with_ratio(errs):
    out = [f"{errs[0]:.3g}"]
    out += [f"{e:.3g} ({p / e:.1f})" for p, e in zip(errs, errs[1:], strict=False)]
    return out


def _twin(t_end, save, bending_form="paper"):
    from cortex_ti.axisymmetric.evolve import simulate
    from cortex_ti.axisymmetric.run import AxisymmetricRun, evolution_options, viscosities
    from cortex_ti.scene import load_scene

    run = AxisymmetricRun(load_scene("furrow_p4_a1", ["model=axisymmetric"]))
    s = run.settings
    return simulate(
        run.zeta,
        **viscosities(s),
        radius=s.mesh.radius,
        t_end=t_end,
        save_times=np.asarray(save, dtype=float),
        n=s.axisymmetric.n,
        rtol=s.axisymmetric.rtol,
        interpolate=True,
        **dict(evolution_options(s), stop_neck=None, stop_ill_posed=False, bending_form=bending_form),
    )


def deformed(nodes_list, forms, times, bending_form):
    from cortex_ti.simulation import Simulation

    res = _twin(max(times), [0.0, *times], bending_form)
    print(
        "\n**Instantaneous flow on the twin's shape of furrow_p4_a1** (normal speed error: rms over the "
        "nodes / largest / at the pole node)\n"
    )
    print("| t | formulation | " + " | ".join(f"N = {n}" for n in nodes_list) + " |")
    print("|---|---|" + "---|" * len(nodes_list))
    for k, t in enumerate(times, start=1):
        for form in forms:
            cells = []
            for nodes in nodes_list:
                sim = Simulation(_scene("furrow_p4_a1", nodes, form, ["solver.reuse=false"]))
                x0 = sim.mesh.points
                label = np.arccos(np.clip(x0[:, 2] / np.linalg.norm(x0, axis=1), -1.0, 1.0))
                phi = np.arctan2(x0[:, 1], x0[:, 0])
                e = res.evaluate(k, label, coordinate="label")
                x = np.stack([e["r"] * np.cos(phi), e["r"] * np.sin(phi), e["z"]], axis=1)
                normal = np.stack([e["n_r"] * np.cos(phi), e["n_r"] * np.sin(phi), e["n_z"]], axis=1)
                sol = sim.solve(x)
                dvn = np.einsum("nc,nc->n", sol.velocity, normal) - e["v_n"]
                pole = int(np.argmax(x0[:, 2]))
                cells.append(f"{np.sqrt(np.mean(dvn**2)):.2e} / {np.abs(dvn).max():.2e} / {dvn[pole]:+.1e}")
            print(f"| {t:g} | {form} | " + " | ".join(cells) + " |")


def furrow(nodes_list, forms, t_end, sets, folder, bending_form):
    from cortex_ti.axisymmetric.compare import node_radii, pole_and_equator
    from cortex_ti.io.trajectory import Trajectory
    from cortex_ti.simulation import Simulation

    print(
        f"\n**furrow_p4_a1 to t = {t_end:g} against its twin at the nodes** (largest |error| over the run: "
        "pole node height / equator nodes' mean radius; wall seconds, one thread"
        + (f"; {' '.join(sets)}" if sets else "")
        + ")\n"
    )
    print("| formulation | " + " | ".join(f"N = {n}" for n in nodes_list) + " |")
    print("|---|" + "---|" * len(nodes_list))
    res = None
    for form in forms:
        cells = []
        for nodes in nodes_list:
            sim = Simulation(_scene("furrow_p4_a1", nodes, form, [f"time.t_end={t_end}", *sets]))
            t0 = time.perf_counter()
            path = sim.run(folder / f"{form}_{nodes}.h5", progress=False)
            wall = time.perf_counter() - t0
            tr = Trajectory(str(path), lazy=True)
            if res is None or len(res.pole_radius) != len(tr.times):
                res = _twin(float(tr.times[-1]), tr.times, bending_form)
            x = tr.ds["points"].values
            pole, eq = pole_and_equator(x[0])
            ep, ef = node_radii(x[:, pole], x[:, eq], res)
            cells.append(f"{ep:.2e} / {ef:.2e} ({wall:.0f} s)")
        print(f"| {form} | " + " | ".join(cells) + " |")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--parts", nargs="+", default=["spheres", "deformed", "furrow"], choices=["spheres", "deformed", "furrow"]
    )
    p.add_argument("--nodes", nargs="+", type=int, default=[642, 2562])
    p.add_argument("--formulations", nargs="+", default=list(METHODS), choices=list(METHODS))
    p.add_argument("--times", nargs="+", type=float, default=[1.0, 2.0], help="deformed: twin times")
    p.add_argument("--t-end", type=float, default=3.0, help="furrow: end time")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="furrow: more scene keys")
    p.add_argument(
        "--twin-bending",
        default="paper",
        choices=["paper", "dissipation"],
        help="the twin's bending viscosity: paper Eq. 45 or the 3D formulations' dissipation form",
    )
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    from cortex_ti import runtime

    runtime.init(threads=args.threads)
    folder = _bench.folder()
    if args.smoke:
        args.nodes, args.times, args.t_end = [42, 162], [0.05], 0.02
    if "spheres" in args.parts:
        spheres(args.nodes, args.formulations)
    if "deformed" in args.parts:
        deformed(args.nodes, args.formulations, args.times, args.twin_bending)
    if "furrow" in args.parts:
        furrow(args.nodes, args.formulations, args.t_end, args.set, folder, args.twin_bending)
    return 0


if __name__ == "__main__":
    sys.exit(main())
