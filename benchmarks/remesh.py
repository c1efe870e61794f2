"""Deep furrows with remeshing (mesh.remesh): the ring furrow p = 4 at amplitudes 6 and 12 with the
mesh moving normally (tension glued to the nodes, the paper's) or by ALE (tension carried by the
material), each with remeshing below 25 deg, to t = 5 or until the run stops.

Per run: the time reached and why it stopped, the smallest triangle angle over the run, the
smallest neck (the smallest section radius along the axis, cortex_ti.analysis.diagnostics.neck_radius;
the furrow radius in the plane through the centroid where the shape has no neck), the largest
volume drift |V/V0 - 1|, the remeshings, their share
of the run's wall time, the node count at the end and the symbolic analyses of the factorisation;
the steps: accepted, the share rejected, the median step before the first remeshing and after
it; then the neck radius over time against the axisymmetric twin (model: axisymmetric, the same
scene) while that runs, and the largest deviation from it while the twin is resolved (its label
map resolved by its points; the twin of ``constriction_p4`` has adaptive points, converged to 1e-9 R0 down
to its neck of 0.1).
Usage::

    python benchmarks/remesh.py --nodes 642 2562                  # the table (minutes on 2 cores)
    python benchmarks/page.py remesh --title "Deep furrows with remeshing" -- remesh --nodes 642 2562
    python benchmarks/remesh.py --scene constriction_p4 --motions normal --nodes 642 2562
    python benchmarks/remesh.py --smoke                           # 162 nodes, a few steps

Each run is in this process (its summary holds the remeshing counts); a run the guard stops is a
row saying so, its frames up to the stop still measured.
"""

from __future__ import annotations

import argparse
import logging
import tempfile
import time
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np
from _bench import at, twin

MOTIONS = {
    "normal (glued)": [],
    "ale (material)": ["mesh.motion=ale", "tension_transport=material"],
}
#: how the remesher sizes and when it fires: the scene settings of each variant
SIZINGS = {
    "curvature": [
        "mesh.remesh.size=curvature",
        "mesh.remesh.coarser=null",
    ],  # h = clip(0.25 / kappa, h_min, mean edge): before issue 18's budget
    "budget": [
        "mesh.remesh.size=budget",
        "mesh.remesh.coarser=null",
    ],  # h = clip(s / kappa, h_min, 3 mean edges), s keeping the node count (h_min: mean edge / 7.5)
    "budget+coarser": ["mesh.remesh.size=budget", "mesh.remesh.coarser=1.5"],  # and on resolution
    # h within 2 % of the initial mean edge {h} everywhere: no curvature sizing at all
    "uniform": [
        "mesh.remesh.size=curvature",
        "mesh.remesh.coarser=null",
        "mesh.remesh.h_min={lo}",
        "mesh.remesh.h_max={h}",
    ],
}
TIMES = (0.5, 1.0, 2.0, 3.0, 4.0, 5.0)


def _sizing(sizing: str, nodes: int) -> list[str]:
    """The scene settings of a sizing; ``{h}``/``{lo}``: the initial icosphere's mean edge and 0.98 of it."""
    from cortex_ti.surface.mesh import icosphere
    from cortex_ti.surface.remesh import mean_edge_length

    m = icosphere(nodes)
    h = mean_edge_length(m.points, m.faces)
    return [x.format(h=f"{h:.5g}", lo=f"{0.98 * h:.5g}") for x in SIZINGS[sizing]]


