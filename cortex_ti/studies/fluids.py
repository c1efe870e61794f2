"""The ``fluids`` study (issue 36): the cell in a fluid, over the hydrodynamic length, read from the
study's store (``results/aggregate/fluids.nc``).

Runs of ``furrow_in_fluid`` (the paper's furrow with a cytoplasm and a medium) and
``polarised_swimmer`` (a tension with a polarity mode: the cell swims) with the fluids' viscosities
``inner`` and ``outer`` swept, in 3D and in the axisymmetric model (the truth). The hydrodynamic length
``eta_s / mu`` (:func:`hydrodynamic_length`, in R0) is that of the medium. Read from each run:

* the furrow's *depth* ``R_f(0) - R_f(t_end)`` and its *half time*, when the furrow radius first
  reached half of that depth (linear between frames): how far and how fast the ring pulls in;
* the swimmer's *speed* (:func:`swim_speed`): the slope of the volume centroid's position along the
  pattern axis (``centroid_axial``, written by the store) over the second half of the run, fitted by
  least squares; beside it Lamb's speed of the sphere at t = 0 (:func:`lamb_speed`, the degree-1 flow
  of the tension ``coeff Y_10``), which a steadily translating sphere keeps.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pandas as pd
import xarray as xr
from matplotlib.figure import Figure

__all__ = [
    "hydrodynamic_length",
    "depth",
    "half_time",
    "swim_speed",
    "lamb_speed",
    "swimmer_drive",
    "fluids_figure",
    "fluids_numbers",
]

FURROW, SWIMMER = "furrow_in_fluid", "polarised_swimmer"


def hydrodynamic_length(ds: xr.Dataset, i: int) -> float:
    """``eta_s / mu_out`` in R0 (the scenes' ``eta_s`` is 1): the medium's hydrodynamic length."""
    return 1.0 / float(ds["outer"].values[i])


def _series(ds: xr.Dataset, i: int, name: str) -> tuple[np.ndarray, np.ndarray]:
    """The run's frames of ``name`` (the store's time grid where the run has them)."""
    v = np.asarray(ds[name].values[i], dtype=float)
    ok = np.isfinite(v)
    return np.asarray(ds["time"].values, dtype=float)[ok], v[ok]


def depth(ds: xr.Dataset, i: int) -> float:
    """``R_f(0) - R_f(end)``: how far the furrow pulled in (R0)."""
    _, r = _series(ds, i, "furrow_radius")
    return float(r[0] - r[-1]) if r.size else math.nan


def half_time(ds: xr.Dataset, i: int) -> float:
    """When the furrow radius first fell by half of the run's depth (linear between frames; t_a)."""
    t, r = _series(ds, i, "furrow_radius")
    if r.size < 2 or not r[0] > r[-1]:
        return math.nan
    target = r[0] - 0.5 * (r[0] - r[-1])
    k = int(np.argmax(r <= target))
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (r[k - 1] - target) / (r[k - 1] - r[k]) * (t[k] - t[k - 1]))


def swim_speed(ds: xr.Dataset, i: int) -> float:
    """The least-squares slope of ``centroid_axial`` over the second half of the run (R0 / t_a):
    negative when the cell moves against the pattern axis."""
    t, z = _series(ds, i, "centroid_axial")
    late = t >= 0.5 * t[-1] if t.size else t
    if late.sum() < 2:
        return math.nan
    return float(np.polyfit(t[late], z[late], 1)[0])


def lamb_speed(mu_in: float, mu_out: float, coeff: float = 0.5, eta_s: float = 1.0, eta_b: float = 1.0) -> float:
    """The translation speed of a spherical cortex (R0 = 1) driven by the tension ``coeff Y_10``
    between fluids ``mu_in`` and ``mu_out`` (:func:`cortex_ti.truth.fluid_sphere.flow_coefficients`:
    Lamb's degree-1 flow; ``Y_10 = sqrt(3 / 4 pi) cos theta``)."""
    from ..truth.fluid_sphere import flow_coefficients

    _, beta = flow_coefficients(1, mu_in=mu_in, mu_out=mu_out, eta_s=eta_s, eta_b=eta_b)
    return coeff * beta * math.sqrt(3.0 / (4.0 * math.pi))


@functools.cache
def swimmer_drive(scene: str) -> dict:
    """The keywords of :func:`lamb_speed` that a scene sets: the degree-1 part of its active tension
    about its pattern axis, ``coeff = int zeta Y_10 dOmega`` on the unit sphere (by the patterns'
    quadrature, so any pattern list, not only a ``coeff Y_10`` term), and the cortex's viscosities."""
    from ..physics.patterns import integrate_patterns
    from ..scene import load_scene

    s = load_scene(scene).settings
    axis = s.pattern_axis
    y10 = math.sqrt(3.0 / (4.0 * math.pi))
    coeff = float(integrate_patterns(list(s.patterns), weight=lambda pts: y10 * (np.asarray(pts) @ axis)))
    return {"coeff": coeff, "eta_s": s.viscosity.shear, "eta_b": s.viscosity.bulk}


def _runs(ds: xr.Dataset, scene: str, model: str | None = None) -> list[int]:
    out = [i for i in range(ds.sizes["run"]) if str(ds["scene"].values[i]) == scene]
    if model is not None:
        out = [i for i in out if str(ds["model"].values[i]) == model]
    return sorted(out, key=lambda i: hydrodynamic_length(ds, i))


