"""The workflow's figures of the myosin self-organisation study: the growth rates against the
linear stability, the onset of the instability and the ring (drawn by name through
:func:`cortex_ti.studies.figures.draw_figure`).
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from .constriction import constriction_figure  # noqa: F401  (issue 18's figure, drawn by name)


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