def one(
    amplitude: float, nodes: int, motion: str, t_end: float, min_angle: float, where, scene: str, sizing: str
) -> dict:
    from cortex_ti.io.trajectory import Trajectory
    from cortex_ti.scene import load_scene
    from cortex_ti.simulation import Simulation
    from cortex_ti.studies.constriction import neck_or_furrow
    from cortex_ti.studies.stores import neck_series

    sets = [
        f"mesh.nodes={nodes}",
        f"active_stress.0.amplitude={amplitude}",
        f"time.t_end={t_end}",
        "time.save_every=0.05",
        f"mesh.remesh.min_angle={min_angle}",
        f"mesh.remesh.quality={max(30.0, min_angle + 5.0)}",
        *MOTIONS[motion],
        *_sizing(sizing, nodes),
    ]
    sim = Simulation(load_scene(scene, sets))
    out = where / f"a{amplitude:g}_{nodes}_{motion.split()[0]}_{sizing}.h5"
    start = time.perf_counter()
    why = ""
    try:
        sim.run(out, progress=False, force=True)  # --keep: a folder of an earlier measurement
    except Exception as exc:  # the guard or a failed solve: the frames so far are measured
        why = str(exc).split(";")[0]
    wall = time.perf_counter() - start
    stats = sim.report.stats if sim.report is not None else None
    tr = Trajectory(out)
    ds = tr.ds
    steps = np.asarray(ds["dt"].values, dtype=float)
    first = next((k for k in range(ds.sizes["time"]) if len(tr.mesh(k)[0]) != len(tr.mesh(0)[0])), None)
    volume = ds["volume"].values
    # the neck: once one lobe of a deep furrow grows at the other's expense (amplitude 12 from t ~ 2)
    # the plane through the centroid leaves it, and that plane's radius grows while the neck closes
    necks = neck_or_furrow(neck_series(tr), ds["furrow_radius"].values)
    return {
        "amplitude": amplitude,
        "nodes": nodes,
        "motion": motion,
        "sizing": sizing,
        "path": out,
        "t": float(ds["time"].values[-1]),
        "stopped": sim.report.stopped if sim.report is not None else "?",
        "why": why,
        "min_angle": float(np.min(ds["min_angle_deg"].values)),
        "neck": float(np.min(necks)),
        "drift": float(np.max(np.abs(volume / volume[0] - 1.0))),
        "remeshes": stats.remeshes if stats is not None else 0,
        "share": (stats.remesh_wall / wall) if stats is not None and wall > 0 else float("nan"),
        "wall": wall,
        "final_nodes": sim.mesh.n_nodes,
        "steps": stats.steps if stats is not None else 0,
        "rejected": stats.rejected / max(1, stats.steps + stats.rejected) if stats is not None else float("nan"),
        "dt_before": float(np.median(steps[: first or None])),
        "dt_after": float(np.median(steps[first:])) if first is not None else float("nan"),
        "analyses": sim.solver.n_analyses,
        "times": ds["time"].values,
        "furrow": necks,
    }


def deviation(r: dict, tw: dict, until: float = np.inf) -> tuple[float, float, float]:
    """The largest |3D - twin| neck radius over the run's frames while the twin runs and is
    resolved (and up to ``until``), the time it is at, and the time up to which that is."""
    end = min(r["times"][-1], tw["times"][-1], tw["resolved_until"], until)
    keep = r["times"] <= end + 1e-9
    dev = np.abs(r["furrow"][keep] - np.interp(r["times"][keep], tw["times"], tw["furrow"]))
    k = int(np.argmax(dev))
    return float(dev[k]), float(r["times"][keep][k]), end


def error_at(r: dict, tw: dict, t: float) -> float:
    """|3D - twin| neck radius at the frame nearest ``t`` (NaN past either run's end)."""
    if t > min(r["times"][-1], tw["times"][-1]) + 1e-9:
        return float("nan")
    return abs(at(r["times"], r["furrow"], t) - float(np.interp(t, tw["times"], tw["furrow"])))


