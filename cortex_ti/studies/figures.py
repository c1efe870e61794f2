"""The workflow's figures, drawn from the aggregate stores (matplotlib, no pyplot state).

Each function returns a :class:`matplotlib.figure.Figure`; the workflow saves it with
:func:`cortex_ti.viz.plotting.save_figure` (atomic, format from the suffix). The caption of
each figure (what it shows, which paper figure it matches) is in ``workflow/report/``.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from ..analysis import reference
from ..dynamics.schemes import SCHEMES
from ..io.trajectory import Trajectory, open_trajectory
from ..physics.formulations import FORMULATIONS
from ..surface.fits import FIT_SCHEMES
from .constriction import constriction_figure  # noqa: F401  (issue 18's figure, drawn by name)
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
]


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
    styles = {name: ("-", "--", "-.", ":")[i % 4] for i, name in enumerate(FORMULATIONS)}
    colours: dict[str, str] = {}
    for scene in ds["scene"].values:
        ax = systems["tangential" if "tangential" in str(scene) else "full"]
        harmonic = str(scene).split("_")[1].upper()
        for form in ds["formulation"].values:
            for fit in ds["fit"].values:
                e = ds["eps_rel"].sel(scene=scene, formulation=form, fit=fit)
                ok = np.isfinite(e.values)
                if not ok.any():
                    continue
                colour = colours.setdefault(harmonic, f"C{len(colours)}")
                ax.loglog(
                    ds["nodes"].values[ok],
                    e.values[ok],
                    styles.get(str(form), "-"),
                    color=colour,
                    marker=markers.get(str(fit), "^"),
                    mfc=colour if form == "paper" else "none",
                    label=f"{harmonic} {form} {fit}",
                )
    n = ds["nodes"].values.astype(float)
    for ax, title in zip(axes, ("(i) full force balance", "(ii) tangential only"), strict=True):
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


def _twin_index(axisym: xr.Dataset | None) -> dict[tuple, int]:
    """Run index of each axisymmetric twin in its store, by (scene, zeta_hat, p)."""
    if axisym is None:
        return {}
    return {
        (str(axisym["scene"].values[i]), float(axisym["zeta_hat"].values[i]), float(axisym["p"].values[i])): i
        for i in range(axisym.sizes["run"])
    }


def radii_figure(ds: xr.Dataset, axisym: xr.Dataset | None = None) -> Figure:
    """Pole and furrow radius against time, one panel per furrow problem (scene, p, zeta_hat):
    the 3D runs as dots, the axisymmetric solution of the same scene (its twin, with the scene's
    own bending viscosity) as black lines (paper Figs. 5A, 7A, 8A)."""
    groups = _groups(ds, ("scene", "p", "zeta_hat"))
    twins = _twin_index(axisym)
    fig = Figure(figsize=(4.2 * len(groups), 3.8), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(groups), squeeze=False)[0])
    t = ds["time"].values
    for ax, ((scene, p, zh), idx) in zip(axes, groups.items(), strict=True):
        for i in idx:
            lab = f"3D N={ds['nodes'].values[i]}, {ds['scheme'].values[i]}"
            ok = np.isfinite(ds["pole_radius"].values[i])
            every = max(1, ok.sum() // 40)
            ax.plot(t[ok][::every], ds["pole_radius"].values[i][ok][::every], "o", ms=3, label=f"pole, {lab}")
            ax.plot(t[ok][::every], ds["furrow_radius"].values[i][ok][::every], "s", ms=3, label=f"furrow, {lab}")
        j = twins.get((str(scene), float(zh), float(p)))
        if j is not None:
            ta = axisym["time"].values
            ok = np.isfinite(axisym["pole_radius"].values[j])
            ax.plot(ta[ok], axisym["pole_radius"].values[j][ok], "k-", lw=1, label="axisymmetric (same model)")
            ax.plot(ta[ok], axisym["furrow_radius"].values[j][ok], "k-", lw=1)
        ax.set_title(f"{scene}: p = {p}, $\\hat\\zeta$ = {zh}", fontsize=9)
        ax.set_xlabel(r"$t / t_a$")
        ax.legend(fontsize=6)
    axes[0].set_ylabel(r"radius / $R_0$")
    return fig


def _profiles(path, times: Sequence[float]) -> tuple[float, dict]:
    """One pass over a trajectory: its last time and, per requested time up to its end,
    ``(z, |v_t|, v_n, frame time)`` at the nearest frame, with the solver's normals
    (:meth:`cortex_ti.io.trajectory.Trajectory.normals`: the normal of the fitted surface;
    area-weighted vertex normals are off by O(h), which at 2562 nodes mixes ~1 % of v_n into
    v_t, visible where v_t is small, at t = 0). For an axisymmetric run, its meridian."""
    out = {}
    with Trajectory(path, lazy=True) as tr:
        tt = tr.times
        meridian = "meridian_z" in tr.ds
        for t in times:
            if t > tt[-1] + 1e-9:
                continue
            k = tr.frame_at(t)
            if meridian:
                f = tr.ds.isel(time=k)
                out[t] = (
                    f["meridian_z"].values,
                    np.abs(f["meridian_v_s"].values),
                    f["meridian_v_n"].values,
                    float(tt[k]),
                )
                continue
            pts = tr.mesh(k)[0]  # the frame's own nodes (a remeshed run)
            vel = tr.nodal("velocity", k)
            normals = tr.normals(k)
            vn = np.einsum("nc,nc->n", vel, normals)
            vt = np.linalg.norm(vel - vn[:, None] * normals, axis=1)
            out[t] = (pts[:, 2], vt, vn, float(tt[k]))
    return float(tt[-1]), out


def profiles_figure(
    runs: Sequence[tuple[Mapping, str]], times: Sequence[float], twins: Sequence[tuple[Mapping, str]] = ()
) -> Figure:
    """``|v_t|`` and v_n against z at the given times (paper Figs. 5B-G, 7B-G, 8B-G), one column
    pair per 3D run; the axisymmetric solution of the same scene (its twin) as a black line.
    Times beyond a run's end are left empty."""
    from .sweeps import twin_key

    times = [float(t) for t in times]
    twin_of = {twin_key(row): path for row, path in twins}
    fig = Figure(figsize=(4.0 * len(runs), 2.2 * len(times) + 0.6), layout="constrained")
    axes = fig.subplots(len(times), 2 * len(runs), squeeze=False)
    for j, (row, path) in enumerate(runs):
        t_last, profiles = _profiles(path, times)
        twin = twin_of.get(twin_key(row))
        twin_profiles = _profiles(twin, times)[1] if twin else {}
        for i, t in enumerate(times):
            ax_t, ax_n = axes[i, 2 * j], axes[i, 2 * j + 1]
            if t not in profiles:
                for ax in (ax_t, ax_n):
                    ax.text(
                        0.5,
                        0.5,
                        f"run ends at t = {t_last:g}",
                        ha="center",
                        va="center",
                        transform=ax.transAxes,
                        fontsize=8,
                        color="0.4",
                    )
                    ax.set_xticks([])
                    ax.set_yticks([])
                continue
            z, vt, vn, tk = profiles[t]
            ax_t.plot(z, vt, ".", ms=2, label="3D nodes")
            ax_n.plot(z, vn, ".", ms=2, label="3D nodes")
            if t in twin_profiles:
                za, vta, vna, _ = twin_profiles[t]
                ax_t.plot(za, vta, "k-", lw=1, label="axisymmetric")
                ax_n.plot(za, vna, "k-", lw=1, label="axisymmetric")
            ax_t.set_ylabel(f"t = {tk:g}\n" + r"$|v_t| / v_a$")
            ax_n.set_ylabel(r"$v_n / v_a$")
            if i == 0:
                ax_t.set_title(f"{row.get('scene')} N={row.get('nodes')}: tangential", fontsize=8)
                ax_n.set_title("normal", fontsize=8)
                ax_t.legend(fontsize=6)
            if i == len(times) - 1:
                ax_t.set_xlabel(r"$z / R_0$")
                ax_n.set_xlabel(r"$z / R_0$")
    return fig


