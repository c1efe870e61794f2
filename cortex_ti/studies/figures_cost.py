"""The workflow's figures of accuracy against cost: the Pareto front of the schemes and
formulations, its figure and table, and the cost store as an HTML table for the report (drawn by
name through :func:`cortex_ti.studies.figures.draw_figure`).
"""

from __future__ import annotations

import re

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from ..dynamics.schemes import SCHEMES
from .constriction import constriction_figure  # noqa: F401  (issue 18's figure, drawn by name)
from .figures_shapes import registry_markers


def pareto_front(cost: np.ndarray, error: np.ndarray) -> np.ndarray:
    """Indices of the points no other point beats in both cost and error, by increasing cost.

    >>> pareto_front([1.0, 2.0, 3.0, 4.0], [5.0, 6.0, 1.0, 0.5]).tolist()
    [0, 2, 3]"""
    cost, error = np.asarray(cost, float), np.asarray(error, float)
    ok = np.flatnonzero(np.isfinite(cost) & np.isfinite(error))
    front, best = [], np.inf
    for i in ok[np.lexsort((error[ok], cost[ok]))]:
        if error[i] < best:
            front.append(i)
            best = error[i]
    return np.asarray(front, dtype=int)


def accuracy_cost_figure(ds: xr.Dataset) -> Figure:
    """What accuracy costs: the error of the radii against the axisymmetric solution of the same
    scene versus the wall time of the run, one panel per formulation, one point per run of the
    accuracy study (colour: N, marker: time scheme, filled: semi-implicit tension); the Pareto
    front over all runs as a dashed line in every panel and, beside the plot, a table of the runs
    on it; runs that failed are crosses along the top; the axisymmetric solution's own wall time
    as a vertical line."""
    study = ds["study"].values
    sel = ds.isel(run=np.flatnonzero(study == "accuracy")) if "accuracy" in set(study) else ds
    forms = sorted(set(sel["formulation"].values.astype(str)), key=lambda f: (f != "rayleigh_p1", f)) or ["-"]
    fig = Figure(figsize=(5.2 * len(forms) + 5.5, 4.8), layout="constrained")
    axes = fig.subplots(1, len(forms) + 1, width_ratios=[1.0] * len(forms) + [1.1])
    panels, tab = axes[:-1], axes[-1]
    wall, err = sel["wall_s"].values, sel["error"].values
    ok = np.asarray(sel["status"].values == "ok") & np.isfinite(err)
    markers = registry_markers(SCHEMES)
    implicit = sel["implicit_tension"].values.astype(bool)
    nodes = sel["nodes"].values.astype(int)
    form_of = sel["formulation"].values.astype(str)
    colours = {n: f"C{i}" for i, n in enumerate(sorted(set(nodes)))}
    front = pareto_front(np.where(ok, wall, np.nan), np.where(ok, err, np.nan))
    top = np.nanmax(err[ok]) * 2.5 if ok.any() else 1.0
    twin_wall = ds["wall_s"].values[(study == "axisymmetric")] if "axisymmetric" in set(study) else []
    handles = []
    for ax, form in zip(panels, forms, strict=True):
        mine = form_of == form
        for i in np.flatnonzero(ok & mine):
            c = colours[nodes[i]]
            ax.loglog(
                wall[i],
                err[i],
                markers.get(str(sel["scheme"].values[i]), "x"),
                ms=7,
                color=c,
                mfc=c if implicit[i] else "none",
                zorder=3,
            )
        if front.size:
            (h,) = ax.loglog(wall[front], err[front], "k--", lw=1.2, zorder=2, label="Pareto front (all runs)")
        failed = np.flatnonzero(~ok & mine)
        if failed.size:
            ax.loglog(wall[failed], np.full(failed.size, top), "rx", ms=8, label=f"failed ({failed.size})")
        if len(twin_wall):
            v = ax.axvline(
                float(np.nanmax(twin_wall)),
                color="0.3",
                lw=1,
                ls=":",
                label=f"axisymmetric solution (the truth): {np.nanmax(twin_wall):.1f} s",
            )
        ax.set_title(f"formulation {form}", fontsize=9)
        ax.set_xlabel("wall time of the run (s, one job, start-up included)")
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    if front.size:
        handles.append(h)
    if len(twin_wall):
        handles.append(v)
    if (~ok).any():
        handles.append(panels[0].plot([], [], "rx", ms=8, label="failed (see the cost table)")[0])
    handles += [panels[0].plot([], [], "s", color=c, label=f"N = {n}")[0] for n, c in colours.items()]
    handles += [
        panels[0].plot([], [], m, color="0.4", mfc="none", label=name)[0]
        for name, m in markers.items()
        if name in set(sel["scheme"].values)
    ]
    handles.append(panels[0].plot([], [], "o", color="0.4", label="filled: semi-implicit tension")[0])
    panels[0].set_ylabel(r"max |radius - axisymmetric| / $R_0$")
    _common_limits(
        panels, np.r_[wall[np.isfinite(wall)], list(twin_wall)], np.r_[err[ok], [top] if (~ok).any() else []]
    )
    found = map(re.compile(r"scene~([^/]+)").search, sel["run"].values.astype(str))
    scenes = ", ".join(sorted({m.group(1) for m in found if m}))
    fig.suptitle(f"accuracy study ({scenes}) against the axisymmetric solution", fontsize=10)
    _pareto_table(tab, sel, front)
    tab.legend(handles=handles, fontsize=7, loc="lower center", ncol=2, frameon=False)
    return fig


