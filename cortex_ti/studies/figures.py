"""The workflow's figures, drawn from the aggregate stores (matplotlib, no pyplot state).

Each function returns a :class:`matplotlib.figure.Figure`; the workflow saves it with
:func:`cortex_ti.viz.plotting.save_figure` (atomic, format from the suffix). The caption of
each figure (what it shows, which paper figure it matches) is in ``workflow/report/``.

The drawing functions live in the modules of their studies (``figures_shapes``, ``figures_cost``,
``figures_pictures``, ``figures_myosin``, ``constriction``, ``fluids``); this module imports each by name, so
that :func:`draw_figure` finds the function a figure of the registry names, and they stay
importable from here.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import xarray as xr
from matplotlib.figure import Figure

from .constriction import constriction_figure  # noqa: F401  (issue 18's figure, drawn by name)
from .cytokinesis import cytokinesis_figure  # noqa: F401  (issue 35's figure, drawn by name)
from .figures_cost import accuracy_cost_figure, cost_table_html, pareto_front
from .figures_myosin import myosin_onset_figure, myosin_rates_figure, myosin_ring_figure
from .figures_pictures import snapshots_figure, sphere_flows_figure
from .figures_shapes import (
    convergence_figure,
    fold_figure,
    orientation_figure,
    profiles_figure,
    radii_figure,
    reference_check_figure,
)
from .fluids import fluids_figure  # noqa: F401  (issue 36's figure, drawn by name)
from .registry import FIGURES

__all__ = [
    "convergence_figure",
    "radii_figure",
    "profiles_figure",
    "orientation_figure",
    "fold_figure",
    "accuracy_cost_figure",
    "pareto_front",
    "snapshots_figure",
    "cost_table_html",
    "draw_figure",
    "myosin_rates_figure",
    "myosin_onset_figure",
    "myosin_ring_figure",
    "reference_check_figure",
    "sphere_flows_figure",
]


def draw_figure(name: str, inputs: Sequence, options: Mapping, rows: Mapping[str, Sequence[Mapping]] = {}) -> Figure:
    """Draw the registered figure ``name`` (:data:`cortex_ti.studies.registry.FIGURES`).

    ``inputs``: its stores (one path each, in the order of ``spec.data``) or its studies'
    trajectories (in the order of ``rows``, the studies' sweep tables); ``options``: the config's
    ``figures`` section."""
    spec = FIGURES[name]
    draw = globals()[spec.draw]
    extra = [options[k] for k in spec.options]
    if spec.source == "store":
        return draw(*[xr.load_dataset(path, engine="h5netcdf") for path in inputs], *extra)
    if spec.source == "static":
        return draw(list(inputs), *extra)
    runs, start = {}, 0
    for study in spec.data:
        runs[study] = list(zip(rows[study], inputs[start : start + len(rows[study])], strict=True))
        start += len(rows[study])
    if spec.draw == "profiles_figure":
        return draw(runs[spec.data[0]], *extra, *(runs[s] for s in spec.data[1:]))
    from .stores import short_labels

    main = runs[spec.data[0]]
    return draw(list(zip(short_labels([r for r, _ in main]), [p for _, p in main], strict=True)), *extra)