#: The overrides that take the furrow_p8_a1 scene to the external reference's problem (no bending viscosity).
REFERENCE_PROBLEM = [
    "model=axisymmetric",
    "viscosity.bending=0",
    "viscosity.bending_bulk=0",
    "time.t_end=3",
    "effects=[active_stress, shear_viscosity, bulk_viscosity, normal_balance, incompressibility, shape_evolution]",
]


def reference_check_figure(axisym: xr.Dataset | None = None) -> Figure:
    """The axisymmetric solver against the external reference run (cortex_ti/data/axisym, the
    authors' code run once: p = 8, zeta_hat = 1, no bending viscosity): the radii, and their
    deviation over time, for the same problem without bending viscosity (solved here, about a
    second) and, for scale, for the scene with its bending viscosity (the twin in ``axisym``)."""
    from ..axisymmetric.run import AxisymmetricRun
    from ..scene import load_scene

    ref = reference.load_radii()
    res = AxisymmetricRun(load_scene("furrow_p8_a1", REFERENCE_PROBLEM)).simulate()
    keep = ref["t"] <= res.t[-1] + 1e-9
    tr = ref["t"][keep]
    fig = Figure(figsize=(10, 3.8), layout="constrained")
    a0, a1 = fig.subplots(1, 2)
    a0.plot(tr, ref["pole_radius"][keep], "k-", lw=2.5, alpha=0.35, label="external reference (pole, furrow)")
    a0.plot(tr, ref["furrow_radius"][keep], "k-", lw=2.5, alpha=0.35)
    a0.plot(res.t, res.pole_radius, "C0-", lw=1, label="axisymmetric solver, no bending viscosity")
    a0.plot(res.t, res.furrow_radius, "C0-", lw=1)
    for name, mark in (("pole_radius", "-"), ("furrow_radius", "--")):
        a1.semilogy(
            tr,
            np.abs(np.interp(tr, res.t, getattr(res, name)) - ref[name][keep]) + 1e-12,
            "C0" + mark,
            label=f"{name.split('_')[0]}: no bending (the reference's problem)",
        )
        twin = _twin_index(axisym).get(("furrow_p8_a1", 1.0, 8.0))
        if twin is not None:
            ta = axisym["time"].values
            ok = np.isfinite(axisym[name].values[twin])
            a1.semilogy(
                tr,
                np.abs(np.interp(tr, ta[ok], axisym[name].values[twin][ok]) - ref[name][keep]) + 1e-12,
                "C1" + mark,
                label=f"{name.split('_')[0]}: with the scene's bending viscosity",
            )
    a1.axhline(1e-4, color="0.5", lw=0.8, ls=":", label="1e-4 (the reference's own time error ~8e-5)")
    a0.set_xlabel(r"$t / t_a$")
    a0.set_ylabel(r"radius / $R_0$")
    a0.legend(fontsize=7)
    a1.set_xlabel(r"$t / t_a$")
    a1.set_ylabel(r"|radius - external reference| / $R_0$")
    a1.legend(fontsize=6)
    return fig


