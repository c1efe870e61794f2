"""Pictures of trajectory frames as RGB arrays, by PyVista/VTK off screen or by matplotlib.

Public API
----------
:func:`choose_renderer`
    which renderer draws here (:class:`Renderer`, with the one line that says which and why).
:func:`frame_renderer`
    a :class:`PyVistaFrames` or :class:`MatplotlibFrames` for a trajectory and a colour
    quantity: ``render(k)`` gives frame ``k`` as an ``(H, W, 3)`` ``uint8`` array.
:func:`colour_limits`
    the colour range of a quantity over some frames (symmetric about 0 for
    ``normal_velocity``).

How the renderer is chosen
--------------------------
PyVista needs OpenGL. With no display (``DISPLAY`` unset) VTK's EGL window (Mesa's software
rasteriser serves it on a machine without a GPU) is tried, then OSMesa; with a display the
default window first. Each is tried in a child process that draws one small sphere and checks
the picture is not blank, so a missing or broken OpenGL cannot crash the caller; the first that
works is set in ``VTK_DEFAULT_OPENGL_WINDOW`` for this process. A ``VTK_DEFAULT_OPENGL_WINDOW``
set by the user is the only one tried. Without pyvista, or when no window works, matplotlib
draws (:func:`cortex_ti.viz.plotting.plot_frame`).

What a PyVista picture shows
----------------------------
The surface with the node values of the quantity (:func:`cortex_ti.viz.plotting.node_values`)
interpolated across each triangle and smooth shading; velocity arrows (black) at an evenly
spread subset of the moving nodes (at most ``max_arrows``; the fastest node of all the frames
given has an arrow 12 % of the size of the shape, as in :mod:`cortex_ti.viz.plotting` for one
frame); the camera at the view angles ``(elev, azim)`` of
matplotlib's convention (:func:`cortex_ti.viz.plotting.view_direction`, z up) and a zoom that stays
fixed across the frames given to :func:`frame_renderer`; optionally a horizontal colour bar and
the time in the upper left corner.
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import CortexError
from .extra import RENDERERS, VIZ_EXTRA, missing
from .plotting import (
    ARROW_FRACTION,
    COLORS,
    DEFAULT_VIEW,
    MAX_ARROWS,
    frame_index,
    node_values,
    spread_nodes,
    view_direction,
)

__all__ = [
    "RENDERERS",
    "MatplotlibFrames",
    "PyVistaFrames",
    "Renderer",
    "choose_renderer",
    "colour_limits",
    "frame_renderer",
]

_PROBE = """
import json, sys
import pyvista as pv
p = pv.Plotter(off_screen=True, window_size=(64, 64))
p.add_mesh(pv.Sphere(), color="red")
img = p.screenshot(return_img=True)
caps = p.ren_win.ReportCapabilities() or ""
gl = [l.split(":", 1)[1].strip() for l in caps.splitlines() if "renderer string" in l]
print(json.dumps({"ok": bool(img.std() > 0), "window": type(p.ren_win).__name__, "gl": gl[0] if gl else ""}))
p.close()
"""

#: Colour-bar titles in plain ASCII (VTK's text drawing lacks some of the glyphs of
#: :data:`cortex_ti.viz.plotting.COLORS`' labels).
PLAIN_LABELS: dict[str, str] = {
    "speed": "speed [R0/t_a]",
    "active_stress": "active tension zeta [zeta_0]",
    "normal_velocity": "normal velocity v.n [R0/t_a]",
}

_WINDOW_NAMES = {"vtkEGLRenderWindow": "EGL", "vtkOSOpenGLRenderWindow": "OSMesa", "vtkXOpenGLRenderWindow": "X11"}


@dataclass(frozen=True)
class Renderer:
    """The renderer that draws 3D pictures here: ``name`` (``"pyvista"`` or ``"matplotlib"``)
    and why."""

    name: str
    reason: str

    @property
    def line(self) -> str:
        """The one line that says which renderer draws and why."""
        return f"cortex-ti: 3D pictures by {self.name}: {self.reason}"


def _probe(window: str | None, timeout: float = 120.0) -> dict | None:
    env = dict(os.environ)
    if window is not None:
        env["VTK_DEFAULT_OPENGL_WINDOW"] = window
    try:
        res = subprocess.run(
            [sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=timeout, check=False
        )
    except (subprocess.TimeoutExpired, OSError):
        return None
    lines = [ln for ln in res.stdout.splitlines() if ln.startswith("{")]
    if res.returncode != 0 or not lines:
        return None
    info = json.loads(lines[-1])
    return info if info.get("ok") else None


@functools.cache
def choose_renderer(prefer: str = "auto") -> Renderer:
    """The renderer for ``prefer`` (one of :data:`RENDERERS`); see the module docstring.

    ``"pyvista"`` that cannot draw here raises :class:`CortexError`; ``"auto"`` falls back to
    matplotlib and says why. The answer is cached for the process.
    """
    if prefer not in RENDERERS:
        raise CortexError(f"unknown renderer '{prefer}'; choose one of: {', '.join(RENDERERS)}")
    if prefer == "matplotlib":
        return Renderer("matplotlib", "asked for (--renderer matplotlib)")
    absent = missing("pyvista")
    if absent:
        why = f"{', '.join(absent)} not installed ({VIZ_EXTRA} for PyVista pictures)"
    else:
        user = os.environ.get("VTK_DEFAULT_OPENGL_WINDOW")
        if user:
            windows = [user]
        elif os.environ.get("DISPLAY"):
            windows = [None, "vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow"]
        else:
            windows = ["vtkEGLRenderWindow", "vtkOSOpenGLRenderWindow"]
        for window in windows:
            info = _probe(window)
            if info is not None:
                if window is not None:
                    os.environ["VTK_DEFAULT_OPENGL_WINDOW"] = window
                kind = _WINDOW_NAMES.get(info["window"], info["window"])
                return Renderer("pyvista", f"VTK off screen through {kind} ({info['gl'] or 'OpenGL'})")
        why = (
            "no OpenGL off screen here (VTK's "
            + ", ".join(_WINDOW_NAMES.get(w, w or "default") for w in windows)
            + " windows failed)"
        )
    if prefer == "pyvista":
        raise CortexError(f"--renderer pyvista cannot draw here: {why}")
    return Renderer("matplotlib", why)


def colour_limits(ds, color: str, frames: Sequence[int]) -> tuple[float, float]:
    """The range of the node values of ``color`` over ``frames`` (symmetric about 0 for
    ``normal_velocity``; widened to a unit interval around a constant)."""
    values = np.concatenate([node_values(ds, k, color) for k in frames])
    if color == "normal_velocity":
        m = float(np.nanmax(np.abs(values)))
        lo, hi = -m, m
    else:
        lo, hi = float(np.nanmin(values)), float(np.nanmax(values))
    if not hi > lo:
        lo, hi = lo - 0.5, hi + 0.5
    return lo, hi


def _bounds(ds, frames: Sequence[int], arrows: bool) -> tuple[np.ndarray, float]:
    """Centre and half-width of the cube holding the shape in ``frames`` (and its arrows)."""
    pts = np.concatenate([np.asarray(ds["points"][k].values, dtype=float) for k in frames])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    half = 0.5 * float(np.max(hi - lo))
    return 0.5 * (lo + hi), half * (1.0 + 2.0 * ARROW_FRACTION if arrows else 1.02)


class PyVistaFrames:
    """Frames of a trajectory drawn by one off-screen PyVista plotter (reused frame after frame).

    Parameters
    ----------
    ds : xarray.Dataset
        A trajectory.
    color : str
        A key of :data:`cortex_ti.viz.plotting.COLORS`.
    frames : sequence of int
        The frames to be drawn: they fix the colour limits (unless ``clim``) and the zoom.
    size : (width, height)
        Picture size in pixels.
    view : (elev, azim)
        Camera angles in degrees (matplotlib's convention, z up).
    clim, cmap, arrows, max_arrows
        As in :func:`cortex_ti.viz.plotting.plot_frame`.
    edges : bool
        Draw the triangles' edges (faint).
    lighting : bool
        Shade the surface; without it every pixel of the surface has exactly a colour of the
        colour map.
    scalar_bar, time_label : bool
        Draw a horizontal colour bar at the bottom, the time in the upper left corner.
    """

    def __init__(
        self,
        ds,
        color: str,
        frames: Sequence[int],
        size=(1200, 1000),
        view=DEFAULT_VIEW,
        clim=None,
        cmap=None,
        arrows: bool = True,
        max_arrows: int = MAX_ARROWS,
        scalar_bar: bool = True,
        time_label: bool = True,
        font_size: int = 14,
        edges: bool = True,
        lighting: bool = True,
    ):
        import pyvista as pv

        if "mesh_id" in ds:
            raise CortexError(
                "pictures and movies of a remeshed run (frames on several meshes) are not drawn yet: "
                "plot one frame (cortex-ti plot) or export it to ParaView (cortex-ti export)"
            )
        self.ds, self.frames, self.arrows, self.max_arrows = ds, list(frames), arrows, int(max_arrows)
        self.time_label, self.font_size, self.scalar_bar, self.edges = time_label, font_size, scalar_bar, edges
        self.lighting = lighting
        self.triangles = np.asarray(ds["triangles"].values, dtype=np.int64)
        faces = np.hstack([np.full((len(self.triangles), 1), 3, dtype=np.int64), self.triangles]).ravel()
        self._pv = pv
        self.plotter = pv.Plotter(off_screen=True, window_size=tuple(int(s) for s in size))
        self.plotter.set_background("white")
        self.surface = pv.PolyData(np.asarray(ds["points"][frames[0]].values, dtype=float), faces)
        self.set_frames(ds, frames, color, clim, cmap)
        centre, half = _bounds(ds, frames, arrows)
        self.half_shape = half / (1.0 + 2.0 * ARROW_FRACTION) if arrows else half / 1.02
        eye = centre + 4.0 * half * view_direction(*view)
        self.plotter.camera_position = [tuple(eye), tuple(centre), (0.0, 0.0, 1.0)]
        # the same zoom for all the frames given: the cube that holds them fills the picture
        self.plotter.reset_camera(bounds=tuple(np.ravel(np.column_stack([centre - half, centre + half]))))
        self.plotter.camera.zoom(1.3)

    def set_frames(self, ds, frames: Sequence[int], color: str | None = None, clim=None, cmap=None) -> None:
        """Draw from ``ds`` (the same mesh, e.g. the file read again with more frames) and the
        ``frames`` given: the colour limits (unless ``clim``), one arrow scale for them all (a
        slowing flow shows shorter arrows) and the decimals of the time (as many as the frame
        spacing needs) are taken over them. The zoom stays."""
        self.ds, self.frames = ds, list(frames)
        speeds = [np.linalg.norm(np.asarray(ds["velocity"][k].values, dtype=float), axis=1).max() for k in self.frames]
        self.speed_max = float(max(speeds))
        spacing = np.diff(np.sort(np.asarray(ds["time"].values, dtype=float)[self.frames]))
        spacing = spacing[spacing > 0]
        self.decimals = int(np.clip(np.ceil(-np.log10(spacing.min())), 1, 8)) if spacing.size else 3
        self.set_color(color or self.color, clim, cmap)

    def set_color(self, color: str, clim=None, cmap=None) -> None:
        """Colour the surface by ``color`` from now on (limits ``clim``, default over the frames
        given)."""
        if color not in COLORS:
            raise CortexError(f"unknown colour {color!r}; choose one of: {', '.join(COLORS)}")
        self.color = color
        self.clim = tuple(float(c) for c in clim) if clim is not None else colour_limits(self.ds, color, self.frames)
        self.cmap = cmap or COLORS[color][1]
        k = getattr(self, "frame", None)
        k = k if k is not None and k < self.ds.sizes["time"] else self.frames[0]
        self.surface.point_data[color] = node_values(self.ds, k, color)
        if self.plotter.scalar_bars:
            self.plotter.remove_scalar_bar()
        bar = {
            "title": PLAIN_LABELS.get(color, color),
            "vertical": False,
            "position_x": 0.2,
            "position_y": 0.03,
            "width": 0.6,
            "height": 0.07,
            "color": "black",
            "title_font_size": self.font_size,
            "label_font_size": self.font_size - 2,
            "fmt": "%.3g",
            "n_labels": 5,
        }
        self.plotter.add_mesh(
            self.surface,
            scalars=color,
            cmap=self.cmap,
            clim=self.clim,
            smooth_shading=True,
            show_edges=self.edges,
            edge_color="black",
            edge_opacity=0.15,
            line_width=0.5,
            show_scalar_bar=self.scalar_bar,
            scalar_bar_args=bar,
            lighting=self.lighting,
            name="surface",
        )

    def _update(self, k: int) -> None:
        ds = self.ds
        self.frame = k
        pts = np.asarray(ds["points"][k].values, dtype=float)
        self.surface.points = pts
        self.surface.point_data[self.color] = node_values(ds, k, self.color)
        if self.arrows:
            vel = np.asarray(ds["velocity"][k].values, dtype=float)
            speed = np.linalg.norm(vel, axis=1)
            moving = np.flatnonzero(speed > 0.0)
            if moving.size:
                chosen = spread_nodes(pts, moving, self.max_arrows, int(moving[np.argmax(speed[moving])]))
                cloud = self._pv.PolyData(pts[chosen])
                cloud["velocity"] = vel[chosen]
                scale = ARROW_FRACTION * 2.0 * self.half_shape / self.speed_max
                glyphs = cloud.glyph(
                    orient="velocity",
                    scale="velocity",
                    factor=scale,
                    geom=self._pv.Arrow(tip_length=0.3, tip_radius=0.12, shaft_radius=0.04),
                )
                self.plotter.add_mesh(glyphs, color="black", name="arrows")
            else:
                self.plotter.remove_actor("arrows")
        if self.time_label:
            t = float(ds["time"].values[k])
            w, h = self.plotter.window_size
            corner = (int(0.03 * w), int(h - 0.03 * w - 1.6 * self.font_size))
            self.plotter.add_text(
                f"t = {t:.{self.decimals}f} t_a", position=corner, font_size=self.font_size, color="black", name="time"
            )

    def show(self, k: int) -> None:
        """Put frame ``k`` in the scene (without drawing it)."""
        self._update(k)

    def render(self, k: int) -> np.ndarray:
        """Frame ``k`` as an ``(H, W, 3)`` ``uint8`` array."""
        self._update(k)
        self.plotter.render()
        return np.asarray(self.plotter.screenshot(return_img=True))[..., :3]

    def close(self) -> None:
        self.plotter.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class MatplotlibFrames:
    """The same pictures drawn by matplotlib (:func:`cortex_ti.viz.plotting.plot_frame`), for
    machines without OpenGL: a colour bar below, the time in the title."""

    def __init__(
        self,
        ds,
        color: str,
        frames: Sequence[int],
        size=(1200, 1000),
        view=DEFAULT_VIEW,
        clim=None,
        cmap=None,
        arrows: bool = True,
        max_arrows: int = MAX_ARROWS,
        scalar_bar: bool = True,
        time_label: bool = True,
        font_size: int = 14,
        edges: bool = True,
        lighting: bool = True,
    ):
        if color not in COLORS:
            raise CortexError(f"unknown colour {color!r}; choose one of: {', '.join(COLORS)}")
        self.ds, self.color, self.view, self.cmap = ds, color, view, cmap
        self.arrows, self.max_arrows, self.scalar_bar, self.time_label = arrows, max_arrows, scalar_bar, time_label
        self.size = tuple(int(s) for s in size)
        self.clim = tuple(float(c) for c in clim) if clim is not None else colour_limits(ds, color, frames)

    def render(self, k: int) -> np.ndarray:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        from .plotting import plot_frame

        dpi = 100.0
        fig = Figure(figsize=(self.size[0] / dpi, self.size[1] / dpi), dpi=dpi)
        canvas = FigureCanvasAgg(fig)
        ax = fig.add_axes(
            (0.02, 0.16 if self.scalar_bar else 0.02, 0.96, 0.8 if self.scalar_bar else 0.94), projection="3d"
        )
        _, mappable = plot_frame(
            self.ds,
            k,
            color=self.color,
            arrows=self.arrows,
            ax=ax,
            view=self.view,
            cmap=self.cmap,
            clim=self.clim,
            max_arrows=self.max_arrows,
        )
        if not self.time_label:
            ax.set_title("")
        if self.scalar_bar:
            cax = fig.add_axes((0.2, 0.07, 0.6, 0.03))
            fig.colorbar(mappable, cax=cax, orientation="horizontal", label=COLORS[self.color][0])
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def frame_renderer(
    ds, color: str = "speed", frames: Sequence[int] | None = None, renderer: Renderer | None = None, **options
):
    """A :class:`PyVistaFrames` or :class:`MatplotlibFrames` (by ``renderer``, default
    :func:`choose_renderer`) for the frames ``frames`` (indices or times, default all)."""
    n = ds.sizes["time"]
    ks = list(range(n)) if frames is None else [frame_index(ds, f) for f in frames]
    if not ks:
        raise CortexError("no frames to draw")
    renderer = renderer or choose_renderer()
    cls = PyVistaFrames if renderer.name == "pyvista" else MatplotlibFrames
    return cls(ds, color, ks, **options)
