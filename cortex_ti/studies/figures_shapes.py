"""The workflow's figures of the shape studies (paper Figs. 5-8 and their checks): the convergence
of the pole and furrow radii, the radii over time beside the axisymmetric twin, the meridian
profiles, the check against the external axisymmetric reference, the orientation and the fold
(drawn by name through :func:`cortex_ti.studies.figures.draw_figure`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import xarray as xr
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from ..analysis import reference
from ..io.trajectory import Trajectory
from ..physics.formulations import FORMULATIONS
from ..surface.fits import FIT_SCHEMES
from .constriction import constriction_figure  # noqa: F401  (issue 18's figure, drawn by name)

_MARKERS = "os^Dvp<>h*"


def registry_markers(registry) -> dict[str, str]:
    """One marker per registered name (fit schemes, time schemes), in registry order."""
    return {name: _MARKERS[i % len(_MARKERS)] for i, name in enumerate(registry)}


def convergence_figure(ds: xr.Dataset) -> Figure:
    """Relative velocity error against N for the sphere scenes (paper Figs. 2F,G and 3F,G)."""
    fig = Figure(figsize=(9, 3.8), layout="constrained")
    axes = fig.subplots(1, 2, sharey=True)
    systems = {"full": axes[0], "tangential": axes[1]}
    markers = registry_markers(FIT_SCHEMES)
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


def twin_index(axisym: xr.Dataset | None) -> dict[tuple, int]:
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
    twins = twin_index(axisym)
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
        twin = twin_index(axisym).get(("furrow_p8_a1", 1.0, 8.0))
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