def orientation_figure(ds: xr.Dataset) -> Figure:
    """Orientation angle (long axis vs pattern axis) and the radii along the long axis against
    time, one line per (gamma, tilt) run (paper Figs. 10-12, quantified)."""
    fig = Figure(figsize=(10, 3.6), layout="constrained")
    a0, a1 = fig.subplots(1, 2)
    t = ds["time"].values
    for i in range(ds.sizes["run"]):
        lab = f"$\\gamma$ = {ds['gamma'].values[i]}, tilt {ds['tilt'].values[i]}°, N={ds['nodes'].values[i]}"
        (line,) = a0.plot(t, ds["orientation_angle"].values[i], label=lab)
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
        (line,) = a0.plot(t, ds["radius_stripe"].values[i], "-", label=f"across stripe, {lab}")
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
    markers = _markers(SCHEMES)
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


def snapshots_figure(runs: Sequence[tuple[str, str]], times: Sequence[float], view=(20.0, -60.0)) -> Figure:
    """3D snapshots (paper Figs. 9-12): per run a row, the active stress at t = 0 and then ``|v|``
    with arrows at each time of ``times`` up to the run's end (and at its end). The frames are
    drawn by PyVista off screen where it works, else by matplotlib (the log says which)."""
    import logging

    from ..viz.figure import frame_panel
    from ..viz.render import choose_renderer

    renderer = choose_renderer()
    logging.getLogger("cortex_ti").info(renderer.line)

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
            ax, _ = frame_panel(
                fig,
                (len(rows), ncol, r * ncol + 1),
                ds,
                0,
                "active_stress",
                arrows=False,
                view=view,
                renderer=renderer,
                label=r"$\zeta / \zeta_0$",
            )
            ax.set_title(f"{label}\nactive stress", fontsize=7)
            for c, k in enumerate(pick):
                ax, _ = frame_panel(
                    fig,
                    (len(rows), ncol, r * ncol + 2 + c),
                    ds,
                    int(k),
                    "speed",
                    view=view,
                    renderer=renderer,
                    label=r"$|v| / v_a$",
                )
                ax.set_title(f"t = {float(ds['time'].values[k]):.4g} $t_a$", fontsize=8)
    for ax in fig.axes:
        ax.tick_params(labelsize=6)
    return fig


