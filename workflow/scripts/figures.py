"""Draw one figure (the rule's name says which) from its store or trajectories; save every format."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import os  # noqa: E402
from pathlib import Path  # noqa: E402

import xarray as xr  # noqa: E402

from cortex_ti import figures  # noqa: E402
from cortex_ti.aggregate import short_labels  # noqa: E402
from cortex_ti.plotting import save_figure  # noqa: E402

sm = snakemake  # noqa: F821
name = sm.rule.removeprefix("figure_")


def store():
    return xr.load_dataset(sm.input[0], engine="h5netcdf")


def labelled(rows):
    return list(zip(short_labels(rows), sm.input))


if name == "cost_table":
    out = Path(sm.output[0])
    tmp = out.with_name(out.name + ".partial")
    tmp.write_text(figures.cost_table_html(store()))
    os.replace(tmp, out)
    sys.exit(0)

draw = {
    "convergence": lambda: figures.convergence_figure(store()),
    "furrow_radii": lambda: figures.radii_figure(store()),
    "velocity_profiles": lambda: figures.profiles_figure(list(zip(sm.params.rows, sm.input)), sm.params.times),
    "fold_depth": lambda: figures.fold_figure(store()),
    "snapshots_fold": lambda: figures.snapshots_figure(labelled(sm.params.rows), sm.params.times),
    "orientation": lambda: figures.orientation_figure(store()),
    "snapshots_reorientation": lambda: figures.snapshots_figure(labelled(sm.params.rows), sm.params.times),
    "accuracy_cost": lambda: figures.accuracy_cost_figure(store()),
}[name]
fig = draw()
for path in sm.output:
    save_figure(fig, path)
