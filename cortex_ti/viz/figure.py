"""The picture of one frame next to its time series (``cortex-ti plot``), with the 3D panel
drawn by the chosen renderer (:func:`cortex_ti.viz.render.choose_renderer`)."""

from __future__ import annotations

from ..plotting import DEFAULT_SERIES, DEFAULT_VIEW, MAX_ARROWS, figure_frame_and_series, frame_index
from .render import PyVistaFrames, Renderer, choose_renderer

__all__ = ["frame_figure", "frame_picture"]


def frame_picture(ds, frame=-1, color: str = "speed", arrows: bool = True, view=DEFAULT_VIEW,
                  size=(1200, 1000), renderer: Renderer | None = None, **options):
    """Frame ``frame`` (index or time) as an ``(H, W, 3)`` picture with its colour bar and time,
    by ``renderer`` (default :func:`choose_renderer`)."""
    from .render import frame_renderer

    k = frame_index(ds, frame)
    with frame_renderer(ds, color, [k], renderer, size=size, view=view, arrows=arrows, **options) as fr:
        return fr.render(k)


def frame_figure(ds, frame=-1, color: str = "speed", arrows: bool = True, series=DEFAULT_SERIES, view=DEFAULT_VIEW,
                 figsize=None, dpi: float = 150.0, renderer: Renderer | None = None,
                 max_arrows: int = MAX_ARROWS):
    """:func:`cortex_ti.plotting.figure_frame_and_series` with the 3D panel drawn by PyVista
    when it is the renderer (a picture twice the panel's pixel size, its colour bar drawn by
    matplotlib with the same limits), by matplotlib otherwise."""
    renderer = renderer or choose_renderer()
    if renderer.name != "pyvista":
        return figure_frame_and_series(ds, frame, color, arrows, series, view=view, figsize=figsize, dpi=dpi)
    k = frame_index(ds, frame)
    with_series = bool(series)
    w, h = figsize if figsize is not None else ((11.0, 4.8) if with_series else (6.5, 5.5))
    side = int(2 * dpi * min(w * (0.45 if with_series else 0.96), h * 0.8))
    with PyVistaFrames(ds, color, [k], size=(side, side), view=view, arrows=arrows, max_arrows=max_arrows,
                       scalar_bar=False, time_label=False) as fr:
        image = fr.render(k)
        clim, cmap = fr.clim, fr.cmap
    return figure_frame_and_series(ds, k, color, arrows, series, view=view, figsize=figsize, dpi=dpi, image=image,
                                   clim=clim, cmap=cmap)


