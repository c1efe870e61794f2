"""Figures of one trajectory: a frame as a coloured 3D surface with velocity arrows, and the
per-frame diagnostics over time (matplotlib :class:`~matplotlib.figure.Figure` objects, no
pyplot: nothing here touches a global figure state or needs a display).

Public API
----------
:func:`plot_frame`
    one frame in 3D: the triangles coloured per face, arrows of the velocity.
:func:`plot_timeseries`
    per-frame scalar variables (``pole_radius``, ``furrow_radius``, ``orientation_angle``, ...)
    against time, one y axis per kind of unit.
:func:`figure_frame_and_series`
    both side by side, with the frame's time marked in the time series (``cortex-ti plot``).
:func:`save_figure`
    atomic save (temporary file in the target folder, then :func:`os.replace`); the format
    (png, pdf, svg) from the suffix.
:func:`frame_index`
    the rule that turns ``frame`` (an index or a time) into a frame index.

Every function takes an :class:`xarray.Dataset` as returned by
:func:`cortex_ti.io.open_trajectory` or :func:`cortex_ti.io.load_trajectory` (the latter also
reads the ``.partial`` file of a simulation that is still running).

Definitions
-----------
Per-face colour
    the mean of the face's three node values (``speed = |v|``, ``active_stress = zeta``, or
    ``normal_velocity = v . n``).
Normal at a node (``normal_velocity``)
    the solver's normal stored with the frame (``normal``: the normal of the fitted surface); in
    files without it, the area-weighted mean of the adjacent face normals
    (:func:`cortex_ti.surface.mesh.vertex_normals`), good enough for display.
Which nodes face the viewer
    by the area-weighted normals.
Arrows
    at the nodes on the visible side (node normal pointing towards the viewer, ``n . e > 0``
    with ``e`` the unit vector from the centre towards the eye for the view ``(elev, azim)``)
    that move (``|v| > 0``); at most ``max_arrows`` of them, an evenly spread subset chosen by
    greedy farthest-point sampling.  All arrows share one scale: the fastest node's arrow is
    12 % of the size of the shape.
"""

from __future__ import annotations

import os
import secrets
import warnings
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d import art3d  # also registers the "3d" projection

from ..errors import CortexError
from ..io.trajectory import frame_mesh
from ..surface.mesh import vertex_normals

__all__ = [
    "ARROW_FRACTION",
    "COLORS",
    "DEFAULT_SERIES",
    "DEFAULT_VIEW",
    "FORMATS",
    "MAX_ARROWS",
    "colorbar_below",
    "figure_format",
    "figure_frame_and_series",
    "frame_index",
    "node_values",
    "plot_frame",
    "plot_timeseries",
    "save_figure",
    "series_names",
    "spread_nodes",
    "view_direction",
]

#: Colour quantities: name -> (colorbar label, default colormap).
COLORS: dict[str, tuple[str, str]] = {
    "speed": ("speed |v| [R0/t_a]", "viridis"),
    "active_stress": ("active tension ζ [ζ0]", "plasma"),
    "normal_velocity": ("normal velocity v·n [R0/t_a]", "RdBu_r"),
}

#: Time series drawn when none are named.
DEFAULT_SERIES: tuple[str, ...] = ("pole_radius", "furrow_radius", "orientation_angle")

#: Default camera (elevation, azimuth) in degrees.
DEFAULT_VIEW: tuple[float, float] = (20.0, -60.0)

#: Figure formats :func:`save_figure` writes (from the file suffix).
FORMATS: tuple[str, ...] = ("png", "pdf", "svg")

#: Default largest number of velocity arrows.
MAX_ARROWS = 150

#: Length of the longest arrow as a fraction of the size of the shape.
ARROW_FRACTION = 0.12


