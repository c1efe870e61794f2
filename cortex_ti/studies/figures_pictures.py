"""The workflow's 3D pictures: snapshots of runs (paper Figs. 9-12) and the flows on the sphere
(drawn by name through :func:`cortex_ti.studies.figures.draw_figure`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from ..io.trajectory import Trajectory, open_trajectory
from .constriction import constriction_figure  # noqa: F401  (issue 18's figure, drawn by name)


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