def sphere_flows_figure(paths: Sequence[str], view=(20.0, -60.0)) -> Figure:
    """The flow on a static sphere (paper Figs. 2B-E, 3B-E): per scene the surface coloured by
    ``|v|`` with arrows, and the velocity against the polar angle theta at the nodes (the normal
    part for the full system, the tangential speed for the tangential one; for a non-axisymmetric
    pattern the nodes near the meridian phi = 0) with the analytic solution as a line."""
    from ..truth.analytic import scene_solution
    from ..viz.plotting import colorbar_below, plot_frame

    fig = Figure(figsize=(7.2, 2.8 * len(paths)), layout="constrained")
    for r, path in enumerate(paths):
        with Trajectory(path, lazy=True) as tr:
            settings = tr.settings
            ax = fig.add_subplot(len(paths), 2, 2 * r + 1, projection="3d")
            _, m = plot_frame(tr.ds, frame=0, color="speed", arrows=True, ax=ax, view=view, axes=False)
            colorbar_below(fig, ax, m, r"$|v| / v_a$", fontsize=7)
            ax.set_title(f"{settings.name}, N = {tr.ds.sizes['node']}", fontsize=8)
            ax.tick_params(labelsize=6)
            x = tr.mesh(0)[0]
            v = tr.nodal("velocity", 0)
            n = tr.normals(0)
        theta = np.arccos(np.clip(x[:, 2] / np.linalg.norm(x, axis=1), -1, 1))
        phi = np.arctan2(x[:, 1], x[:, 0])
        tangential = settings.has("fixed_normal_velocity")
        axisym = all(t["m"] == 0 for p in settings.patterns for t in p.get("terms", []))
        near = np.ones(len(x), bool) if axisym else np.abs(phi) < 0.2  # the meridian phi = 0
        radius = float(np.mean(np.linalg.norm(x, axis=1)))
        line = np.linspace(0.0, np.pi, 181)
        meridian = radius * np.stack([np.sin(line), np.zeros_like(line), np.cos(line)], -1)

        def value(w, normals, tangential=tangential):
            wn = np.einsum("nc,nc->n", w, normals)
            return np.linalg.norm(w - wn[:, None] * normals, axis=1) if tangential else wn

        ax = fig.add_subplot(len(paths), 2, 2 * r + 2)
        ax.plot(theta[near], value(v, n)[near], ".", ms=2, label="3D nodes")
        ax.plot(line, value(scene_solution(settings, meridian), meridian / radius), "k-", lw=1, label="analytic")
        ax.set_xlabel(r"$\theta$" + ("" if axisym else r" (nodes near the meridian $\phi$ = 0)"))
        ax.set_ylabel(r"$|v_t| / v_a$" if tangential else r"$v_n / v_a$")
        ax.legend(fontsize=6)
    return fig


def _rate_groups(ds: xr.Dataset):
    """The rate runs of a self_organisation store: their indices, rates, scene, and the (activity,
    turnover) of the panel against l (the largest activity at the commonest turnover)."""
    from . import self_organisation as so

    idx = so.rate_runs(ds)
    rates = so.run_rates(ds)
    if not idx:
        return idx, rates, None, (np.nan, np.nan)
    scene = str(ds["scene"].values[idx[0]])
    ks = [float(ds["turnover"].values[i]) for i in idx]
    k = max(set(ks), key=ks.count)
    a = max(so.activity(ds, i) for i in idx if float(ds["turnover"].values[i]) == k)
    return idx, rates, scene, (a, k)