# ---------------------------------------------------------------------------------------------
# selecting and evaluating a frame
# ---------------------------------------------------------------------------------------------
def _require(ds, names: Sequence[str]) -> None:
    missing = [n for n in names if n not in ds.variables]
    if missing:
        raise CortexError(f"not a cortex-ti trajectory: it has no {', '.join(missing)}")


def frame_index(ds, frame=-1) -> int:
    """The frame index that ``frame`` selects.

    Rule: an ``int`` (Python or numpy) is a frame index, negative ones counting from the end
    (``-1`` is the last frame); a ``float`` is a time, and the frame whose time is nearest to it
    is chosen (the earlier frame on a tie).  A time more than half the mean frame spacing
    outside the trajectory's time span is refused, so is an index out of range.

    Raises
    ------
    CortexError
        No frames, an index out of range, a time outside the trajectory, or a ``frame`` that is
        neither an integer nor a finite float.
    """
    _require(ds, ["time"])
    times = np.asarray(ds["time"].values, dtype=float)
    n = len(times)
    if n == 0:
        raise CortexError("the trajectory has no frames (yet)")
    if isinstance(frame, (bool, np.bool_)):
        raise CortexError(f"frame must be an integer index or a time, got {frame!r}")
    if isinstance(frame, (int, np.integer)):
        k = int(frame)
        if not -n <= k < n:
            raise CortexError(
                f"frame {k} is out of range: the trajectory has {n} frame(s) "
                f"(0..{n - 1}, or negative counting from the end)"
            )
        return k % n
    if isinstance(frame, (float, np.floating)):
        t = float(frame)
        if not np.isfinite(t):
            raise CortexError(f"time {frame!r} is not a finite number")
        spacing = (times[-1] - times[0]) / (n - 1) if n > 1 else 0.0
        tol = max(0.5 * spacing, 1e-9 * max(1.0, abs(t)))
        if t < times[0] - tol or t > times[-1] + tol:
            raise CortexError(
                f"time {t:g} is outside the trajectory: its {n} frame(s) span t = {times[0]:g} .. {times[-1]:g}"
            )
        return int(np.argmin(np.abs(times - t)))
    raise CortexError(f"frame must be an integer index or a time (float), got {type(frame).__name__} {frame!r}")


def node_values(ds, k: int, color: str) -> np.ndarray:
    """The per-node values of the colour quantity ``color`` (a key of :data:`COLORS`) at frame ``k``."""
    if color not in COLORS:
        raise CortexError(f"unknown colour {color!r}; choose one of: {', '.join(COLORS)}")
    pts, tri = frame_mesh(ds, k)  # a remeshed run's frame: its own nodes and triangles
    n = pts.shape[0]
    if color == "active_stress":
        _require(ds, ["active_stress"])
        return np.asarray(ds["active_stress"][k].values, dtype=float)[:n]
    _require(ds, ["velocity"])
    vel = np.asarray(ds["velocity"][k].values, dtype=float)[:n]
    if color == "speed":
        return np.linalg.norm(vel, axis=1)
    if "normal" in ds:  # the solver's normals, stored with each frame
        normals = np.asarray(ds["normal"][k].values, dtype=float)[:n]
    else:
        normals = vertex_normals(pts, np.asarray(tri, dtype=np.int64))
    return np.einsum("nc,nc->n", vel, normals)


def view_direction(elev: float, azim: float) -> np.ndarray:
    """Unit vector from the centre of a 3D axes towards its camera for ``view_init(elev, azim)``
    (degrees, z vertical)."""
    e, a = np.radians(float(elev)), np.radians(float(azim))
    return np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])


def spread_nodes(points: np.ndarray, candidates: np.ndarray, count: int, start: int) -> np.ndarray:
    """Greedy farthest-point subset of ``count`` of the ``candidates`` (node indices), starting
    from the node ``start`` (one of them); all of them if there are no more than ``count``."""
    if len(candidates) <= count:
        return candidates
    p = points[candidates]
    chosen = [int(np.flatnonzero(candidates == start)[0])]
    dist = np.linalg.norm(p - p[chosen[0]], axis=1)
    for _ in range(count - 1):
        j = int(np.argmax(dist))
        chosen.append(j)
        dist = np.minimum(dist, np.linalg.norm(p - p[j], axis=1))
    return np.sort(candidates[chosen])


