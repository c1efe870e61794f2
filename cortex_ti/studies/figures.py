"""The workflow's figures, drawn from the aggregate stores (matplotlib, no pyplot state).

Each function returns a :class:`matplotlib.figure.Figure`; the workflow saves it with
:func:`cortex_ti.plotting.save_figure` (atomic, format from the suffix). The caption of
each figure (what it shows, which paper figure it matches) is in ``workflow/report/``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from ..analysis import reference
from ..dynamics.schemes import SCHEMES
from ..io.trajectory import Trajectory, open_trajectory
from ..surface.fits import FIT_SCHEMES
from .registry import FIGURES

__all__ = ["convergence_figure", "radii_figure", "profiles_figure", "orientation_figure", "fold_figure",
           "accuracy_cost_figure", "pareto_front", "snapshots_figure", "cost_table_html", "draw_figure"]


_MARKERS = "os^Dvp<>h*"


def _markers(registry) -> dict[str, str]:
    """One marker per registered name (fit schemes, time schemes), in registry order."""
    return {name: _MARKERS[i % len(_MARKERS)] for i, name in enumerate(registry)}


def convergence_figure(ds: xr.Dataset) -> Figure:
    """Relative velocity error against N for the sphere scenes (paper Figs. 2F,G and 3F,G)."""
    fig = Figure(figsize=(9, 3.8), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    systems = {"full": axes[0], "tangential": axes[1]}
    markers = _markers(FIT_SCHEMES)
    for scene in ds["scene"].values:
        ax = systems["tangential" if "tangential" in str(scene) else "full"]
        for fit in ds["fit"].values:
            e = ds["eps_rel"].sel(scene=scene, fit=fit)
            ok = np.isfinite(e.values)
            ax.loglog(ds["nodes"].values[ok], e.values[ok], marker=markers.get(str(fit), "^"),
                      label=f"{str(scene).split('_')[1].upper()} {fit}")
    n = ds["nodes"].values.astype(float)
    for ax, title in zip(axes, ("(i) full force balance", "(ii) tangential only")):
        for power, style in ((1, ":"), (2, "--")):
            ref = ds["eps_rel"].max().item() * (n / n[0]) ** (-power)
            ax.loglog(n, ref, "k" + style, lw=0.8, label=f"$\\propto N^{{-{power}}}$")
        ax.set_xticks(n, [str(int(v)) for v in n])
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("nodes N")
        ax.set_title(title)
        ax.legend(fontsize=7)
    axes[0].set_ylabel(r"$\epsilon_\mathrm{rel}$ (Eq. 58)")
    return fig


def _groups(ds: xr.Dataset, keys: Sequence[str]) -> dict[tuple, list[int]]:
    out: dict[tuple, list[int]] = {}
    for i in range(ds.sizes["run"]):
        out.setdefault(tuple(ds[k].values[i] for k in keys if k in ds.coords), []).append(i)
    return out


def radii_figure(ds: xr.Dataset) -> Figure:
    """Pole and furrow radius against time, one panel per (p, zeta_hat); the axisymmetric
    reference as lines where the run is its problem (paper Figs. 5A, 7A, 8A)."""
    groups = _groups(ds, ("p", "zeta_hat"))
    fig = Figure(figsize=(4.2 * len(groups), 3.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(groups), squeeze=False)[0])
    ref = reference.load_radii()
    for ax, ((p, zh), idx) in zip(axes, groups.items()):
        for i in idx:
            lab = f"N={ds['nodes'].values[i]}, {ds['scheme'].values[i]}, dt={ds['dt'].values[i]}"
            t = ds["time"].values
            ok = np.isfinite(ds["pole_radius"].values[i])
            every = max(1, ok.sum() // 40)
            ax.plot(t[ok][::every], ds["pole_radius"].values[i][ok][::every], "o", ms=3, label=f"pole, {lab}")
            ax.plot(t[ok][::every], ds["furrow_radius"].values[i][ok][::every], "s", ms=3, label=f"furrow, {lab}")
        if float(p) == 8 and float(zh) == 1:
            tmax = np.nanmax(np.where(np.isfinite(ds["pole_radius"].values[idx]), ds["time"].values, np.nan))
            keep = ref["t"] <= tmax + 1e-9
            ax.plot(ref["t"][keep], ref["pole_radius"][keep], "k-", lw=1, label="axisymmetric reference")
            ax.plot(ref["t"][keep], ref["furrow_radius"][keep], "k-", lw=1)
        ax.set_title(f"p = {p}, $\\hat\\zeta$ = {zh}")
        ax.set_xlabel(r"$t / t_a$")
        ax.legend(fontsize=6)
    axes[0].set_ylabel(r"radius / $R_0$")
    return fig


def _profiles(path, times: Sequence[float]) -> tuple[float, bool, dict]:
    """One pass over a trajectory: its last time, whether it is the reference's problem, and per
    requested time up to its end ``(z, |v_t|, v_n, frame time)`` at the nearest frame, with the
    solver's normals (:meth:`cortex_ti.io.trajectory.Trajectory.normals`: the normal of the fitted
    surface; area-weighted vertex normals are off by O(h), which at 2562 nodes mixes ~1 % of v_n
    into v_t, visible where v_t is small, at t = 0)."""
    out = {}
    with Trajectory(path, lazy=True) as tr:
        tt = tr.times
        has_ref = reference.matches_reference(tr.settings)
        for t in times:
            if t > tt[-1] + 1e-9:
                continue
            k = tr.frame_at(t)
            pts = tr.ds["points"].isel(time=k).values
            vel = tr.ds["velocity"].isel(time=k).values
            normals = tr.normals(k)
            vn = np.einsum("nc,nc->n", vel, normals)
            vt = np.linalg.norm(vel - vn[:, None] * normals, axis=1)
            out[t] = (pts[:, 2], vt, vn, float(tt[k]))
    return float(tt[-1]), has_ref, out


def profiles_figure(runs: Sequence[tuple[Mapping, str]], times: Sequence[float]) -> Figure:
    """|v_t| and v_n against z at the given times (paper Figs. 5B-G, 7B-G, 8B-G), one column
    pair per run; the reference profile as a line where the run is its problem. Times beyond a
    run's end are left empty."""
    times = [float(t) for t in times]
    fig = Figure(figsize=(4.0 * len(runs), 2.2 * len(times) + 0.6), layout="constrained")
    axes = fig.subplots(len(times), 2 * len(runs), squeeze=False)
    for j, (row, path) in enumerate(runs):
        t_last, has_ref, profiles = _profiles(path, times)
        for i, t in enumerate(times):
            ax_t, ax_n = axes[i, 2 * j], axes[i, 2 * j + 1]
            if t not in profiles:
                for ax in (ax_t, ax_n):
                    ax.text(0.5, 0.5, f"run ends at t = {t_last:g}", ha="center", va="center", transform=ax.transAxes,
                            fontsize=8, color="0.4")
                    ax.set_xticks([])
                    ax.set_yticks([])
                continue
            z, vt, vn, tk = profiles[t]
            ax_t.plot(z, vt, ".", ms=2, label="3D nodes")
            ax_n.plot(z, vn, ".", ms=2, label="3D nodes")
            if has_ref and any(abs(t - tp) < 1e-9 for tp in reference.PROFILE_TIMES):
                prof = reference.load_profile(t)
                ax_t.plot(prof["z"], prof["abs_vt"], "k-", lw=1, label="axisymmetric")
                ax_n.plot(prof["z"], prof["vn"], "k-", lw=1, label="axisymmetric")
            ax_t.set_ylabel(f"t = {tk:g}\n" + r"$|v_t| / v_a$")
            ax_n.set_ylabel(r"$v_n / v_a$")
            if i == 0:
                ax_t.set_title(f"p = {row.get('p')}, $\\hat\\zeta$ = {row.get('zeta_hat')}: tangential", fontsize=9)
                ax_n.set_title("normal", fontsize=9)
                ax_t.legend(fontsize=6)
            if i == len(times) - 1:
                ax_t.set_xlabel(r"$z / R_0$")
                ax_n.set_xlabel(r"$z / R_0$")
    return fig