def myosin_rates_figure(ds: xr.Dataset) -> Figure:
    """Growth rates of the uniform myosin cortex against the degree l and against the activity: closed
    form (lines), spectrum tool at the runs' resolutions (open markers, thin lines), runs (filled)."""
    from . import self_organisation as so

    idx, rates, scene, (a_top, k) = _rate_groups(ds)
    fig = Figure(figsize=(14, 3.8), layout="constrained")
    a0, a1, a2 = fig.subplots(1, 3)
    if scene is None:
        return fig
    nodes = sorted({int(ds["nodes"].values[i]) for i in idx})
    colour = {n: f"C{j}" for j, n in enumerate(nodes)}
    ls = np.arange(1, 6)
    a0.plot(ls, [so.closed_rate(scene, l, a_top, k) for l in ls], "k-", lw=1, label="closed form")
    for n in nodes:
        a0.plot(
            ls[:3],
            [so.spectrum_rate(scene, n, l, a_top, k) for l in ls[:3]],
            "o",
            mfc="none",
            color=colour[n],
            label=f"spectrum tool, N={n}",
        )
    for i in idx:
        if so.activity(ds, i) == a_top and float(ds["turnover"].values[i]) == k:
            n = int(ds["nodes"].values[i])
            a0.plot(int(ds["degree"].values[i]), rates[i], "s", ms=4, color=colour[n], label=f"runs, N={n}")
    a0.axhline(0.0, color="0.6", lw=0.6)
    a0.set_xticks(ls)
    a0.set_xlabel("degree l")
    a0.set_ylabel(r"growth rate $\lambda\, t_a$")
    a0.set_title(f"A = {a_top:g}, k = {k:g}", fontsize=9)
    _dedupe_legend(a0)
    acts = np.linspace(0.0, 1.05 * max(so.activity(ds, i) for i in idx), 43)
    for l, style in ((1, "--"), (2, "-")):
        a1.plot(acts, [so.closed_rate(scene, l, a, k) for a in acts], "k" + style, lw=1, label=f"closed form, l = {l}")
        for n in nodes:
            a1.plot(
                acts,
                [so.spectrum_rate(scene, n, l, a, k) for a in acts],
                style,
                lw=0.7,
                color=colour[n],
                label=f"spectrum tool, N={n}",
            )
        for i in idx:
            if int(ds["degree"].values[i]) == l and float(ds["turnover"].values[i]) == k:
                n = int(ds["nodes"].values[i])
                a1.plot(
                    so.activity(ds, i),
                    rates[i],
                    "s" if l == 2 else "^",
                    ms=4,
                    color=colour[n],
                    label=f"runs l = {l}, N={n}",
                )
    a1.axhline(0.0, color="0.6", lw=0.6)
    a1.set_xlabel(r"activity $A = \zeta_0 \gamma$")
    a1.set_ylabel(r"growth rate $\lambda\, t_a$")
    a1.set_title(f"k = {k:g}", fontsize=9)
    _dedupe_legend(a1)
    marker = {1: "^", 2: "s", 3: "D"}
    for i in idx:
        l, n = int(ds["degree"].values[i]), int(ds["nodes"].values[i])
        a, kk = so.activity(ds, i), float(ds["turnover"].values[i])
        exact = so.closed_rate(scene, l, a, kk)
        a2.loglog(n, abs(rates[i] - exact), marker.get(l, "o"), color=f"C{l - 1}", label=f"runs, l = {l}")
        a2.loglog(
            n,
            abs(so.spectrum_rate(scene, n, l, a, kk) - exact),
            marker.get(l, "o"),
            mfc="none",
            ms=9,
            color=f"C{l - 1}",
            label=f"spectrum tool, l = {l}",
        )
    guide = np.array([min(nodes) / 2, max(nodes) * 2], dtype=float)
    a2.loglog(guide, 0.02 * (guide / 642.0) ** -1.0, "k:", lw=0.8, label=r"$\propto N^{-1} \sim h^2$")
    a2.set_xlabel("nodes N")
    a2.set_ylabel(r"|rate $-$ closed form| $t_a$")
    a2.set_title("every run", fontsize=9)
    _dedupe_legend(a2)
    return fig