# ---------------------------------------------------------------------------------------------
# the two panels
# ---------------------------------------------------------------------------------------------
def plot_frame(
    ds,
    frame=-1,
    color: str = "speed",
    arrows: bool = True,
    ax=None,
    view=None,
    cmap=None,
    clim=None,
    max_arrows: int = MAX_ARROWS,
    axes: bool = True,
):
    """Draw one frame: the surface coloured per face, velocity arrows on the visible side.

    Parameters
    ----------
    ds : xarray.Dataset
        A trajectory (``points``, ``velocity``, ``active_stress``, ``triangles``, ``time``).
    frame : int or float
        Frame index, or a time (nearest frame); see :func:`frame_index`.
    color : {"speed", "active_stress", "normal_velocity"}
        The node quantity whose per-face mean colours each triangle (see the module docstring).
    arrows : bool
        Draw velocity arrows (``ax.quiver``; its collection has the gid ``"velocity"``).
    ax : mpl_toolkits.mplot3d.Axes3D, optional
        Axes to draw in (``projection="3d"``); a new figure is made without one.  Its
        ``computed_zorder`` is switched off so that the arrows (all on the visible side) are
        drawn over the surface.
    view : (elev, azim), optional
        Camera angles in degrees; default: the axes' current view if ``ax`` is given, else
        :data:`DEFAULT_VIEW`.  The arrows are chosen for this view.
    cmap : str or Colormap, optional
        Default from :data:`COLORS` (a diverging map for ``normal_velocity``).
    clim : (vmin, vmax), optional
        Colour limits; default the range of the face values (symmetric about 0 for
        ``normal_velocity``).
    max_arrows : int
        Largest number of arrows.
    axes : bool
        Draw the axes (panes, ticks, labels in R0); ``False`` for the shape alone, as in small
        multiples of snapshots where the labels of neighbouring 3D panels would collide.

    Returns
    -------
    ax : Axes3D
    mappable : mpl_toolkits.mplot3d.art3d.Poly3DCollection
        The surface; ``mappable.get_array()`` holds the per-face values, and it can be passed
        to ``fig.colorbar`` (label: ``COLORS[color][0]``).
    """
    _require(ds, ["points", "triangles", "time"])
    if color not in COLORS:
        raise CortexError(f"unknown colour {color!r}; choose one of: {', '.join(COLORS)}")
    k = frame_index(ds, frame)
    pts, tri = frame_mesh(ds, k)
    tri = np.asarray(tri, dtype=np.int64)
    face_values = node_values(ds, k, color)[tri].mean(axis=1)
    ax = _axes_3d(ax, view)
    surface = _surface(ax, pts, tri, face_values, color, cmap, clim)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    centre, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo))
    if arrows:
        _velocity_arrows(ax, pts, tri, np.asarray(ds["velocity"][k].values, dtype=float)[: len(pts)], half, max_arrows)
    _frame_axes(ax, centre, half * (1.0 + 2.0 * ARROW_FRACTION if arrows else 1.02))
    if not axes:
        ax.set_axis_off()
        ax.set_box_aspect((1, 1, 1), zoom=1.4)  # the room of the labels goes to the shape
    ax.set_title(
        f"t = {float(ds['time'].values[k]):.4g} t_a  (frame {k}; frames 0..{ds.sizes['time'] - 1})", fontsize=9
    )
    return ax, surface