def orientation_figure(ds: xr.Dataset) -> Figure:
    """Orientation angle (long axis vs pattern axis) and the radii along the long axis against
    time, one line per (gamma, tilt) run (paper Figs. 10-12, quantified)."""
    fig = Figure(figsize=(10, 3.6), layout="constrained")
    a0, a1 = fig.subplots(1, 2)
    t = ds["time"].values
    for i in range(ds.sizes["run"]):
        lab = f"$\\gamma$ = {ds['gamma'].values[i]}, tilt {ds['tilt'].values[i]}°, N={ds['nodes'].values[i]}"
        line, = a0.plot(t, ds["orientation_angle"].values[i], label=lab)
        a1.plot(t, ds["pole_radius_long_axis"].values[i], "-", color=line.get_color(), label=f"pole, {lab}")
        a1.plot(t, ds["furrow_radius_long_axis"].values[i], "--", color=line.get_color(), label="furrow")
    a0.set_xlabel(r"$t / t_a$")
    a0.set_ylabel("orientation angle (degrees)")
    a0.set_ylim(bottom=0)
    a0.legend(fontsize=7)
    a1.set_xlabel(r"$t / t_a$")
    a1.set_ylabel(r"radius along the long axis / $R_0$")
    a1.legend(fontsize=6)
    return fig


