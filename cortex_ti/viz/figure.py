"""Frames in matplotlib figures, drawn by the chosen renderer
(:func:`cortex_ti.viz.render.choose_renderer`): the figure of ``cortex-ti plot`` (a frame next to
its time series) and bare panels of frames for grids of snapshots (the report's figures).
"""

from __future__ import annotations

import numpy as np

from .plotting import (
    COLORS,
    DEFAULT_SERIES,
    DEFAULT_VIEW,
    MAX_ARROWS,
    colorbar_below,
    figure_frame_and_series,
    frame_index,
    plot_frame,
)
from .render import PyVistaFrames, Renderer, choose_renderer

__all__ = ["crop_to_content", "frame_figure", "frame_panel", "frame_picture"]


def crop_to_content(image: np.ndarray, margin: float = 0.03, background: int = 245) -> np.ndarray:
    """``image`` cut to the box of its non-background pixels (any channel below ``background``),
    plus ``margin`` of the larger side on each side; unchanged if it is all background."""
    ink = np.any(np.asarray(image)[..., :3] < background, axis=-1)
    if not ink.any():
        return image
    rows, cols = np.flatnonzero(ink.any(axis=1)), np.flatnonzero(ink.any(axis=0))
    pad = round(margin * max(image.shape[:2]))
    r0, r1 = max(rows[0] - pad, 0), min(rows[-1] + pad + 1, image.shape[0])
    c0, c1 = max(cols[0] - pad, 0), min(cols[-1] + pad + 1, image.shape[1])
    return image[r0:r1, c0:c1]


def frame_panel(
    fig,
    spec,
    ds,
    frame=-1,
    color: str = "speed",
    arrows: bool = True,
    view=DEFAULT_VIEW,
    renderer: Renderer | None = None,
    label: str | None = None,
    fontsize: float = 7.0,
    pixels: int = 700,
):
    """One frame as a bare panel of ``fig`` (no axes, ticks or labels) with its colour bar below.

    ``spec``: where, as ``fig.add_subplot`` takes it (a ``SubplotSpec``, or ``(nrows, ncols,
    index)``). With PyVista (``renderer``, default :func:`choose_renderer`) the panel is a
    ``pixels``-square picture cut to the shape; with matplotlib a 3D axes
    (:func:`cortex_ti.viz.plotting.plot_frame` with ``axes=False``). ``label``: of the colour bar
    (default the quantity's). Returns ``(ax, colorbar)``.
    """
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    renderer = renderer or choose_renderer()
    k = frame_index(ds, frame)
    where = spec if isinstance(spec, tuple) else (spec,)
    if renderer.name == "pyvista":
        with PyVistaFrames(
            ds, color, [k], size=(pixels, pixels), view=view, arrows=arrows, scalar_bar=False, time_label=False
        ) as fr:
            image = crop_to_content(fr.render(k))
            mappable = ScalarMappable(norm=Normalize(*fr.clim), cmap=fr.cmap)
        ax = fig.add_subplot(*where)
        ax.imshow(image, interpolation="antialiased")
        ax.set_axis_off()
    else:
        ax = fig.add_subplot(*where, projection="3d")
        _, mappable = plot_frame(ds, k, color=color, arrows=arrows, ax=ax, view=view, axes=False)
    bar = colorbar_below(fig, ax, mappable, label if label is not None else COLORS[color][0], fontsize=fontsize)
    return ax, bar


def frame_picture(
    ds,
    frame=-1,
    color: str = "speed",
    arrows: bool = True,
    view=DEFAULT_VIEW,
    size=(1200, 1000),
    renderer: Renderer | None = None,
    **options,
):
    """Frame ``frame`` (index or time) as an ``(H, W, 3)`` picture with its colour bar and time,
    by ``renderer`` (default :func:`choose_renderer`)."""
    from .render import frame_renderer

    k = frame_index(ds, frame)
    with frame_renderer(ds, color, [k], renderer, size=size, view=view, arrows=arrows, **options) as fr:
        return fr.render(k)


def frame_figure(
    ds,
    frame=-1,
    color: str = "speed",
    arrows: bool = True,
    series=DEFAULT_SERIES,
    view=DEFAULT_VIEW,
    figsize=None,
    dpi: float = 150.0,
    renderer: Renderer | None = None,
    max_arrows: int = MAX_ARROWS,
):
    """:func:`cortex_ti.viz.plotting.figure_frame_and_series` with the 3D panel drawn by PyVista
    when it is the renderer (a picture twice the panel's pixel size, its colour bar drawn by
    matplotlib with the same limits), by matplotlib otherwise."""
    renderer = renderer or choose_renderer()
    if renderer.name != "pyvista":
        return figure_frame_and_series(ds, frame, color, arrows, series, view=view, figsize=figsize, dpi=dpi)
    k = frame_index(ds, frame)
    with_series = bool(series)
    w, h = figsize if figsize is not None else ((11.0, 4.8) if with_series else (6.5, 5.5))
    side = int(2 * dpi * min(w * (0.45 if with_series else 0.96), h * 0.8))
    with PyVistaFrames(
        ds,
        color,
        [k],
        size=(side, side),
        view=view,
        arrows=arrows,
        max_arrows=max_arrows,
        scalar_bar=False,
        time_label=False,
    ) as fr:
        image = fr.render(k)
        clim, cmap = fr.clim, fr.cmap
    return figure_frame_and_series(
        ds, k, color, arrows, series, view=view, figsize=figsize, dpi=dpi, image=image, clim=clim, cmap=cmap
    )
