"""The ``constriction`` study (issue 18): deep rings, the neck radius over time and whether the furrow
closes or arrests, read from the study's store (``results/aggregate/constriction.nc``).

A run's *outcome* (:func:`outcome`): ``closed`` when it ended before its ``t_end`` (the
axisymmetric model stops cleanly at its ``stop_neck``); ``arrested`` when the neck's rate over its
last frames is below :data:`ARREST_RATE`; ``closing`` otherwise (undecided at ``t_end``). The
*threshold* (:func:`threshold`) lies between the largest ring-to-pole tension ratio
``1 + zeta_hat`` whose axisymmetric run arrests and the smallest whose run closes (same ``p``).
Rings with bending rigidity (the ``bending`` column, kappa > 0) are kept apart from the threshold,
which is that of the rings without it; :func:`rigidity_map` lists how each rigid ring ended.
The axisymmetric runs' frames whose label map their points do not resolve (``label_resolved``: past
:data:`~cortex_ti.axisymmetric.evolve.STRETCH_LIMIT` of material stretch for arc-length points, a
folded map for the adaptive ones) are drawn dotted and excluded from the 3D comparison.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import xarray as xr
from matplotlib.figure import Figure

__all__ = [
    "ARREST_RATE",
    "neck",
    "neck_or_furrow",
    "outcome",
    "threshold",
    "constriction_figure",
    "constriction_numbers",
    "bending",
    "rigidity_map",
]

#: |d neck / dt| (R0/t_a) over the last frames below which a run counts as arrested
#: (docs/validation/constriction.md: arrested runs end at 1e-6 or slower, closing ones at 3e-4 or faster)
ARREST_RATE = 1e-4


def neck(ds: xr.Dataset, i: int) -> np.ndarray:
    """Run ``i``'s neck radius per frame: ``neck_radius`` (the narrowest section) where the shape has
    one, and before it forms (a shallow furrow leaves the section radius largest in the ring's
    plane) the ring plane's ``furrow_radius``, which it then equals for a symmetric ring. A store
    written before ``neck_radius`` existed: ``furrow_radius`` throughout, which leaves the neck
    once one lobe outgrows the other."""
    furrow = ds["furrow_radius"].values[i]
    if "neck_radius" not in ds:
        return furrow
    return neck_or_furrow(ds["neck_radius"].values[i], furrow)


def neck_or_furrow(neck_radius: np.ndarray, furrow_radius: np.ndarray) -> np.ndarray:
    """Per frame, the neck radius where the shape has a neck (finite), else the ring plane's
    furrow radius (:func:`neck`)."""
    return np.where(np.isfinite(neck_radius), neck_radius, furrow_radius)


def _series(ds: xr.Dataset, i: int, name: str = "neck"):
    """Run ``i``'s finite values of ``name`` (``neck``: :func:`neck`) and their times."""
    v = neck(ds, i) if name == "neck" else ds[name].values[i]
    ok = np.isfinite(v)
    return ds["time"].values[ok], v[ok]


def outcome(ds: xr.Dataset, i: int) -> str:
    """How run ``i`` ended: ``closed``, ``arrested`` or ``closing`` (module docstring)."""
    t, neck = _series(ds, i)
    if t[-1] < float(ds["t_end"].values[i]) - 1e-9:
        return "closed"
    if t.size < 2:
        return "closing"
    rate = (neck[-1] - neck[-2]) / (t[-1] - t[-2])
    return "arrested" if abs(rate) < ARREST_RATE else "closing"


def _unresolved_time(ds: xr.Dataset, i: int) -> float:
    """The first time run ``i``'s label map is not resolved (inf: never, or a 3D run): where its
    ``label_resolved`` turns 0 (the run judged it by its parametrisation's limit), in a store
    written before that variable where its material stretch passes the arc-length points' limit."""
    if "label_resolved" in ds and np.isfinite(ds["label_resolved"].values[i]).any():
        t, ok = _series(ds, i, "label_resolved")
        bad = np.flatnonzero(ok < 0.5)
        return float(t[bad[0]]) if bad.size else math.inf
    if "material_stretch" not in ds:
        return math.inf
    from ..axisymmetric.dynamics import first_unresolved  # here: every figure job imports this module

    t, s = _series(ds, i, "material_stretch")
    k = first_unresolved(s) if s.size else None
    return math.inf if k is None else float(t[k])


def _axisymmetric(ds: xr.Dataset) -> list[int]:
    return [i for i in range(ds.sizes["run"]) if str(ds["model"].values[i]) == "axisymmetric"]


def _prescribed(ds: xr.Dataset, i: int) -> bool:
    """Whether run ``i``'s ring is prescribed (a pattern with ``zeta_hat`` and ``p``), not a myosin
    ring that forms by itself (its pattern columns are nan)."""
    return math.isfinite(float(ds["zeta_hat"].values[i])) and math.isfinite(float(ds["p"].values[i]))


