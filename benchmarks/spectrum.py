"""Which normal modes of a shape grow: the spectrum of the linearised normal dynamics.

The shape moves by ``dX/dt = v_n(X) n``; linearised about a shape, a normal displacement ``s``
(one number per node) evolves with ``J s = d v_n / dX [s n]``
(:func:`cortex_ti.dynamics.spectrum.normal_spectrum`: the scene's own formulation linearised,
all eigenvalues up to 3000 nodes, the rightmost ones by ARPACK above; deterministic). For a
scene on its initial shape, on a uniformly tense sphere (``--uniform``: zeta = 1, the state the
tension relaxes to), or on frames of a stored run (``--trajectory RUN.h5 --times ...``, with the
run's scene and active stress), it prints the largest real part, how many eigenvalues have
Re > 0.1 and > 1 (1/t_a), the stiffest eigenvalue and its explicit Euler limit 2/|lambda|.
With ``--dt DT`` the velocity is the one solved for a step DT (the semi-implicit tension):
the column ``step factor`` is then the largest ``|1 + DT lambda|``, what one step of DT does to
the worst mode.

Usage::

    python benchmarks/spectrum.py furrow_p4_a1 --uniform --nodes 162 642 2562 --no-bending
    python benchmarks/spectrum.py furrow_p4_a1 --uniform --nodes 642 --set numerics.formulation=paper
    python benchmarks/spectrum.py --trajectory RUN.h5 --times 0 1 3 [--dt 1e-3]

Cost (one core): 642 nodes a few seconds, 2562 about a minute (dense), 10242 a few minutes (ARPACK).
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import time

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

NO_BENDING = ["viscosity.bending=0", "viscosity.bending_bulk=0"]


def without_bending(scene, load):
    """The scene with the bending viscosity switched off (``load(extra_overrides)`` rebuilds it)."""
    eff = sorted(e for e in scene.effects if e != "bending_viscosity")
    return load(NO_BENDING + ["effects=[" + ",".join(eff) + "]"])


def cases(args):
    from cortex_ti.scene import load_scene, scene_from_dict
    from cortex_ti.simulation import Simulation

    if args.trajectory:
        from cortex_ti.io import Trajectory

        tr = Trajectory(args.trajectory)
        ds = tr.ds

        def rebuild(extra=()):
            return scene_from_dict(copy.deepcopy(tr.scene.data), list(args.overrides) + list(extra))

        scene = rebuild()
        if args.no_bending:
            scene = without_bending(scene, rebuild)
        t = ds["time"].values
        for want in args.times:
            k = int(np.argmin(np.abs(t - want)))
            sim = Simulation(scene)
            sim.zeta = np.asarray(ds["active_stress"].values[k], dtype=float)
            yield f"{scene.name} t={t[k]:.3g}", sim, ds["points"].values[k]
        return
    for nodes in args.nodes:
        ov = list(args.overrides) + ([f"mesh.nodes={nodes}"] if nodes else [])
        scene = load_scene(args.scene, ov)
        if args.no_bending:
            scene = without_bending(scene, lambda extra, ov=ov: load_scene(args.scene, ov + extra))
        sim = Simulation(scene)
        if args.uniform:
            sim.zeta = np.ones(sim.mesh.n_nodes)
        yield f"{scene.name} N={sim.mesh.n_nodes}{' uniform' if args.uniform else ''}", sim, sim.mesh.points


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scene", nargs="?", default=None, help="built-in scene or YAML (not with --trajectory)")
    p.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
    p.add_argument("--nodes", type=int, nargs="*", default=[None])
    p.add_argument("--uniform", action="store_true", help="zeta = 1 at every node (a uniformly tense sphere)")
    p.add_argument("--no-bending", action="store_true", help="switch the bending viscosity off")
    p.add_argument("--trajectory", default=None, help="a stored run: its frames at --times")
    p.add_argument("--times", type=float, nargs="*", default=[0.0])
    p.add_argument("--dt", type=float, default=0.0, help="the semi-implicit step solved for (0: the rate)")
    p.add_argument("--k", type=int, default=12, help="eigenvalues ARPACK computes above 3000 nodes")
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--json", default=None, help="append one JSON record per case to this file")
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:  # the uniformly tense 162-node sphere of the furrow scene
        args.scene, args.uniform, args.nodes, args.trajectory = args.scene or "furrow_p4_a1", True, [162], None
    if (args.scene is None) == (args.trajectory is None):
        p.error("give a scene or --trajectory, not both")

    from cortex_ti import runtime
    from cortex_ti.dynamics.spectrum import normal_spectrum

    runtime.init(threads=args.threads)
    last = f"step factor at dt = {args.dt:g}" if args.dt > 0 else "Euler limit"
    print(
        f"| case | formulation | bending | largest Re lambda (1/t_a) | # Re > 0.1 | # Re > 1 | stiffest | {last} "
        "| method | s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, sim, x in cases(args):
        t0 = time.perf_counter()
        spec = normal_spectrum(sim, x, dt=args.dt, k=args.k)
        wall = time.perf_counter() - t0
        num = sim.settings.numerics
        form = num.formulation + (f" rows {num.fit_residual_weight:g}" if num.fit_residual_weight else "")
        bend = "on" if sim.settings.has("bending_viscosity") else "off"
        stiff = spec.stiffest
        col = f"{np.abs(1 + args.dt * spec.eigenvalues).max():.3g}" if args.dt > 0 else f"{2.0 / abs(stiff):.2e}"
        print(
            f"| {label} | {form}, {num.fit} | {bend} | {spec.largest_real:+.3g} | {spec.count_above(0.1)} | "
            f"{spec.count_above(1.0)} | {stiff.real:+.3g}{stiff.imag:+.2g}j | {col} | {spec.method} | {wall:.0f} |",
            flush=True,
        )
        if args.json:
            with open(args.json, "a") as fh:
                fh.write(
                    json.dumps(
                        dict(
                            case=label,
                            formulation=num.formulation,
                            fit=num.fit,
                            rows=num.fit_residual_weight,
                            bending=bend,
                            dt=args.dt,
                            largest_real=spec.largest_real,
                            n_above_0p1=spec.count_above(0.1),
                            n_above_1=spec.count_above(1.0),
                            stiffest=[stiff.real, stiff.imag],
                            top=[[complex(w).real, complex(w).imag] for w in spec.eigenvalues[:8]],
                            leak=spec.leak,
                            method=spec.method,
                            seconds=wall,
                        )
                    )
                    + "\n"
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