def _common_limits(panels, xs: np.ndarray, ys: np.ndarray) -> None:
    """The same log axes in every panel, wide enough for every point (and a factor 1.5 around)."""
    xs, ys = xs[np.isfinite(xs) & (xs > 0)], ys[np.isfinite(ys) & (ys > 0)]
    if xs.size and ys.size:
        for ax in panels:
            ax.set_xlim(xs.min() / 1.5, xs.max() * 1.5)
            ax.set_ylim(ys.min() / 1.5, ys.max() * 1.5)


def _pareto_table(ax, sel: xr.Dataset, front: np.ndarray) -> None:
    """The runs on the Pareto front as a table: what each costs and what it gets."""
    ax.axis("off")
    rows = [
        [
            str(sel["formulation"].values[i]),
            str(int(sel["nodes"].values[i])),
            str(sel["scheme"].values[i]),
            "semi-impl." if bool(sel["implicit_tension"].values[i]) else "explicit",
            f"{sel['dt'].values[i]:g}" if str(sel["scheme"].values[i]) != "bdf2" else f"tol {sel['tol'].values[i]:g}",
            f"{sel['wall_s'].values[i]:.0f}",
            f"{sel['error'].values[i]:.1e}",
        ]
        for i in front
    ]
    if not rows:
        ax.text(0.5, 0.5, "no run finished", ha="center", va="center")
        return
    table = ax.table(
        cellText=rows,
        colLabels=["formulation", "N", "scheme", "tension", "dt / tol", "wall (s)", "error (R0)"],
        loc="upper center",
        cellLoc="center",
    )
    table.auto_set_font_size(False)
    table.set_fontsize(7)
    table.auto_set_column_width(list(range(len(rows[0]))))
    table.scale(1.0, 1.3)
    ax.set_title("the Pareto front: nothing is both cheaper and more accurate", fontsize=9)


def cost_table_html(ds: xr.Dataset) -> str:
    """The cost store as an HTML table (for the report), through pandas."""
    cols = [
        "study",
        "status",
        "nodes",
        "fit",
        "scheme",
        "dt",
        "wall_s",
        "max_rss_mb",
        "steps",
        "solves",
        "ms_per_step",
        "ms_geometry_per_solve",
        "ms_assembly_per_solve",
        "ms_solve_per_solve",
        "error",
    ]
    table = ds.reset_coords()[cols].to_dataframe()
    table.columns = [f"{c} [{ds[c].attrs['units']}]" if ds[c].attrs.get("units") else c for c in cols]
    body = table.to_html(float_format=lambda x: f"{x:.3g}", na_rep="", border=0)
    return (
        "<html><head><meta charset='utf-8'><style>td,th{padding:2px 6px;font:12px sans-serif;"
        f"border-bottom:1px solid #ddd}}</style></head><body><p>{ds.attrs.get('description', '')}</p>"
        f"{body}</body></html>"
    )