def fold_figure(ds: xr.Dataset) -> Figure:
    """Equatorial radii across and beside the stripe, and the fold depth, against time (Fig. 9)."""
    fig = Figure(figsize=(10, 3.6), layout="constrained")
    a0, a1 = fig.subplots(1, 2)
    t = ds["time"].values
    for i in range(ds.sizes["run"]):
        lab = f"{ds['scene'].values[i]} ($\\hat\\zeta$ = {ds['zeta_hat'].values[i]}, N={ds['nodes'].values[i]})"
        line, = a0.plot(t, ds["radius_stripe"].values[i], "-", label=f"across stripe, {lab}")
        a0.plot(t, ds["radius_off_stripe"].values[i], "--", color=line.get_color(), label="beside stripe")
        a1.plot(t, ds["fold_depth"].values[i], color=line.get_color(), label=lab)
    a0.set_xlabel(r"$t / t_a$")
    a0.set_ylabel(r"equatorial radius / $R_0$")
    a0.legend(fontsize=6)
    a1.set_xlabel(r"$t / t_a$")
    a1.set_ylabel(r"fold depth / $R_0$")
    a1.legend(fontsize=7)
    return fig


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
    """Error of the radii against the axisymmetric reference versus wall time, one point per
    (N, fit, scheme, implicit tension, dt; colour: N, marker: scheme, filled: semi-implicit tension),
    the Pareto front joined; runs that failed (unstable) are marked at the top."""
    sel = ds.where(ds["study"] == "accuracy", drop=True) if "accuracy" in set(ds["study"].values) else ds
    fig = Figure(figsize=(6.4, 4.4), layout="constrained")
    ax = fig.subplots()
    wall, err = sel["wall_s"].values, sel["error"].values
    ok = np.asarray(sel["status"].values == "ok") & np.isfinite(err)
    markers = _markers(SCHEMES)
    implicit = (sel["implicit_tension"].values.astype(bool) if "implicit_tension" in sel.coords
                else np.zeros(sel.sizes["run"], dtype=bool))
    node_counts = sorted({int(v) for v in sel["nodes"].values})
    rows = (sel["fit_residual_weight"].values if "fit_residual_weight" in sel.coords
            else np.zeros(sel.sizes["run"]))
    extra = [(" impl." if implicit[i] else "") + (f" rows {rows[i]:g}" if rows[i] > 0 else "")
             for i in range(sel.sizes["run"])]
    for i in np.flatnonzero(ok):
        color = f"C{node_counts.index(int(sel['nodes'].values[i])) % 10}"
        ax.loglog(wall[i], err[i], markers.get(str(sel["scheme"].values[i]), "x"), ms=7, color=color,
                  mfc=color if implicit[i] else "none")
        ax.annotate(f"N={int(sel['nodes'].values[i])} {sel['scheme'].values[i]}{extra[i]} "
                    f"{sel['fit'].values[i][:4]} dt={sel['dt'].values[i]:g}", (wall[i], err[i]), fontsize=6,
                    xytext=(4, 2), textcoords="offset points")
    front = pareto_front(np.where(ok, wall, np.nan), np.where(ok, err, np.nan))
    if front.size:
        ax.loglog(wall[front], err[front], "k-", lw=1, label="Pareto front")
    top = np.nanmax(err[ok]) * 2 if ok.any() else 1.0
    for k, i in enumerate(np.flatnonzero(~ok)):
        ax.loglog(wall[i], top, "rx", ms=8)
        ax.annotate(f"failed: N={int(sel['nodes'].values[i])} {sel['scheme'].values[i]}{extra[i]} "
                    f"dt={sel['dt'].values[i]:g}",
                    (wall[i], top), fontsize=6, color="r", xytext=(4, -8 - 8 * k), textcoords="offset points")
    for s, m in markers.items():
        ax.plot([], [], m, color="0.4", label=s)
    ax.plot([], [], "o", color="0.4", label="filled: semi-implicit tension")
    ax.plot([], [], "o", color="0.4", mfc="none", label="open: explicit")
    ax.set_xlabel("wall time of the run (s)")
    ax.set_ylabel(r"max |radius - reference| / $R_0$")
    ax.set_title("furrow p = 8, $\\hat\\zeta$ = 1 against the axisymmetric reference", fontsize=9)
    ax.legend(fontsize=7)
    return fig


