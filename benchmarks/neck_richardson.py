"""Where the 3D neck converges to: Richardson extrapolation of a deep ring's neck radius over
resolutions, against the axisymmetric twin.

Reads the trajectories of one scene at several node counts (finished or ``.partial``: a run still
going is measured up to its last flushed frame), takes each frame's neck (the narrowest section,
``cortex_ti.analysis.diagnostics.neck_radius``; the ring plane's radius before a neck forms, as the
constriction study does), runs the axisymmetric twin of the same ring, and prints at fixed times:

- the neck at each resolution and the twin's;
- the error e_N = 3D - twin and its observed order p = log2(e_coarse / e_fine) for each pair of
  resolutions four times apart in nodes (h halves);
- the Richardson extrapolation of the two finest, ``(4 n_fine - n_coarse) / 3`` (second order
  assumed), and its distance from the twin.

If the 3D discretisation converges to the continuum at second order, the last column falls to the
twin's own error (``constriction_p4``'s adaptive points: 1e-9 down to its neck of 0.1,
docs/validation/constriction.md) plus the next order's remainder. Usage::

    python benchmarks/remesh.py --scene constriction_p4 --motions normal --nodes 642 2562 10242 \\
        --amplitudes 6 --sizings budget --keep RUNS
    python benchmarks/neck_richardson.py RUNS/a6_642_normal_budget.h5 RUNS/a6_2562_normal_budget.h5 \\
        RUNS/a6_10242_normal_budget.h5.partial --amplitude 6
    python benchmarks/neck_richardson.py --smoke
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

TIMES = (0.25, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0)


def necks(path: Path, curved: bool = False) -> tuple[int, np.ndarray, np.ndarray]:
    """(initial node count, frame times, neck radius per frame) of a trajectory (or its .partial);
    ``curved``: the neck cut on the curved cells of a rayleigh_p2 run
    (:func:`cortex_ti.analysis.curved_measures.curved_neck_radius`; its file's furrow radius is the
    curved cells' already), not on their flat sub-triangles."""
    from cortex_ti.analysis.curved_measures import curved_neck_radius
    from cortex_ti.io.trajectory import Trajectory
    from cortex_ti.studies.constriction import neck_or_furrow
    from cortex_ti.studies.stores import neck_series

    with Trajectory(path) as tr:
        if curved:
            axis = tr.settings.pattern_axis
            found = [curved_neck_radius(*tr.mesh(k), axis=axis)[0] for k in range(tr.ds.sizes["time"])]
        else:
            found = neck_series(tr)
        neck = neck_or_furrow(np.asarray(found), tr.ds["furrow_radius"].values)
        return len(tr.mesh(0)[0]), tr.ds["time"].values.astype(float), neck


def value_at(times: np.ndarray, values: np.ndarray, t: float) -> float:
    """The value at the frame at ``t`` (NaN if no frame is within 1e-6 of it)."""
    k = int(np.argmin(np.abs(times - t)))
    return float(values[k]) if abs(times[k] - t) < 1e-6 else float("nan")


def table(runs: list[tuple[int, np.ndarray, np.ndarray]], twin: dict, times) -> list[str]:
    runs = sorted(runs, key=lambda r: r[0])
    nodes = [r[0] for r in runs]
    head = ["t", "twin"] + [f"N={n}" for n in nodes] + [f"e_{n}" for n in nodes]
    pairs = [(i, i + 1) for i in range(len(runs) - 1)]
    head += [f"order {nodes[i]}->{nodes[j]}" for i, j in pairs]
    if len(runs) >= 2:
        head += [f"Richardson {nodes[-2]}, {nodes[-1]}", "Richardson - twin"]
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for t in times:
        tw = value_at(twin["times"], twin["neck"], t)  # a frame of the twin's: no interpolation error
        n = [value_at(r[1], r[2], t) for r in runs]
        if np.all(np.isnan(n)):
            continue
        e = [x - tw for x in n]
        row = [f"{t:g}", f"{tw:.6f}"] + [f"{x:.6f}" for x in n] + [f"{x:+.2e}" for x in e]
        for i, j in pairs:
            ratio = 0.5 * np.log(nodes[j] / nodes[i])
            ok = np.isfinite(e[i] / e[j]) and e[i] / e[j] > 0
            row.append(f"{np.log(e[i] / e[j]) / ratio:.2f}" if ok else "-")
        if len(runs) >= 2:
            r4 = nodes[-1] / nodes[-2]  # h^2 ratio: 4 for 4x the nodes
            rich = (r4 * n[-1] - n[-2]) / (r4 - 1.0)
            row += [f"{rich:.6f}", f"{rich - tw:+.2e}"]
        out.append("| " + " | ".join(row) + " |")
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*", type=Path, help="trajectories of one scene at several node counts")
    ap.add_argument("--amplitude", type=float, default=6.0, help="the ring's amplitude (the twin's)")
    ap.add_argument("--scene", default="constriction_p4")
    ap.add_argument("--times", type=float, nargs="+", default=list(TIMES))
    ap.add_argument("--curved", action="store_true", help="necks cut on the curved cells (rayleigh_p2 runs)")
    ap.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = ap.parse_args(argv)
    logging.getLogger("cortex_ti").setLevel(logging.ERROR)
    if args.smoke:
        where = _bench.folder()
        sets = ["mesh.remesh.min_angle=null", "time.save_every=0.05"]
        args.files = [_bench.tiny_run(args.scene, 0.05, n, where, sets, name=f"n{n}") for n in (162, 642)]
        args.times = [0.05]
    if len(args.files) < (1 if args.curved else 2):
        ap.error("give trajectories at two or more node counts (one with --curved)")
    from _bench import twin  # the axisymmetric twin of the same ring

    runs = [necks(f, args.curved) for f in args.files]
    t_end = max(float(r[1][-1]) for r in runs)
    where = _bench.folder()
    tw = twin(args.amplitude, t_end, where, args.scene)
    tw["neck"] = tw["furrow"]  # the symmetric ring's neck is its equator's radius
    print(f"# {args.scene}, amplitude {args.amplitude:g}: the neck against the axisymmetric twin\n")
    print("Files: " + ", ".join(f"`{f}` (to t = {r[1][-1]:.3g})" for f, r in zip(args.files, runs, strict=True)))
    print(f"\nThe twin stopped: {tw['stopped']}; its label map is resolved to t = {tw['resolved_until']:.3g}.\n")
    print("\n".join(table(runs, tw, args.times)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
