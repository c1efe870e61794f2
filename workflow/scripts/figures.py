"""Draw one registered figure (rule figure) or table (rule table); save every format atomically."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

import xarray as xr  # noqa: E402

from cortex_ti.io.files import atomic_path  # noqa: E402
from cortex_ti.studies import figures  # noqa: E402
from cortex_ti.studies.numbers import figure_numbers, numbers_html  # noqa: E402
from cortex_ti.viz.plotting import save_figure  # noqa: E402

sm = snakemake  # noqa: F821
if sm.rule == "table":
    out, tmp = atomic_path(sm.output[0])
    tmp.write_text(figures.cost_table_html(xr.load_dataset(sm.input[0], engine="h5netcdf")))
    tmp.replace(out)
else:
    name, data = sm.wildcards.name, list(sm.input.data)
    fig = figures.draw_figure(name, data, sm.params.options, sm.params.rows)
    for path in sm.output.figures:
        save_figure(fig, path)
    numbers, cost = figure_numbers(
        name, data, sm.params.options, sm.params.rows, xr.load_dataset(sm.input.cost, engine="h5netcdf")
    )
    out, tmp = atomic_path(sm.output.numbers)
    tmp.write_text(numbers_html(name, numbers, cost))
    tmp.replace(out)