def snapshots_figure(runs: Sequence[tuple[str, str]], times: Sequence[float], view=(20.0, -60.0)) -> Figure:
    """3D snapshots (paper Figs. 9-12): per run a row, the active stress at t = 0 and then |v|
    with arrows at each time of ``times`` up to the run's end (and at its end)."""
    from ..plotting import plot_frame

    rows = []
    for label, path in runs:
        with open_trajectory(path) as ds:
            tt = ds["time"].values
            pick = sorted({int(np.argmin(np.abs(tt - t))) for t in times if t <= tt[-1] + 1e-9} | {len(tt) - 1})
        rows.append((label, path, pick))
    ncol = 1 + max(len(p) for _, _, p in rows)
    fig = Figure(figsize=(2.6 * ncol, 2.7 * len(rows)), layout="constrained")
    for r, (label, path, pick) in enumerate(rows):
        with open_trajectory(path) as ds:
            ax = fig.add_subplot(len(rows), ncol, r * ncol + 1, projection="3d")
            _, m = plot_frame(ds, frame=0, color="active_stress", arrows=False, ax=ax, view=view)
            fig.colorbar(m, ax=ax, shrink=0.6, label=r"$\zeta / \zeta_0$")
            ax.set_title(f"{label}\nactive stress", fontsize=7)
            for c, k in enumerate(pick):
                ax = fig.add_subplot(len(rows), ncol, r * ncol + 2 + c, projection="3d")
                _, m = plot_frame(ds, frame=k, color="speed", arrows=True, ax=ax, view=view)
                fig.colorbar(m, ax=ax, shrink=0.6, label=r"$|v| / v_a$")
                ax.set_title(f"t = {float(ds['time'].values[k]):.4g} $t_a$", fontsize=8)
    for ax in fig.axes:
        ax.tick_params(labelsize=6)
    return fig


def cost_table_html(ds: xr.Dataset) -> str:
    """The cost store as an HTML table (for the report), through pandas."""
    cols = ["study", "status", "nodes", "fit", "scheme", "dt", "wall_s", "max_rss_mb", "steps", "solves", "ms_per_step",
            "ms_geometry_per_solve", "ms_assembly_per_solve", "ms_solve_per_solve", "error"]
    table = ds.reset_coords()[cols].to_dataframe()
    table.columns = [f"{c} [{ds[c].attrs['units']}]" if ds[c].attrs.get("units") else c for c in cols]
    body = table.to_html(float_format=lambda x: f"{x:.3g}", na_rep="", border=0)
    return ("<html><head><meta charset='utf-8'><style>td,th{padding:2px 6px;font:12px sans-serif;"
            f"border-bottom:1px solid #ddd}}</style></head><body><p>{ds.attrs.get('description', '')}</p>"
            f"{body}</body></html>")


def draw_figure(name: str, inputs: Sequence, options: Mapping, rows: Sequence[Mapping] = ()) -> Figure:
    """Draw the registered figure ``name`` (:data:`cortex_ti.studies.registry.FIGURES`).

    ``inputs``: its store (one path) or its study's trajectories (one per row of ``rows``, the
    study's sweep table); ``options``: the config's ``figures`` section."""
    spec = FIGURES[name]
    draw = globals()[spec.draw]
    extra = [options[k] for k in spec.options]
    if spec.source == "store":
        return draw(xr.load_dataset(inputs[0], engine="h5netcdf"), *extra)
    if spec.draw == "profiles_figure":
        return draw(list(zip(rows, inputs)), *extra)
    from .stores import short_labels

    return draw(list(zip(short_labels(rows), inputs)), *extra)