def bending(ds: xr.Dataset, i: int) -> float:
    """Run ``i``'s bending rigidity kappa (the ``bending`` column; 0 in a store written before it)."""
    if "bending" not in ds.coords and "bending" not in ds:
        return 0.0
    value = float(ds["bending"].values[i])
    return value if math.isfinite(value) else 0.0


def _ring(ds: xr.Dataset, i: int) -> tuple:
    """What makes two runs the same ring: the scene, the pattern's ``zeta_hat`` and ``p`` (None
    for a scene without one, so that two such runs compare equal) and the rigidity."""
    if not _prescribed(ds, i):
        return (str(ds["scene"].values[i]), None, None, bending(ds, i))
    return (str(ds["scene"].values[i]), float(ds["zeta_hat"].values[i]), float(ds["p"].values[i]), bending(ds, i))


def threshold(ds: xr.Dataset) -> dict[float, tuple[float, float]]:
    """Per ``p``: (the largest ratio 1 + zeta_hat that arrests, the smallest that closes) among the
    axisymmetric runs of prescribed rings without rigidity (nan where the sweep has none; the rigid
    rings are :func:`rigidity_map`'s)."""
    out = {}
    prescribed = [i for i in _axisymmetric(ds) if _prescribed(ds, i) and bending(ds, i) == 0.0]
    for p in sorted({float(ds["p"].values[i]) for i in prescribed}):
        runs = [i for i in prescribed if float(ds["p"].values[i]) == p]
        ratio = {i: 1.0 + float(ds["zeta_hat"].values[i]) for i in runs}
        arrested = [ratio[i] for i in runs if outcome(ds, i) == "arrested"]
        closed = [ratio[i] for i in runs if outcome(ds, i) == "closed"]
        out[p] = (max(arrested, default=math.nan), min(closed, default=math.nan))
    return out


def _twin(ds: xr.Dataset, i: int) -> int | None:
    """The axisymmetric run of the same ring as 3D run ``i`` (the longest one), if any."""
    same = [j for j in _axisymmetric(ds) if _ring(ds, j) == _ring(ds, i)]
    return max(same, key=lambda j: float(ds["t_end"].values[j]), default=None)


def deviation(ds: xr.Dataset, i: int) -> tuple[float, float]:
    """(largest |3D - axisymmetric| neck radius over the frames both have while the twin is
    resolved, the time up to which that is measured); nan without a twin."""
    j = _twin(ds, i)
    if j is None:
        return math.nan, math.nan
    t, v = _series(ds, i)
    ta, va = _series(ds, j)
    end = min(t[-1], ta[-1], _unresolved_time(ds, j))
    keep = t <= end + 1e-9
    return float(np.max(np.abs(v[keep] - np.interp(t[keep], ta, va)))), float(end)