def order(coarse: float, fine: float, log_h_ratio: float) -> str:
    """The observed order of an error falling from ``coarse`` to ``fine`` over ``log(h_c / h_f)``."""
    if coarse > 0 and fine > 0 and np.isfinite(coarse / fine):
        return f"{np.log(coarse / fine) / log_h_ratio:.2f}"
    return "-"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, nargs="+", default=[642, 2562])
    ap.add_argument("--amplitudes", type=float, nargs="+", default=[6.0, 12.0])
    ap.add_argument("--t-end", type=float, default=5.0)
    ap.add_argument("--min-angle", type=float, default=25.0)
    ap.add_argument("--scene", default="furrow_p4_a1", help="furrow_p4_a1 (with bending viscosity) or constriction_p4")
    ap.add_argument("--motions", nargs="+", choices=["normal", "ale"], default=["normal", "ale"])
    ap.add_argument("--sizings", nargs="+", choices=list(SIZINGS), default=["budget"], help="remesher variants")
    ap.add_argument("--keep", type=Path, default=None, help="write the trajectories here (default: a temporary folder)")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    if args.smoke:  # the code path only: too short to remesh
        args.nodes, args.amplitudes, args.t_end = [162], [6.0], 0.03
    logging.getLogger("cortex_ti").setLevel(logging.ERROR)
    where = _bench.folder() if args.smoke else args.keep or Path(tempfile.mkdtemp(prefix="cortex-ti-remesh-"))
    where.mkdir(parents=True, exist_ok=True)
    motions = [m for m in MOTIONS if m.split()[0] in args.motions]
    rows = [
        one(a, n, m, args.t_end, args.min_angle, where, args.scene, z)
        for a in args.amplitudes
        for z in args.sizings
        for n in args.nodes
        for m in motions
    ]
    twins = {a: twin(a, args.t_end, where, args.scene) for a in args.amplitudes}
    print(f"# {args.scene} with remeshing below {args.min_angle:g} deg, to t = {args.t_end:g}\n")
    print(
        "Sizings: curvature = h = clip(0.25 / kappa, 0.01, initial mean edge) (before the budget); budget = "
        "h = clip(s / kappa, 0.01, 3 initial mean edges) with s keeping the initial node count; "
        "budget+coarser = that, remeshed also where the mesh is 1.5 times coarser than its field; "
        "uniform = h within 2 % of the initial mean edge everywhere.\n"
    )
    print(
        "| amplitude | nodes | motion | sizing | t reached | stopped | smallest angle (deg) | smallest neck (R0) | "
        "volume drift | remeshings | remeshing share of wall | wall (s) | nodes at the end | symbolic analyses |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(
            f"| {r['amplitude']:g} | {r['nodes']} | {r['motion']} | {r['sizing']} | {r['t']:.3g} | {r['stopped']} | "
            f"{r['min_angle']:.1f} | {r['neck']:.3f} | {r['drift']:.1e} | {r['remeshes']} | "
            f"{100 * r['share']:.1f} % | {r['wall']:.0f} | {r['final_nodes']} | {r['analyses']} |"
        )
    print("\n## Steps (bdf2) and the deviation from the axisymmetric twin\n")
    print(
        "Median step between frames before the first remeshing and after it; deviation: |3D - twin| neck "
        "radius at t = 1 and its largest value over the frames while the twin runs and its material stretch "
        "is below 100 (at which t, and up to which t that was measured).\n"
    )
    print(
        "| amplitude | nodes | motion | sizing | steps | rejected | median dt before | median dt after | "
        "deviation at t = 1 | max deviation | at t | to t |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        tw = twins[r["amplitude"]]
        dev, when, end = deviation(r, tw)
        r["dev"], r["end"] = dev, end
        print(
            f"| {r['amplitude']:g} | {r['nodes']} | {r['motion']} | {r['sizing']} | {r['steps']} | "
            f"{100 * r['rejected']:.0f} % | {r['dt_before']:.2e} | {r['dt_after']:.2e} | "
            f"{error_at(r, tw, 1.0):.2e} | {dev:.2e} | {when:.3g} | {end:.3g} |"
        )
    pairs = [
        (r, q)
        for r in rows
        for q in rows
        if q["nodes"] > r["nodes"]
        and (q["amplitude"], q["motion"], q["sizing"]) == (r["amplitude"], r["motion"], r["sizing"])
    ]
    if pairs:
        print("\n## Order of the neck error with resolution\n")
        print(
            "Observed order p = log(e_coarse / e_fine) / log(h_coarse / h_fine), h ~ N^(-1/2), of the |3D - twin| "
            "neck radius at fixed times (both runs reaching them) and of the largest deviation over the common span.\n"
        )
        shown = [t for t in TIMES if t <= args.t_end + 1e-9]
        print(
            "| amplitude | motion | sizing | nodes | "
            + " | ".join(f"order at t = {t:g}" for t in shown)
            + " | order of the max |"
        )
        print("|---|---|---|---|" + "---|" * (len(shown) + 1))
        for r, q in pairs:
            tw = twins[r["amplitude"]]
            ratio = 0.5 * np.log(q["nodes"] / r["nodes"])
            cells = [order(error_at(r, tw, t), error_at(q, tw, t), ratio) for t in shown]
            end = min(r["end"], q["end"])
            big = [deviation(x, tw, end)[0] for x in (r, q)]
            print(
                f"| {r['amplitude']:g} | {r['motion']} | {r['sizing']} | {r['nodes']} -> {q['nodes']} | "
                + " | ".join(cells)
                + f" | {order(*big, ratio)} |"
            )
    stops = [r for r in rows if r["why"]]
    if stops:
        print("\nWhy runs stopped early:\n")
        for r in stops:
            print(f"- amplitude {r['amplitude']:g}, {r['nodes']} nodes, {r['motion']}, {r['sizing']}: {r['why']}")
    for a in args.amplitudes:
        tw = twins[a]
        print(f"\n## Neck radius (R0) over time, amplitude {a:g}\n")
        print(f"The axisymmetric twin stopped: {tw['stopped']} (at t = {tw['times'][-1]:.3g}).\n")
        shown = [t for t in TIMES if t <= args.t_end + 1e-9] or [args.t_end]
        print("| run | " + " | ".join(f"t = {t:g}" for t in shown) + " |")
        print("|---|" + "---|" * len(shown))
        for r in (r for r in rows if r["amplitude"] == a):
            cells = " | ".join(f"{at(r['times'], r['furrow'], t):.4f}" for t in shown)
            print(f"| {r['nodes']} {r['motion']} {r['sizing']} | {cells} |")
        cells = " | ".join(f"{at(tw['times'], tw['furrow'], t):.4f}" for t in shown)
        print(f"| axisymmetric | {cells} |")
    if args.keep:
        print(f"\nTrajectories: {args.keep}/ (e.g. python benchmarks/remesh_mode.py FILE --time T --stiffest 2)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