def _axes_3d(ax, view):
    """The 3D axes to draw in (a new figure's without one), turned to ``view``."""
    if ax is None:
        fig = Figure(figsize=(6.0, 5.5))
        ax = fig.add_subplot(projection="3d")
        view = DEFAULT_VIEW if view is None else view
    elif getattr(ax, "name", None) != "3d":
        raise ValueError("ax must be a 3D axes (add_subplot(..., projection='3d'))")
    if view is not None:
        try:
            elev, azim = (float(v) for v in view)
        except (TypeError, ValueError):
            raise CortexError(f"view must be (elevation, azimuth) in degrees, got {view!r}") from None
        ax.view_init(elev=elev, azim=azim)
    return ax


def _surface(ax, pts, tri, face_values, color, cmap, clim):
    """The triangles coloured per face (colour limits: ``clim``, or the values' range, symmetric
    about 0 for ``normal_velocity``)."""
    if clim is not None:
        vmin, vmax = (float(c) for c in clim)
    elif color == "normal_velocity":
        m = float(np.nanmax(np.abs(face_values))) if face_values.size else 0.0
        vmin, vmax = -m, m
    else:
        vmin, vmax = float(np.nanmin(face_values)), float(np.nanmax(face_values))
    surface = art3d.Poly3DCollection(
        pts[tri],
        cmap=cmap or COLORS[color][1],
        norm=Normalize(vmin, vmax),
        edgecolors=(0.0, 0.0, 0.0, 0.15),
        linewidths=0.2,
        zorder=1,
    )
    surface.set_array(face_values)
    ax.computed_zorder = False  # arrows (visible side only) are drawn over the surface
    ax.add_collection3d(surface)
    return surface


def _velocity_arrows(ax, pts, tri, vel, half, max_arrows) -> None:
    """Arrows at an evenly spread subset of the moving nodes on the visible side (module docstring)."""
    speed = np.linalg.norm(vel, axis=1)
    facing = vertex_normals(pts, tri) @ view_direction(ax.elev, ax.azim)
    candidates = np.flatnonzero((facing > 0.0) & (speed > 0.0))
    if not candidates.size:
        return
    start = int(candidates[np.argmax(facing[candidates])])
    chosen = spread_nodes(pts, candidates, int(max_arrows), start)
    length = ARROW_FRACTION * 2.0 * half / float(speed.max())
    q = ax.quiver(
        *pts[chosen].T,
        *vel[chosen].T,
        length=length,
        normalize=False,
        arrow_length_ratio=0.3,
        color="k",
        linewidths=0.6,
        zorder=2,
    )
    q.set_gid("velocity")


def _frame_axes(ax, centre, half) -> None:
    """Equal-aspect limits of half-width ``half`` about ``centre``, labelled in R0."""
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1))
    for axis in "xyz":
        getattr(ax, f"set_{axis}label")(f"{axis} [R0]", fontsize=8, labelpad=2)
    ax.tick_params(labelsize=7, pad=1)


def colorbar_below(fig: Figure, ax, mappable, label: str, fontsize: float = 8.0, pad: float = 0.04):
    """A horizontal colour bar under the panel ``ax`` (a 3D frame or a picture of one), labelled
    below it: neither its label nor its ticks run into the panel's z axis label, as a vertical
    bar beside a 3D axes does. Returns the :class:`~matplotlib.colorbar.Colorbar`."""
    bar = fig.colorbar(mappable, ax=ax, location="bottom", shrink=0.6, pad=0.04, fraction=0.05, aspect=30)
    bar.set_label(label, fontsize=fontsize)
    bar.ax.tick_params(labelsize=fontsize - 1)
    return bar


def series_names(ds) -> list[str]:
    """The per-frame scalar variables of a trajectory (dims ``("time",)``), in file order."""
    return [str(name) for name, var in ds.data_vars.items() if var.dims == ("time",)]


