"""The pictures of the non-axisymmetric scenes (paper Figs. 9-12) from finished runs, for
docs/validation/nonaxisymmetric.md.

Usage (each trajectory from ``cortex-ti run <scene> -o <scene>.h5``, 2562 nodes, t_end = 3.5)::

    python benchmarks/readme_figures.py --runs RUNS_DIR --out docs/figures

expects ``fold_narrow.h5, fold_broad.h5, shear_035.h5, shear_035_tilted.h5, shear_075.h5`` in
RUNS_DIR (missing ones are skipped; ``<name>.h5.partial`` of a stopped run is used if that is all there is) and
writes ``fold.png``, ``shear.png`` (snapshots at the
paper's times) and ``orientation.png`` (orientation angle and fold depth over time), using the
workflow's own figure functions. Prints the numbers quoted on that page.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import _bench  # benchmarks/_bench.py: the helpers every benchmark shares
import numpy as np

from cortex_ti.studies.figures import fold_figure, orientation_figure, snapshots_figure
from cortex_ti.studies.stores import study_dataset
from cortex_ti.studies.sweeps import expand_runs
from cortex_ti.viz.plotting import save_figure

FOLD = ("fold_narrow", "fold_broad")
SHEAR = ("shear_035", "shear_035_tilted", "shear_075")
TIMES = (0.0035, 0.035, 0.087, 3.5)  # paper Figs. 10-12 B-E


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--runs", type=Path, default=None, help="folder of the runs (required)")
    p.add_argument("--out", type=Path, default=Path("docs/figures"))
    p.add_argument("--smoke", action="store_true", help=_bench.HELP)
    args = p.parse_args(argv)
    if args.smoke:  # one fold and one shear scene, tiny, to t = 0.04 (past two of the snapshot times)
        args.runs = args.out = _bench.folder()
        for name in ("fold_narrow", "shear_035"):
            _bench.tiny_run(name, t_end=0.04, where=args.runs)
    if args.runs is None:
        p.error("--runs is required")
    args.out.mkdir(parents=True, exist_ok=True)
    for study, names, fig_name in (("fold", FOLD, "fold"), ("reorientation", SHEAR, "shear")):
        # a finished run, else the frames of an interrupted one (<name>.h5.partial)
        paths = {
            n: next((f for f in (args.runs / f"{n}.h5", args.runs / f"{n}.h5.partial") if f.exists()), None)
            for n in names
        }
        found = [n for n in names if paths[n] is not None]
        if not found:
            continue
        paths = [paths[n] for n in found]
        times = (0.1, 0.5, 3.5) if study == "fold" else TIMES
        save_figure(snapshots_figure(list(zip(found, paths, strict=False)), times), args.out / f"{fig_name}.png")
        rows = expand_runs(study, [{"scene": n} for n in found])
        ds = study_dataset(study, rows, paths)
        draw = fold_figure if study == "fold" else orientation_figure
        save_figure(draw(ds), args.out / f"{fig_name}_series.png")
        for i, name in enumerate(found):
            t = ds["time"].values
            if study == "fold":
                d = ds["fold_depth"].values[i]
                ok = np.isfinite(d)
                print(
                    f"{name}: fold depth "
                    + ", ".join(f"{d[np.argmin(abs(t - s))]:.3f} (t = {s})" for s in (0.1, 0.5, 1.0, t[ok][-1])),
                    f"| across {ds['radius_stripe'].values[i][ok][-1]:.3f}, beside "
                    f"{ds['radius_off_stripe'].values[i][ok][-1]:.3f}"
                    f", pole {ds['pole_radius'].values[i][ok][-1]:.3f}, volume change "
                    f"{ds['volume_change'].values[i][ok][-1]:.1e}",
                )
            else:
                a = ds["orientation_angle"].values[i]
                ok = np.isfinite(a)
                print(
                    f"{name}: orientation "
                    + ", ".join(f"{a[np.argmin(abs(t - s))]:.1f} (t = {s})" for s in (0.0, 0.09, 0.5, 1.0, t[ok][-1])),
                    f"| pole/furrow along long axis {ds['pole_radius_long_axis'].values[i][ok][-1]:.3f}/"
                    f"{ds['furrow_radius_long_axis'].values[i][ok][-1]:.3f}, volume change "
                    f"{ds['volume_change'].values[i][ok][-1]:.1e}",
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
