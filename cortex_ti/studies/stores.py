"""Gather the workflow's runs into xarray stores (``results/aggregate/*.nc``).

Each time-dependent study becomes one Dataset with dimensions ``(run, time)``: the run's
parameters (the columns of :data:`cortex_ti.studies.registry.STUDIES`) are coordinates along
``run``, ``time`` is the union of the frame times (a run that ended earlier is NaN after its
end). To get a dense grid over the swept parameters::

    ds.set_index(run=["zeta_hat", "p", "nodes", "dt"]).unstack("run")

The cost store has one entry per run of every study, from the ``benchmark:`` files Snakemake
writes (wall time, peak memory) and the run summaries of ``cortex-ti run --summary``
(steps, solves, time per stage).
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import xarray as xr

from ..about import provenance
from ..analysis import reference
from ..analysis.diagnostics import DIAGNOSTIC_ATTRS, NECK_ATTRS, fold_radii, neck_radius
from ..io.files import read_benchmark
from ..io.trajectory import Trajectory
from ..surface.division import side_volumes
from ..surface.measures import area_centroid, volume_centroid
from .registry import STUDIES
from .sweeps import PATTERN_COLUMNS

__all__ = ["study_dataset", "cost_dataset", "run_label", "short_labels", "trajectory_deviation", "twin_deviation"]

_TIME_DECIMALS = 9


def _number(text: str):
    """A sweep value as a number where it is one (so coordinates sort and plot)."""
    try:
        v = float(text)
    except (TypeError, ValueError):
        return text
    return int(v) if v.is_integer() and "." not in str(text) and "e" not in str(text).lower() else v


def run_label(row: Mapping) -> str:
    """Human label of a run: its parameters joined, e.g. ``furrow_p8_a1 nodes=2562 dt=0.0005``."""
    return " ".join([str(row.get("scene", ""))] + [f"{k}={v}" for k, v in row.items() if k != "scene"])


def short_labels(rows: Sequence[Mapping]) -> list[str]:
    """Labels that tell the runs apart: the scene and only the parameters that vary between rows."""
    varying = [k for k in (rows[0] if rows else {}) if k != "scene" and len({str(r[k]) for r in rows}) > 1]
    return [" ".join([str(r.get("scene", ""))] + [f"{k}={r[k]}" for k in varying]) for r in rows]


def fold_series(tr: Trajectory) -> dict[str, np.ndarray]:
    """Equatorial radii across and beside the fold's stripe and the fold depth, per frame."""
    ds = tr.ds
    axis = tr.settings.pattern_axis
    on, off = [], []
    for k in range(ds.sizes["time"]):
        pts, faces = tr.mesh(k)  # each frame's own mesh (a remeshed run)
        a, b = fold_radii(pts, faces, axis)
        on.append(a)
        off.append(b)
    on, off = np.array(on), np.array(off)
    return {"radius_stripe": on, "radius_off_stripe": off, "fold_depth": off - on}


def neck_series(tr: Trajectory) -> np.ndarray:
    """The neck radius of every frame (:func:`~cortex_ti.analysis.diagnostics.neck_radius`, NaN
    without a neck): the trajectory's own ``neck_radius`` where it carries one (runs with
    ``time.stop_neck``, the axisymmetric model), else computed from its frames (a 3D run without
    ``time.stop_neck``, or one written before the variable existed)."""
    if "neck_radius" in tr.ds:
        return np.asarray(tr.ds["neck_radius"].values, dtype=float)
    axis = tr.settings.pattern_axis
    return np.array([neck_radius(*tr.mesh(k), axis=axis)[0] for k in range(tr.ds.sizes["time"])])