def plot_timeseries(ds, names: Sequence[str] = DEFAULT_SERIES, ax=None, mark_time=None):
    """Per-frame scalars against time, with units from the variables' attributes.

    The variables sharing the unit of the first one go on ``ax``; each other unit gets its own
    y axis on the right (``ax.twinx()``; the third and further ones offset outward), so e.g.
    ``orientation_angle`` (degrees) goes on a twin axis next to the radii (R0).

    Parameters
    ----------
    ds : xarray.Dataset
    names : sequence of str, or a comma-separated str
        Variables to draw; names the trajectory does not have are skipped with a warning.
    ax : matplotlib Axes, optional
        A 2D axes; a new figure is made without one.
    mark_time : float, optional
        Draw a vertical dotted line there (gid ``"mark_time"``).

    Returns
    -------
    ax : Axes
        The primary axes (the twin axes are in ``ax.figure.axes``).
    lines : dict of str -> Line2D
        One line per drawn variable; ``get_xdata()`` is the time, ``get_ydata()`` the values.

    Raises
    ------
    CortexError
        If none of ``names`` is in the trajectory (the message lists what it has).
    """
    _require(ds, ["time"])
    if isinstance(names, str):
        names = [s.strip() for s in names.split(",") if s.strip()]
    available = series_names(ds)
    present = [n for n in dict.fromkeys(names) if n in available]
    for name in names:
        if name not in available:
            warnings.warn(f"the trajectory has no per-frame variable {name!r}: not drawn", stacklevel=2)
    if not present:
        raise CortexError(
            f"none of the series {', '.join(map(repr, names)) or '(none given)'} is in the trajectory; "
            f"it has: {', '.join(available) or 'no per-frame variables'}"
        )
    if ax is None:
        fig = Figure(figsize=(6.0, 4.0))
        ax = fig.add_subplot()
    groups: dict[str, list[str]] = {}
    for name in present:
        groups.setdefault(str(ds[name].attrs.get("units", "")), []).append(name)
    axes = [ax]
    for i in range(1, len(groups)):
        twin = ax.twinx()
        if i > 1:
            twin.spines["right"].set_position(("axes", 1.0 + 0.18 * (i - 1)))
        axes.append(twin)

    t = np.asarray(ds["time"].values, dtype=float)
    cycle = [f"C{i}" for i in range(10)]  # one colour sequence across all y axes
    styles = ["-", "--", "-.", ":"]
    lines = {}
    i = 0
    for g, (units, members) in enumerate(groups.items()):
        a = axes[g]
        for name in members:
            y = np.asarray(ds[name].values, dtype=float)
            (line,) = a.plot(
                t,
                y,
                styles[g % len(styles)],
                color=cycle[i % len(cycle)],
                marker="o" if len(t) == 1 else None,
                markersize=3,
                label=f"{name} [{units}]" if units else name,
            )
            lines[name] = line
            i += 1
        if len(members) == 1:
            long_name = ds[members[0]].attrs.get("long_name", members[0])
            label = f"{long_name} [{units}]" if units else long_name
        else:
            label = f"{', '.join(members)}" + (f" [{units}]" if units else "")
        a.set_ylabel(label, fontsize=8)
    ax.set_xlabel(f"time [{ds['time'].attrs.get('units', 't_a')}]")
    if mark_time is not None:
        ax.axvline(float(mark_time), color="0.3", linestyle=":", linewidth=1.0, gid="mark_time")
    ax.legend(list(lines.values()), [ln.get_label() for ln in lines.values()], fontsize=7, loc="best")
    return ax, lines