def _dedupe_legend(ax, **kw) -> None:
    handles, labels = ax.get_legend_handles_labels()
    seen = dict(zip(labels, handles, strict=True))
    ax.legend(seen.values(), seen.keys(), fontsize=6, **kw)


def myosin_onset_figure(ds: xr.Dataset) -> Figure:
    """The onset of l = 1 and l = 2 in the (turnover, activity) plane: closed form, spectrum tool,
    and the runs (filled: the seeded mode grew)."""
    from . import self_organisation as so

    idx, rates, scene, _ = _rate_groups(ds)
    fig = Figure(figsize=(8.0, 4.2), layout="constrained")
    ax = fig.subplots()
    if scene is None:
        return fig
    nodes = sorted({int(ds["nodes"].values[i]) for i in idx})
    colour = {n: f"C{j}" for j, n in enumerate(nodes)}
    ks = np.linspace(0.0, 1.2 * max(float(ds["turnover"].values[i]) for i in idx), 25)
    for l, style in ((1, "--"), (2, "-")):
        ax.plot(ks, so.closed_onset(scene, l, ks), "k" + style, lw=1, label=f"closed form, l = {l}")
        for n in nodes:
            ax.plot(
                ks[::4],
                [so.spectrum_onset(scene, n, l, k) for k in ks[::4]],
                style,
                lw=0.7,
                color=colour[n],
                label=f"spectrum tool l = {l}, N={n}",
            )
    marker = {1: "^", 2: "s", 3: "D"}
    for i in idx:
        l, n = int(ds["degree"].values[i]), int(ds["nodes"].values[i])
        grew = rates[i] > 0
        ax.plot(
            float(ds["turnover"].values[i]),
            so.activity(ds, i),
            marker.get(l, "o"),
            ms=6,
            color=colour[n],
            mfc=colour[n] if grew else "none",
            label=f"runs l = {l}, N={n} (filled: grew)",
        )
    ax.set_xlabel(r"turnover $k\, t_a$")
    ax.set_ylabel(r"activity $A = \zeta_0 \gamma$")
    ax.set_ylim(0.0, 1.3 * max(so.activity(ds, i) for i in idx))
    _dedupe_legend(ax, loc="upper left", bbox_to_anchor=(1.02, 1.0))
    return fig


def myosin_ring_figure(ds: xr.Dataset) -> Figure:
    """The self-organised ring's furrow radius: 3D runs and the axisymmetric twin, and their difference."""
    from . import self_organisation as so

    rings = so.ring_runs(ds)
    fig = Figure(figsize=(10, 3.8), layout="constrained")
    a0, a1 = fig.subplots(1, 2)
    t = ds["time"].values
    for scene, (idx, j) in rings.items():
        twin = ds["furrow_radius"].values[j]
        ok = np.isfinite(twin)
        a0.plot(t[ok], twin[ok], "k-", lw=1.2, label=f"{scene}: axisymmetric twin")
        for i in idx:
            r = ds["furrow_radius"].values[i]
            k = np.isfinite(r) & ok
            (line,) = a0.plot(t[k], r[k], "--", lw=1, label=f"3D N={ds['nodes'].values[i]}")
            a1.semilogy(
                t[k],
                np.abs(r[k] - twin[k]),
                "-",
                color=line.get_color(),
                label=f"|3D N={ds['nodes'].values[i]} - twin|",
            )
    a1.axhline(2e-3, color="0.5", lw=0.8, ls="--", label=r"$2\times 10^{-3} R_0$")
    a0.set_xlabel(r"$t / t_a$")
    a0.set_ylabel(r"furrow radius / $R_0$")
    a1.set_xlabel(r"$t / t_a$")
    a1.set_ylabel(r"|3D $-$ axisymmetric| / $R_0$")
    a0.legend(fontsize=7)
    a1.legend(fontsize=7)
    return fig


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