def division_series(tr: Trajectory) -> dict[str, np.ndarray]:
    """Per frame of a run toward a cut (the ``cytokinesis`` study): ``n_bodies`` (1 where the run
    does not carry it), and ``volume_upper`` / ``volume_lower``, the volumes on either side along the
    pattern axis: of the two bodies after a cut (ordered by their centroids), before it of the one
    body on either side of its neck's plane (:func:`~cortex_ti.surface.division.side_volumes`, the
    cut's own measure; NaN while the shape has no neck)."""
    ds = tr.ds
    axis = np.asarray(tr.settings.pattern_axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    n_t = ds.sizes["time"]
    bodies = ds["n_bodies"].values.astype(float) if "n_bodies" in ds else np.ones(n_t)
    upper, lower = np.full(n_t, np.nan), np.full(n_t, np.nan)
    for k in range(n_t):
        if bodies[k] >= 2:
            vol, cen = ds["body_volume"].values[k, :2], ds["body_centroid"].values[k, :2] @ axis
            order = np.argsort(-cen)
            upper[k], lower[k] = vol[order[0]], vol[order[1]]
            continue
        pts, faces = tr.mesh(k)
        r, z = neck_radius(pts, faces, axis=axis)
        if np.isfinite(r):
            centre = area_centroid(pts, faces) + z * axis
            lower[k], upper[k] = side_volumes(pts, faces, centre, axis)
    out = {"n_bodies": bodies, "volume_upper": upper, "volume_lower": lower}
    if "axisymmetric_state" in ds and tr.settings.axisymmetric.points == "adaptive":
        out["lobe_rate"] = lobe_series(tr)
    return out


#: the most frames of a run at which the study evaluates the lobe mode's rate (~0.1 CPU s each at n = 64)
LOBE_FRAMES = 16


def lobe_series(tr: Trajectory) -> np.ndarray:
    """The up-down lobe mode's growth rate (:func:`cortex_ti.axisymmetric.lobe.lobe_rate`) at up to
    :data:`LOBE_FRAMES` frames of an axisymmetric run of adaptive points whose neck is below 0.55 R0,
    spread evenly in the logarithm of the neck (the rate climbs as the neck closes), and at its last
    frame (nan at the others)."""
    from ..axisymmetric.lobe import lobe_rate  # the axisymmetric runs of the cytokinesis study only
    from ..axisymmetric.rigidity import rigidity
    from ..axisymmetric.run import axisymmetric_tension, viscosities

    s = tr.settings
    neck = np.asarray(tr.ds["neck_radius"].values, dtype=float)
    deep = np.flatnonzero(np.isfinite(neck) & (neck <= 0.55))
    out = np.full(neck.size, np.nan)
    if not deep.size:
        return out
    log_neck = np.log(neck[deep])
    targets = np.linspace(log_neck[0], log_neck[-1], LOBE_FRAMES)
    pick = np.unique(np.r_[deep[np.abs(log_neck[None, :] - targets[:, None]).argmin(axis=1)], deep[-1]])
    zeta, kappa = axisymmetric_tension(s), rigidity(s).get("kappa", 0.0)
    for k in pick:
        state = tr.ds["axisymmetric_state"].values[k]
        out[k] = lobe_rate(zeta, state, **viscosities(s), kappa=kappa, radius=s.mesh.radius)
    return out


_DIVISION_ATTRS = {
    "n_bodies": {"units": "1", "long_name": "number of bodies (closed surfaces) of the frame"},
    "volume_upper": {
        "units": "R0^3",
        "long_name": "volume on the upper side (along the pattern axis)",
        "description": "after a cut the upper daughter's; before it the one body's above its neck's plane",
    },
    "lobe_rate": {
        "units": "1/t_a",
        "long_name": "growth rate of the up-down lobe mode",
        "description": "axisymmetric runs: the largest real eigenvalue of the modes odd under z -> -z of the "
        "full-meridian linearisation at the frame's state (axisymmetric.lobe.lobe_rate); at up to 16 frames of "
        "neck <= 0.55 and the last, nan at the others and in 3D",
    },
    "volume_lower": {
        "units": "R0^3",
        "long_name": "volume on the lower side",
        "description": "after a cut the lower daughter's; before it the one body's below its neck's plane",
    },
}


def centroid_series(tr: Trajectory) -> np.ndarray:
    """The enclosed volume's centroid along the pattern axis, per frame
    (:func:`~cortex_ti.surface.measures.volume_centroid` of each frame's triangles): how far a cell
    in a fluid has moved."""
    axis = np.asarray(tr.settings.pattern_axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return np.array([volume_centroid(*tr.mesh(k)) @ axis for k in range(tr.ds.sizes["time"])])


_CENTROID_ATTRS = {
    "centroid_axial": {
        "units": "R0",
        "long_name": "volume centroid along the pattern axis",
        "description": "the centroid of the volume the frame's triangles enclose (surface.measures.volume_centroid), "
        "projected on the pattern axis",
    }
}


#: The degrees of the myosin whose amplitude a self_organisation store keeps per frame.
MYOSIN_LMAX = 6


def myosin_series(tr: Trajectory, lmax: int = MYOSIN_LMAX) -> dict[str, np.ndarray]:
    """The amplitude ``sqrt(sum_m c_lm^2)`` of every degree ``l <= lmax`` of the myosin, per frame
    ``(time, l)`` (:func:`cortex_ti.analysis.harmonics.degree_amplitudes`, directions from the
    area centroid); empty for a trajectory without myosin."""
    from ..analysis.harmonics import degree_amplitudes

    if "myosin" not in tr.ds:
        return {}
    frames = range(tr.ds.sizes["time"])
    if tr.remeshed:
        out = [degree_amplitudes(*tr.mesh(k), tr.nodal("myosin", k), lmax) for k in frames]
    else:  # one mesh: read every frame at once (a lazy file read frame by frame costs more than the fits)
        points, myosin, triangles = tr.ds["points"].values, tr.ds["myosin"].values, tr.triangles
        out = [degree_amplitudes(points[k], triangles, myosin[k], lmax) for k in frames]
    return {"myosin_amplitude": np.array(out)}


_MYOSIN_ATTRS = {
    "myosin_amplitude": {
        "units": "c0 units",
        "long_name": "amplitude of each degree of the myosin",
        "description": "sqrt(sum_m c_lm^2) of the weighted least-squares expansion of the nodal myosin in the real "
        "orthonormal harmonics of the directions from the area centroid (analysis.harmonics)",
    }
}

_FOLD_ATTRS = {
    "radius_stripe": {
        "units": "R0",
        "long_name": "equatorial radius across the stripe",
        "description": "half the width of the surface along the stripe's direction e2 (diagnostics.fold_radii)",
    },
    "radius_off_stripe": {
        "units": "R0",
        "long_name": "equatorial radius beside the stripe",
        "description": "half the width of the surface along e1, 90 degrees from the stripe",
    },
    "fold_depth": {
        "units": "R0",
        "long_name": "fold depth",
        "description": "radius beside the stripe minus radius across it",
    },
}


def study_dataset(study: str, rows: Sequence[Mapping], paths: Sequence) -> xr.Dataset:
    """``(run, time)`` store of one study from its table rows and trajectory files (same order)."""
    if len(rows) != len(paths):
        raise ValueError(f"{len(rows)} rows but {len(paths)} trajectory files")
    if study not in STUDIES or not STUDIES[study].has_store:
        known = ", ".join(name for name, s in STUDIES.items() if s.has_store)
        raise ValueError(f"unknown study {study!r}; the studies with a store: {known}")
    series, times, attrs = [], [], {}
    for path in paths:
        with Trajectory(path, lazy=True) as tr:
            ds = tr.ds
            t = np.round(ds["time"].values.astype(float), _TIME_DECIMALS)
            data = {}
            for name in STUDIES[study].variables:
                if name in ds:
                    data[name] = ds[name].values.astype(float)
                    attrs[name] = {
                        k: v for k, v in ds[name].attrs.items() if k in ("units", "long_name", "description")
                    }
            if study == "fold":
                data.update(fold_series(tr))
                attrs.update(_FOLD_ATTRS)
            if study == "self_organisation":
                data.update(myosin_series(tr))
                attrs.update(_MYOSIN_ATTRS)
            if study == "fluids":
                data["centroid_axial"] = centroid_series(tr)
                attrs.update(_CENTROID_ATTRS)
            if study == "cytokinesis":
                data.update(division_series(tr))
                attrs.update(_DIVISION_ATTRS)
            if study in ("constriction", "cytokinesis") and "neck_radius" not in data:
                data["neck_radius"] = neck_series(tr)
                attrs.update(NECK_ATTRS)
            if "volume" in data:
                data["volume_change"] = data["volume"] / data["volume"][0] - 1.0
        times.append(t)
        series.append((t, data))
    attrs["volume_change"] = {
        "units": "1",
        "long_name": "relative change of the enclosed volume",
        "description": "V(t)/V(0) - 1",
    }
    grid = np.unique(np.concatenate(times)) if times else np.zeros(0)
    names = sorted({k for _, d in series for k in d})
    out = {}
    for name in names:
        extra = next(d[name].shape[1:] for _, d in series if name in d)  # (l,) for myosin_amplitude
        arr = np.full((len(series), grid.size, *extra), np.nan)
        for i, (t, d) in enumerate(series):
            if name in d:
                arr[i, np.searchsorted(grid, t)] = d[name]
        dims = ("run", "time", "l")[: 2 + len(extra)]
        out[name] = (dims, arr, attrs.get(name, DIAGNOSTIC_ATTRS.get(name, {})))
    coords = {
        "time": ("time", grid, {"units": "t_a", "long_name": "time"}),
        "run": ("run", np.arange(len(rows)), {"long_name": "run index (parameters are coordinates along run)"}),
    }
    if any(len(v[0]) == 3 for v in out.values()):
        n_deg = next(v[1].shape[2] for v in out.values() if len(v[0]) == 3)
        coords["l"] = ("l", np.arange(n_deg), {"long_name": "spherical-harmonic degree"})
    for col in rows[0].keys() if rows else []:
        values = [_number(r[col]) for r in rows]
        if all(isinstance(v, (int, float)) for v in values):
            values = np.asarray(values)
        elif all(isinstance(v, (int, float)) or v == "null" for v in values) and col in PATTERN_COLUMNS:
            # a pattern column of a scene without a pattern (a myosin ring) is null: nan keeps it numeric
            values = np.asarray([math.nan if v == "null" else float(v) for v in values])
        else:
            values = np.asarray([str(v) for v in values], dtype=object)
        coords[col] = ("run", values, {"long_name": f"sweep parameter {col}"})
    coords["label"] = ("run", np.asarray([run_label(r) for r in rows], dtype=object), {"long_name": "run label"})
    return xr.Dataset(
        out,
        coords=coords,
        attrs={
            "description": STUDIES[study].description,
            "study": study,
            "units": "lengths R0, times t_a = eta_s / zeta_0",
            **provenance(),
        },
    )


_COST_ATTRS = {
    "wall_s": ("s", "wall time of the job", "Snakemake benchmark 's': the whole process, start-up included"),
    "max_rss_mb": ("MB", "peak resident memory", "Snakemake benchmark 'max_rss'"),
    "cpu_time_s": ("s", "CPU time of the job", "Snakemake benchmark 'cpu_time'"),
    "steps": ("1", "time steps taken", "accepted steps of the time integration (0 for a static solve)"),
    "solves": ("1", "force-balance solves", "geometry + assembly + sparse solve, rejected steps included"),
    "ms_per_step": ("ms", "wall time per step", "run wall time (cortex-ti's own) divided by the steps"),
    "ms_geometry_per_solve": ("ms", "geometry per solve", "local frames and parabolic fits"),
    "ms_assembly_per_solve": ("ms", "assembly per solve", "building the formulation's sparse system"),
    "ms_solve_per_solve": ("ms", "sparse solve per solve", "factorisation and solve of the constrained system"),
    "t_reached": ("t_a", "time reached", "end time of the run (earlier than t_end if it failed or became steady)"),
    "error": (
        "R0",
        "error of the radii against the axisymmetric solution of the same scene",
        "largest |3D - axisymmetric| of pole and furrow radius over the run's frames, against its axisymmetric "
        "twin (model: axisymmetric, the scene's own bending viscosity; NaN without one or if the run failed)",
    ),
    "error_external": (
        "R0",
        "deviation of the radii from the external reference run",
        "largest |run - reference| of pole and furrow radius on the reference's 0.01 t_a grid, for runs "
        "of the reference's problem (p = 8, zeta_hat = 1; the reference has no bending viscosity)",
    ),
}


def cost_dataset(entries: Sequence[Mapping]) -> xr.Dataset:
    """One row per run: ``entries`` are dicts with ``study``, ``run`` (label), ``benchmark`` (path),
    ``summary`` (path or None) and optionally ``params`` (the sweep row) and ``error`` (float)."""
    n = len(entries)
    data = {k: np.full(n, np.nan) for k in _COST_ATTRS}
    status, studies, labels, nodes, scheme, fit, dt, tol = ([] for _ in range(8))
    implicit, residual, model, formulation = ([] for _ in range(4))
    for i, e in enumerate(entries):
        b = read_benchmark(e["benchmark"])
        data["wall_s"][i] = b.get("s", np.nan)
        data["max_rss_mb"][i] = b.get("max_rss", np.nan)
        data["cpu_time_s"][i] = b.get("cpu_time", np.nan)
        s = json.loads(Path(e["summary"]).read_text()) if e.get("summary") else {}
        for k in (
            "steps",
            "solves",
            "ms_geometry_per_solve",
            "ms_assembly_per_solve",
            "ms_solve_per_solve",
            "t_reached",
        ):
            if s.get(k) is not None:
                data[k][i] = float(s[k])
        if s.get("steps"):
            data["ms_per_step"][i] = 1e3 * float(s["wall_s"]) / float(s["steps"])
        data["error"][i] = float(e.get("error", np.nan))
        data["error_external"][i] = float(e.get("error_external", np.nan))
        status.append(s.get("status", "ok") if s else "ok")
        model.append(str(s.get("model", "3d")))
        # a summary written before numerics.formulation existed is the paper's formulation's
        formulation.append(
            "-"
            if s.get("model") == "axisymmetric"
            else str(s.get("formulation", e.get("params", {}).get("formulation", "paper")))
        )
        studies.append(e["study"])
        labels.append(e["run"])
        p = e.get("params", {})
        nodes.append(int(float(p.get("nodes", s.get("n_nodes", -1)))))
        scheme.append(str(p.get("scheme", "static" if s.get("stopped") == "static" else "")))
        fit.append(str(p.get("fit", s.get("fit", ""))))
        dt.append(float(p.get("dt", np.nan)))
        tol.append(float(p.get("tol", np.nan)))
        implicit.append(bool(s.get("implicit_tension", str(p.get("implicit", "false")) == "true")))
        residual.append(float(s.get("fit_residual_weight", p.get("residual", 0.0)) or 0.0))
    variables = {
        k: (("run",), v, {"units": u, "long_name": ln, "description": d})
        for k, v in data.items()
        for u, ln, d in [_COST_ATTRS[k]]
    }
    obj = lambda xs: np.asarray(xs, dtype=object)  # noqa: E731
    coords = {
        "run": ("run", obj(labels), {"long_name": "study and parameters of the run"}),
        "study": ("run", obj(studies)),
        "status": ("run", obj(status), {"long_name": "ok or failed (with why in the summary)"}),
        "nodes": ("run", np.asarray(nodes)),
        "scheme": ("run", obj(scheme)),
        "fit": ("run", obj(fit)),
        "dt": ("run", np.asarray(dt), {"units": "t_a", "long_name": "(first) time step"}),
        "tol": ("run", np.asarray(tol), {"units": "R0", "long_name": "local error per step of an adaptive scheme"}),
        "implicit_tension": (
            "run",
            np.asarray(implicit, dtype=bool),
            {"long_name": "semi-implicit active tension (time.implicit_tension)"},
        ),
        "model": ("run", obj(model), {"long_name": "3d or axisymmetric"}),
        "formulation": (
            "run",
            obj(formulation),
            {
                "long_name": "discretisation of the 3D force balance (numerics.formulation; - for "
                "the axisymmetric model)"
            },
        ),
        "fit_residual_weight": (
            "run",
            np.asarray(residual),
            {"long_name": "weight of the fit-residual rows (numerics.fit_residual_weight)"},
        ),
    }
    return xr.Dataset(
        variables,
        coords=coords,
        attrs={
            "description": "What every run of the workflow cost: wall time and peak memory from "
            "Snakemake's benchmark files, steps and time per stage from cortex-ti's "
            "run summaries; error against the axisymmetric reference where one exists.",
            **provenance(),
        },
    )


def trajectory_deviation(path, ref_path=None) -> dict[str, float] | None:
    """:func:`radii_deviation` of a trajectory file, or None if its scene is not the reference's."""
    with Trajectory(path, lazy=True) as tr:
        if not reference.matches_reference(tr.settings):
            return None
        ds = tr.ds
        return reference.radii_deviation(
            ds["time"].values, ds["pole_radius"].values, ds["furrow_radius"].values, ref_path
        )


def twin_deviation(path, twin_path) -> dict[str, float]:
    """Largest ``|3D - axisymmetric|`` of pole and furrow radius over the frames of a run, against
    its axisymmetric twin (the same scene solved with ``model: axisymmetric``; its frames
    interpolated in time, linearly, to the run's frame times up to the twin's end)."""
    with Trajectory(path, lazy=True) as run, Trajectory(twin_path, lazy=True) as twin:
        t, ta = run.times, twin.times
        ok = t <= ta[-1] + 1e-9
        out = {}
        for name in ("pole_radius", "furrow_radius"):
            d = np.abs(run.ds[name].values[ok] - np.interp(t[ok], ta, twin.ds[name].values))
            out[name.split("_")[0]] = float(np.max(d)) if d.size else float("nan")
            out["t_" + name.split("_")[0]] = float(t[ok][np.argmax(d)]) if d.size else float("nan")
        out["frames"] = int(ok.sum())
        return out
