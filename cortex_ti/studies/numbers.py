"""The numbers to compare, figure by figure, and what the runs behind each figure cost.

For every registered figure (:data:`cortex_ti.studies.registry.FIGURES`) the workflow writes,
beside the picture, a small HTML table: the quantities a reader compares with the paper or with
a truth (an analytic solution, the axisymmetric solution of the same scene), and the cost of
the runs the figure is drawn from (from the cost store). :func:`figure_numbers` dispatches on
the figure's drawing function; a figure without numbers of its own gets only the cost.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
import xarray as xr

from ..io.trajectory import Trajectory
from .constriction import constriction_numbers
from .cytokinesis import cytokinesis_numbers
from .fluids import fluids_numbers
from .registry import FIGURES

__all__ = ["figure_numbers", "numbers_html"]


def _convergence(stores) -> pd.DataFrame:
    ds = stores[0]
    rows = []
    for scene in ds["scene"].values:
        for form in ds["formulation"].values:
            for fit in ds["fit"].values:
                e = ds["eps_rel"].sel(scene=scene, formulation=form, fit=fit).values
                n = ds["nodes"].values.astype(float)
                ok = np.isfinite(e)
                if not ok.any():
                    continue
                order = np.polyfit(np.log(n[ok]), np.log(e[ok]), 1)[0] if ok.sum() > 1 else np.nan
                rows.append(
                    {
                        "scene": scene,
                        "formulation": form,
                        "fit": fit,
                        **{f"eps_rel N={int(k)}": f"{v:.2e}" for k, v in zip(n, e, strict=True)},
                        "slope d log eps / d log N": f"{order:.2f}",
                        "paper": "quadratic: eps ~ 1/N (slope -1)",
                    }
                )
    return pd.DataFrame(rows)


def _sphere_flows(paths) -> pd.DataFrame:
    from ..truth.analytic import error_measures, scene_solution

    rows = []
    for path in paths:
        with Trajectory(path, lazy=True) as tr:
            x, v = tr.mesh(0)[0], tr.nodal("velocity", 0)
            eps, eps_rel = error_measures(v, scene_solution(tr.settings, x))
            rows.append(
                {
                    "scene": tr.settings.name,
                    "nodes": x.shape[0],
                    "fit": tr.settings.numerics.fit,
                    "eps (Eq. 57)": f"{eps:.2e}",
                    "eps_rel (Eq. 58)": f"{eps_rel:.2e}",
                    "max |v| analytic": f"{np.linalg.norm(scene_solution(tr.settings, x), axis=1).max():.4f}",
                }
            )
    return pd.DataFrame(rows)


def _furrow_pictures(runs) -> pd.DataFrame:
    from ..truth.sphere_exact import sphere_flow

    rows = []
    for label, path in runs:
        with Trajectory(path, lazy=True) as tr:
            s = tr.settings
            x0, v0, n0 = tr.mesh(0)[0], tr.nodal("velocity", 0), tr.normals(0)
            ring = s.patterns[0]
            vis = s.viscosity

            def zeta(p, ring=ring):
                th = np.arccos(np.clip(p[:, 2] / np.linalg.norm(p, axis=1), -1, 1))
                return ring["zeta0"] + ring["amplitude"] * np.exp(-ring["sigma"] * np.abs(th - np.pi / 2) ** ring["p"])

            poles = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
            exact, _, _ = sphere_flow(
                zeta,
                poles,
                eta_s=vis.shear,
                eta_b=vis.bulk,
                eta_bar=vis.bending,
                eta_bar_b=vis.bending_bulk,
                axis=(0, 0, 1),
                lmax=240,
            )
            top = int(np.argmax(x0[:, 2]))
            rows.append(
                {
                    "run": label,
                    "v_n at the north pole, t = 0": f"{float(v0[top] @ n0[top]):.4f}",
                    "exact (sphere_exact, with the scene's bending viscosity)": f"{exact[0, 2]:.4f}",
                    "t_end": f"{tr.times[-1]:g}",
                    "final pole radius": f"{tr.ds['pole_radius'].values[-1]:.5f}",
                    "final furrow radius": f"{tr.ds['furrow_radius'].values[-1]:.5f}",
                }
            )
    return pd.DataFrame(rows)


def _furrow_radii(stores) -> pd.DataFrame:
    from .figures_shapes import twin_index

    ds, axisym = stores
    twins = twin_index(axisym)
    rows = []
    for i in range(ds.sizes["run"]):
        key = (str(ds["scene"].values[i]), float(ds["zeta_hat"].values[i]), float(ds["p"].values[i]))
        j = twins.get(key)
        row = {"run": str(ds["label"].values[i])}
        for name in ("pole_radius", "furrow_radius"):
            v = ds[name].values[i]
            ok = np.isfinite(v)
            row[f"{name} at t = {ds['time'].values[ok][-1]:g}"] = f"{v[ok][-1]:.5f}"
            if j is not None:
                a = np.interp(ds["time"].values[ok], axisym["time"].values, axisym[name].values[j])
                row[f"axisymmetric {name}"] = f"{a[-1]:.5f}"
                row[f"max |3D - axisymmetric| {name}"] = f"{np.max(np.abs(v[ok] - a)):.2e}"
        rows.append(row)
    return pd.DataFrame(rows)


def _velocity_profiles(runs, times, twins=()) -> pd.DataFrame:
    from ..axisymmetric.compare import compare

    rows = []
    for row, path in runs:
        r = compare(path, times)
        for t in times:
            if f"profile_{t:g}" in r:
                a, b, c, d, sn, st = r[f"profile_{t:g}"]
                rows.append(
                    {
                        "scene": row.get("scene"),
                        "nodes": row.get("nodes"),
                        "t": t,
                        "max / rms |dv_n|": f"{a:.1e} / {b:.1e}",
                        "max / rms |d|v_t||": f"{c:.1e} / {d:.1e}",
                        "scale v_n, |v_t|": f"{sn:.3f}, {st:.3f}",
                    }
                )
    return pd.DataFrame(rows)


def _fold(stores) -> pd.DataFrame:
    ds = stores[0]
    t = ds["time"].values
    rows = []
    for i in range(ds.sizes["run"]):
        depth = ds["fold_depth"].values[i]
        ok = np.isfinite(depth)
        row = {"run": str(ds["label"].values[i])}
        for tq in (0.1, 0.5, 1.0, 3.5):
            if tq <= t[ok][-1] + 1e-9:
                row[f"fold depth t = {tq:g}"] = f"{depth[np.argmin(np.abs(t - tq))]:.3f}"
        row["radius across / beside the stripe at the end"] = (
            f"{ds['radius_stripe'].values[i][ok][-1]:.3f} / {ds['radius_off_stripe'].values[i][ok][-1]:.3f}"
        )
        rows.append(row)
    return pd.DataFrame(rows)


def _orientation(stores) -> pd.DataFrame:
    ds = stores[0]
    t = ds["time"].values
    rows = []
    for i in range(ds.sizes["run"]):
        a = ds["orientation_angle"].values[i]
        ok = np.isfinite(a)
        row = {"run": str(ds["label"].values[i])}
        for tq in (0.0, 0.09, 0.5, 1.0, 3.5):
            if tq <= t[ok][-1] + 1e-9:
                row[f"angle t = {tq:g} (deg)"] = f"{a[np.argmin(np.abs(t - tq))]:.1f}"
        rows.append(row)
    return pd.DataFrame(rows)


def _reference_check(stores) -> pd.DataFrame:
    from ..analysis import reference
    from ..axisymmetric.run import AxisymmetricRun
    from ..scene import load_scene
    from .figures_shapes import REFERENCE_PROBLEM, twin_index

    ref = reference.load_radii()
    res = AxisymmetricRun(load_scene("furrow_p8_a1", REFERENCE_PROBLEM)).simulate()
    dev = reference.radii_deviation(res.t, res.pole_radius, res.furrow_radius)
    rows = [
        {
            "axisymmetric run": "no bending viscosity (the reference's problem)",
            **{f"max |dev| {k} (t <= 3)": f"{dev[k]:.2e}" for k in ("pole", "furrow")},
        }
    ]
    axisym = stores[0]
    j = twin_index(axisym).get(("furrow_p8_a1", 1.0, 8.0))
    if j is not None:
        d = reference.radii_deviation(
            axisym["time"].values, axisym["pole_radius"].values[j], axisym["furrow_radius"].values[j]
        )
        rows.append(
            {
                "axisymmetric run": "with the scene's bending viscosity",
                **{f"max |dev| {k} (t <= 3)": f"{d[k]:.2e}" for k in ("pole", "furrow")},
            }
        )
    rows.append(
        {
            "axisymmetric run": "the reference's own time error (its README)",
            "max |dev| pole (t <= 3)": "~8e-5",
            "max |dev| furrow (t <= 3)": "~8e-5",
        }
    )
    del ref
    return pd.DataFrame(rows)


def _accuracy(stores) -> pd.DataFrame:
    ds = stores[0]
    sel = np.flatnonzero(ds["study"].values == "accuracy")
    cols = ["formulation", "nodes", "fit", "scheme", "implicit_tension", "dt", "tol", "status"]
    out = ds.isel(run=sel).reset_coords()[cols + ["wall_s", "steps", "error"]].to_dataframe().reset_index(drop=True)
    out["wall_s"] = out["wall_s"].map(lambda v: f"{v:.1f}")
    out["error"] = out["error"].map(lambda v: f"{v:.2e}")
    return out


def _myosin_rates(stores) -> pd.DataFrame:
    from . import self_organisation as so

    out = pd.DataFrame([r._asdict() for r in so.rate_table(stores[0])])
    if not len(out):
        return out
    params = list(zip(out.scene, out.nodes, out.degree, out.activity, out.turnover, strict=True))
    out["spectrum tool"] = [so.spectrum_rate(*p) for p in params]
    out["closed form"] = [so.closed_rate(s, l, a, k) for s, _, l, a, k in params]
    out["run / closed - 1"] = out.rate / out["closed form"] - 1.0
    out["spectrum / closed - 1"] = out["spectrum tool"] / out["closed form"] - 1.0
    out["run - spectrum"] = out.rate - out["spectrum tool"]
    return out.drop(columns=["index"]).rename(columns={"rate": "run"}).round(6)


def _myosin_onset(stores) -> pd.DataFrame:
    from . import self_organisation as so

    out = pd.DataFrame([r._asdict() for r in so.rate_table(stores[0])])
    if not len(out):
        return out
    out["closed-form onset A_c"] = [
        float(so.closed_onset(s, l, k)[0]) for s, l, k in zip(out.scene, out.degree, out.turnover, strict=True)
    ]
    out["spectrum-tool onset"] = [
        so.spectrum_onset(s, n, l, k) for s, n, l, k in zip(out.scene, out.nodes, out.degree, out.turnover, strict=True)
    ]
    out["grew (run) / grows (closed form)"] = [
        f"{'yes' if r > 0 else 'no'} / {'yes' if a > ac else 'no'}"
        for r, a, ac in zip(out.rate, out.activity, out["closed-form onset A_c"], strict=True)
    ]
    return out.drop(columns=["index", "scene"]).round(5)


def _myosin_ring(stores) -> pd.DataFrame:
    from . import self_organisation as so

    ds = stores[0]
    t = ds["time"].values
    rows = []
    for scene, (idx, j) in so.ring_runs(ds).items():
        twin = ds["furrow_radius"].values[j]
        for tq in (0.0, 10.0, 20.0, 25.0, 30.0, 36.0):
            k = int(np.argmin(np.abs(t - tq)))
            if abs(t[k] - tq) > 1e-6 or not np.isfinite(twin[k]):
                continue
            row = {"scene": scene, "t": f"{t[k]:g}", "twin furrow radius": f"{twin[k]:.5f}"}
            for i in idx:
                row[f"3D N={ds['nodes'].values[i]} - twin"] = f"{ds['furrow_radius'].values[i][k] - twin[k]:+.2e}"
            rows.append(row)
    return pd.DataFrame(rows)


_NUMBERS = {
    "myosin_rates_figure": _myosin_rates,
    "myosin_onset_figure": _myosin_onset,
    "myosin_ring_figure": _myosin_ring,
    "convergence_figure": _convergence,
    "sphere_flows_figure": _sphere_flows,
    "radii_figure": _furrow_radii,
    "profiles_figure": _velocity_profiles,
    "fold_figure": _fold,
    "orientation_figure": _orientation,
    "reference_check_figure": _reference_check,
    "accuracy_cost_figure": _accuracy,
    "constriction_figure": constriction_numbers,
    "fluids_figure": fluids_numbers,
    "cytokinesis_figure": cytokinesis_numbers,
}


def _cost(name: str, cost: xr.Dataset) -> pd.DataFrame:
    """Runs, wall time, steps and peak memory of the studies a figure is drawn from."""
    spec = FIGURES[name]
    behind = {"convergence": "static", "cost": "accuracy"}  # the runs behind a store that is not a study's
    studies = ("static",) if spec.source == "static" else tuple(behind.get(d, d) for d in spec.data)
    rows = []
    for study in studies:
        sel = np.flatnonzero(cost["study"].values == study)
        if not sel.size:
            continue
        c = cost.isel(run=sel)
        rows.append(
            {
                "study": study,
                "runs": int(sel.size),
                "failed": int((c["status"].values != "ok").sum()),
                "wall time, sum (s)": f"{np.nansum(c['wall_s'].values):.0f}",
                "wall time, largest (s)": f"{np.nanmax(c['wall_s'].values):.0f}",
                "steps, sum": int(np.nansum(c["steps"].values)),
                "peak memory, largest (MB)": f"{np.nanmax(c['max_rss_mb'].values):.0f}",
            }
        )
    return pd.DataFrame(rows)


def figure_numbers(name: str, inputs: Sequence, options: Mapping, rows: Mapping, cost: xr.Dataset | None):
    """``(numbers, cost)`` DataFrames of the figure ``name`` (inputs as for
    :func:`cortex_ti.studies.figures.draw_figure`); ``numbers`` is None for a figure without."""
    spec = FIGURES[name]
    func = _NUMBERS.get(spec.draw)
    numbers = None
    if spec.draw == "snapshots_figure" and spec.data == ("furrow",):
        from .stores import short_labels

        main = list(zip(rows["furrow"], inputs, strict=False))  # inputs may hold more than the furrow runs
        numbers = _furrow_pictures(list(zip(short_labels([r for r, _ in main]), [p for _, p in main], strict=True)))
    elif func is not None:
        if spec.source == "store":
            numbers = func([xr.load_dataset(p, engine="h5netcdf") for p in inputs])
        elif spec.source == "static":
            numbers = func(list(inputs))
        else:
            first = spec.data[0]
            numbers = func(
                list(zip(rows[first], inputs[: len(rows[first])], strict=True)), [options[k] for k in spec.options][0]
            )
    return numbers, (_cost(name, cost) if cost is not None else None)


def numbers_html(name: str, numbers: pd.DataFrame | None, cost: pd.DataFrame | None) -> str:
    """The numbers and the cost of a figure as one small HTML page (for the report)."""
    parts = [f"<h3>{name}: the numbers to compare</h3>"]
    parts.append(
        numbers.to_html(index=False, border=0)
        if numbers is not None and len(numbers)
        else "<p>(the figure itself is the result: see its caption)</p>"
    )
    if cost is not None and len(cost):
        parts += ["<h3>what the runs behind it cost</h3>", cost.to_html(index=False, border=0)]
    return (
        "<html><head><meta charset='utf-8'><style>td,th{padding:2px 6px;font:12px sans-serif;"
        "border-bottom:1px solid #ddd}</style></head><body>" + "".join(parts) + "</body></html>"
    )