def _label(ds: xr.Dataset, i: int) -> str:
    ell = hydrodynamic_length(ds, i)
    inner = float(ds["inner"].values[i])
    contrast = "" if inner == float(ds["outer"].values[i]) else f", $\\mu_{{in}}$ = {inner:g}"
    return f"$\\ell$ = {ell:g}{contrast}"


def fluids_figure(ds: xr.Dataset) -> Figure:
    """Left: the furrow radius of ``furrow_in_fluid`` against time, one colour per hydrodynamic length
    (lines: the axisymmetric model; markers: 3D). Middle: the furrow's depth at the end and its half
    time against the hydrodynamic length. Right: the swimmer's speed against it, with Lamb's."""
    fig = Figure(figsize=(13.5, 4.0), layout="constrained")
    a0, a1, a2 = fig.subplots(1, 3)
    lengths = sorted({hydrodynamic_length(ds, i) for i in range(ds.sizes["run"])})
    colour = {ell: f"C{k % 10}" for k, ell in enumerate(lengths)}
    seen = set()
    for i in _runs(ds, FURROW):
        t, r = _series(ds, i, "furrow_radius")
        ell = hydrodynamic_length(ds, i)
        if str(ds["model"].values[i]) == "axisymmetric":
            a0.plot(t, r, "-", color=colour[ell], lw=1.2, label=f"axisymmetric, {_label(ds, i)}")
        else:
            every = max(1, t.size // 30)
            n = int(ds["nodes"].values[i])
            label = f"3D N={n}" if n not in seen else None
            seen.add(n)
            a0.plot(t[::every], r[::every], "o", ms=3, mfc="none", color=colour[ell], label=label)
    a0.set_xlabel(r"$t / t_a$")
    a0.set_ylabel(r"furrow radius / $R_0$")
    a0.set_title(FURROW, fontsize=9)
    a0.legend(fontsize=6)
    twin = a1.twinx()
    for model, style in (("axisymmetric", "-"), ("3d", "o")):
        runs = _runs(ds, FURROW, model)
        if not runs:
            continue
        ell = [hydrodynamic_length(ds, i) for i in runs]
        a1.plot(ell, [depth(ds, i) for i in runs], style, color="C0", mfc="none", label=f"depth, {model}")
        twin.plot(ell, [half_time(ds, i) for i in runs], style, color="C3", mfc="none", label=f"half time, {model}")
    a1.set_xscale("log")
    a1.set_xlabel(r"hydrodynamic length $\ell = \eta_s / \mu$ / $R_0$")
    a1.set_ylabel(r"depth $R_f(0) - R_f(t_{end})$ / $R_0$", color="C0")
    twin.set_ylabel(r"half time / $t_a$", color="C3")
    lines = a1.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
    if lines:
        a1.legend(lines, [h.get_label() for h in lines], fontsize=6)
    for model, style in (("axisymmetric", "s"), ("3d", "o")):
        runs = _runs(ds, SWIMMER, model)
        if runs:
            ell = [hydrodynamic_length(ds, i) for i in runs]
            a2.plot(ell, [swim_speed(ds, i) for i in runs], style, mfc="none", label=f"{model} (centroid)")
    swimmers = _runs(ds, SWIMMER)
    if swimmers:
        grid = np.geomspace(min(lengths), max(lengths), 60) if len(lengths) > 1 else np.array(lengths)
        drive = swimmer_drive(SWIMMER)
        lamb = [lamb_speed(1.0 / g, 1.0 / g, **drive) for g in grid]
        a2.plot(grid, lamb, "k-", lw=0.8, label="Lamb, t = 0 (equal fluids)")
    a2.set_xscale("log")
    a2.set_xlabel(r"hydrodynamic length $\ell = \eta_s / \mu$ / $R_0$")
    a2.set_ylabel(r"swimming speed along the axis / ($R_0 / t_a$)")
    a2.set_title(SWIMMER, fontsize=9)
    a2.legend(fontsize=6)
    return fig


def fluids_numbers(stores) -> pd.DataFrame:
    """Per run: the hydrodynamic length, the furrow's depth and half time or the swimmer's speed
    (with Lamb's and, for a 3D run, its axisymmetric twin's of the same viscosities)."""
    ds = stores[0]
    rows = []
    for i in range(ds.sizes["run"]):
        scene, model = str(ds["scene"].values[i]), str(ds["model"].values[i])
        inner, outer = float(ds["inner"].values[i]), float(ds["outer"].values[i])
        row = {
            "run": str(ds["label"].values[i]),
            "scene": scene,
            "model": model,
            "ell = eta_s / mu_out": f"{1 / outer:g}",
        }
        twins = [
            j
            for j in _runs(ds, scene, "axisymmetric")
            if (float(ds["inner"].values[j]), float(ds["outer"].values[j])) == (inner, outer)
        ]
        if scene == FURROW:
            row["depth"] = f"{depth(ds, i):.5f}"
            row["half time"] = f"{half_time(ds, i):.4g}"
            if model != "axisymmetric" and twins:
                row["depth - twin's"] = f"{depth(ds, i) - depth(ds, twins[0]):+.2e}"
        elif scene == SWIMMER:
            speed = swim_speed(ds, i)
            row["speed"] = f"{speed:.6f}"
            row["Lamb at t = 0"] = f"{lamb_speed(inner, outer, **swimmer_drive(scene)):.6f}"
            if model != "axisymmetric" and twins:
                row["speed / twin's - 1"] = f"{speed / swim_speed(ds, twins[0]) - 1:+.2e}"
        rows.append(row)
    return pd.DataFrame(rows)