def figure_frame_and_series(
    ds,
    frame=-1,
    color: str = "speed",
    arrows: bool = True,
    series: Sequence[str] | None = DEFAULT_SERIES,
    view=DEFAULT_VIEW,
    figsize=None,
    dpi: float = 150.0,
    image=None,
    clim=None,
    cmap=None,
) -> Figure:
    """A figure with the 3D frame (its colour bar below it) on the left and the time series on
    the right, with a vertical line at the frame's time.  ``series=None`` or empty: the 3D panel
    only.  Default size 11 x 4.8 inches (6.5 x 5.5 without series); the PNG is ``figsize * dpi``
    pixels.

    ``image``: an ``(H, W, 3)`` picture of the frame drawn elsewhere (e.g. by PyVista,
    :mod:`cortex_ti.viz.render`) to show instead of the matplotlib 3D panel; ``clim`` (required
    then) and ``cmap`` are the colours it was drawn with, for the colour bar.

    Layout: the colour bar is horizontal under the 3D panel, so that neither its label nor the
    panel's z label run into each other; the twin y axes of the series get room on the right.
    """
    k = frame_index(ds, frame)
    if isinstance(series, str):
        series = [s.strip() for s in series.split(",") if s.strip()]
    with_series = bool(series)
    if figsize is None:
        figsize = (11.0, 4.8) if with_series else (6.5, 5.5)
    fig = Figure(figsize=figsize, dpi=dpi)
    if with_series:
        units = {str(ds[n].attrs.get("units", "")) for n in series if n in ds.data_vars}
        right = 0.92 - 0.07 * max(len(units) - 1, 0)  # room for the twin y axes
        grid = fig.add_gridspec(
            1, 2, width_ratios=(1.0, 1.1), left=0.02, right=right, bottom=0.12, top=0.9, wspace=0.22
        )
        slot = grid[0, 0]
    else:
        slot = fig.add_gridspec(1, 1, left=0.02, right=0.98, bottom=0.09, top=0.92)[0, 0]
    t = float(ds["time"].values[k])
    if image is None:
        ax3d = fig.add_subplot(slot, projection="3d")
        _, mappable = plot_frame(ds, k, color=color, arrows=arrows, ax=ax3d, view=view, clim=clim, cmap=cmap)
        ax3d.zaxis.labelpad = 0
        panel = ax3d
    else:
        if clim is None:
            raise ValueError("an image needs the colour limits it was drawn with (clim)")
        from matplotlib.cm import ScalarMappable

        panel = fig.add_subplot(slot)
        panel.imshow(np.asarray(image), interpolation="antialiased")
        panel.set_axis_off()
        panel.set_title(f"t = {t:.4g} t_a  (frame {k}; frames 0..{ds.sizes['time'] - 1})", fontsize=9)
        mappable = ScalarMappable(norm=Normalize(*(float(c) for c in clim)), cmap=cmap or COLORS[color][1])
    colorbar_below(fig, panel, mappable, COLORS[color][0])
    if with_series:
        plot_timeseries(ds, series, ax=fig.add_subplot(grid[0, 1]), mark_time=t)
    return fig


# ---------------------------------------------------------------------------------------------
# saving
# ---------------------------------------------------------------------------------------------
def figure_format(path) -> str:
    """The format of a figure file from its suffix (one of :data:`FORMATS`).

    Raises
    ------
    CortexError
        Unknown or missing suffix.
    """
    suffix = Path(os.fspath(path)).suffix
    fmt = suffix.lower().lstrip(".")
    if fmt not in FORMATS:
        raise CortexError(
            f"cannot save a figure as '{path}': unknown format '{suffix or '(no suffix)'}'; "
            f"use {', '.join('.' + f for f in FORMATS)}"
        )
    return fmt


def save_figure(fig: Figure, path, dpi: float | None = None) -> Path:
    """Save ``fig`` atomically: to a temporary file in the target folder, then :func:`os.replace`.

    The format comes from the suffix (:data:`FORMATS`); the folder is created if needed.  If
    anything fails, the temporary file is removed and ``path`` is left as it was (absent, or
    the previous figure).  ``dpi`` defaults to the figure's; no tight bounding box, so a PNG is
    ``figsize * dpi`` pixels.

    Returns
    -------
    Path
        ``path``.
    """
    path = Path(os.fspath(path))
    fmt = figure_format(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        with open(tmp, "xb") as fh:
            fig.savefig(fh, format=fmt, dpi=dpi if dpi is not None else fig.dpi)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