def constriction_figure(ds: xr.Dataset) -> Figure:
    """Neck radius against time (axisymmetric lines, dotted past the stretch limit; 3D dots) of the
    prescribed rings, and of the myosin rings that form by themselves in a panel of their own (they
    take ten times longer), and the neck at the end of each axisymmetric run against the
    ring-to-pole ratio, with the threshold."""
    own = [i for i in range(ds.sizes["run"]) if not _prescribed(ds, i)]
    fig = Figure(figsize=(15 if own else 10, 3.8), layout="constrained")
    axes = fig.subplots(1, 3 if own else 2)
    a0, a1 = axes[0], axes[-1]
    rings = sorted({_ring(ds, i) for i in range(ds.sizes["run"])}, key=str)
    colour = {r: f"C{k % 10}" for k, r in enumerate(rings)}
    marker_of: dict[int, str] = {}
    labels: set[str] = set()

    def once(label: str) -> str | None:
        """The label the first time (a ring run to two end times is one entry of the legend)."""
        seen, _ = label in labels, labels.add(label)
        return None if seen else label

    for i in range(ds.sizes["run"]):
        ax = axes[1] if i in own else a0
        ring = _ring(ds, i)
        name = f"1 + $\\hat\\zeta$ = {1 + ring[1]:g}" if ring[1] is not None else ring[0]
        if ring[3]:
            name += f", $\\kappa$ = {ring[3]:g}"
        t, v = _series(ds, i)
        if str(ds["model"].values[i]) == "axisymmetric":
            tu = _unresolved_time(ds, i)
            ok = t <= tu
            ax.plot(t[ok], v[ok], "-", color=colour[ring], lw=1.2, label=once(f"axisymmetric, {name}"))
            ax.plot(t[t >= tu], v[t >= tu], ":", color=colour[ring], lw=1.2)
        else:
            every = max(1, t.size // 40)
            n = int(ds["nodes"].values[i])
            marker = marker_of.setdefault(n, "osD^v"[len(marker_of) % 5])
            ax.plot(t[::every], v[::every], marker, ms=3, mfc="none", color=colour[ring], label=once(f"3D N={n}"))
    three_d = [float(ds["t_end"].values[i]) for i in range(ds.sizes["run"]) if i not in own + _axisymmetric(ds)]
    if three_d:  # the axisymmetric threshold runs go on much longer: show the 3D runs' span
        a0.set_xlim(0.0, max(three_d))
    for ax in axes[:-1]:  # the neck against time: the prescribed rings, and the myosin rings if any
        ax.set_xlabel(r"$t / t_a$")
        ax.set_ylabel(r"neck radius / $R_0$")
        ax.set_ylim(0.0, 1.05)
        ax.legend(fontsize=6)
    a0.set_title("prescribed rings", fontsize=9)
    if own:
        axes[1].set_title("myosin rings that form by themselves", fontsize=9)
    style = {
        "closed": ("v", "closed (0.1 $R_0$)"),
        "arrested": ("s", "arrested"),
        "closing": ("o", "still closing at the end"),
    }
    seen = set()
    longest = {}  # per ring, its longest axisymmetric run
    for i in _axisymmetric(ds):
        if not _prescribed(ds, i) or bending(ds, i):
            continue
        key = _ring(ds, i)
        if key not in longest or float(ds["t_end"].values[i]) > float(ds["t_end"].values[longest[key]]):
            longest[key] = i
    for i in longest.values():
        kind = outcome(ds, i)
        _, v = _series(ds, i)
        marker, label = style[kind]
        a1.plot(1.0 + float(ds["zeta_hat"].values[i]), v[-1], marker, color="k", label=None if kind in seen else label)
        seen.add(kind)
    kappas = sorted({row[0] for row in rigidity_map(ds)})
    for kappa, ratio, kind, end in rigidity_map(ds):  # the rigid rings, coloured by kappa
        k = kappas.index(kappa)
        a1.plot(ratio, end, style[kind][0], color=f"C{k % 10}", mfc="none", label=once(f"$\\kappa$ = {kappa:g}"))
    for p, (lo, hi) in threshold(ds).items():
        if math.isfinite(lo) and math.isfinite(hi):
            a1.axvspan(lo, hi, color="0.85", label=f"threshold, p = {p:g}: ({lo:g}, {hi:g}]")
    a1.set_xlabel(r"ring-to-pole tension ratio $1 + \hat\zeta$")
    a1.set_ylabel(r"neck radius at the end / $R_0$")
    a1.legend(fontsize=7)
    return fig


def rigidity_map(ds: xr.Dataset) -> list[tuple[float, float, str, float]]:
    """(kappa, ratio 1 + zeta_hat, outcome, neck at the end) of the longest axisymmetric run of each
    prescribed ring with rigidity (kappa > 0), sorted: which rings close against the bending number."""
    longest = {}
    for i in _axisymmetric(ds):
        if _prescribed(ds, i) and bending(ds, i) > 0.0:
            key = _ring(ds, i)
            if key not in longest or float(ds["t_end"].values[i]) > float(ds["t_end"].values[longest[key]]):
                longest[key] = i
    rows = [
        (bending(ds, i), 1.0 + float(ds["zeta_hat"].values[i]), outcome(ds, i), float(_series(ds, i)[1][-1]))
        for i in longest.values()
    ]
    return sorted(rows)


def constriction_numbers(stores) -> pd.DataFrame:
    """Per run: how it ended, its neck at the end, where its material stretch passed the limit,
    and for a 3D run its largest deviation from the axisymmetric twin; then the threshold."""
    ds = stores[0]
    rows = []
    for i in range(ds.sizes["run"]):
        t, v = _series(ds, i)
        row = {
            "run": str(ds["label"].values[i]),
            "ratio 1 + zeta_hat": f"{1.0 + float(ds['zeta_hat'].values[i]):g}" if _prescribed(ds, i) else "myosin",
            "kappa": f"{bending(ds, i):g}",
            "t reached": f"{t[-1]:.4g}",
            "neck at the end": f"{v[-1]:.5f}",
            "outcome": outcome(ds, i),
            "label map unresolved from t": f"{_unresolved_time(ds, i):.3g}",
        }
        if str(ds["model"].values[i]) != "axisymmetric":
            dev, until = deviation(ds, i)
            row["max |3D - axisymmetric| neck"] = f"{dev:.2e} (to t = {until:.3g})"
            row["smallest angle (deg)"] = f"{np.nanmin(ds['min_angle_deg'].values[i]):.1f}"
            row["volume drift"] = f"{np.nanmax(np.abs(ds['volume_change'].values[i])):.1e}"
        rows.append(row)
    for p, (lo, hi) in threshold(ds).items():
        bracket = f"({lo:g}, {hi:g}]" if math.isfinite(lo) and math.isfinite(hi) else "not bracketed by these runs"
        rows.append({"run": f"threshold, p = {p:g}", "ratio 1 + zeta_hat": bracket})
    return pd.DataFrame(rows)
