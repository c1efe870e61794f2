"""Movies of a trajectory (``cortex-ti movie``): its frames coloured by one quantity, with the
time in the upper left corner, as MP4 (H.264 by the ffmpeg that the imageio-ffmpeg wheel
carries) or GIF (Pillow, through imageio).

The colour limits and the zoom are those of all the frames in the movie, so that a colour and a
size mean the same in every frame. The pictures come from
:func:`cortex_ti.viz.render.frame_renderer` (PyVista off screen, or matplotlib without OpenGL).
The file is written under a temporary name in the target folder and renamed when complete.
"""

from __future__ import annotations

import os
import secrets
from collections.abc import Sequence
from pathlib import Path

from ..errors import CortexError
from ..plotting import COLORS, DEFAULT_VIEW, MAX_ARROWS
from .extra import require
from .render import Renderer, frame_renderer

__all__ = ["MOVIE_FORMATS", "movie_format", "parse_size", "write_movie"]

#: Movie formats, from the file suffix.
MOVIE_FORMATS: tuple[str, ...] = ("mp4", "gif")


def movie_format(path) -> str:
    """The movie format of ``path`` from its suffix (one of :data:`MOVIE_FORMATS`)."""
    suffix = Path(os.fspath(path)).suffix
    fmt = suffix.lower().lstrip(".")
    if fmt not in MOVIE_FORMATS:
        raise CortexError(
            f"cannot write a movie as '{path}': unknown format '{suffix or '(no suffix)'}'; "
            f"use {', '.join('.' + f for f in MOVIE_FORMATS)}"
        )
    return fmt


def parse_size(text: str) -> tuple[int, int]:
    """``"WIDTHxHEIGHT"`` in pixels, each rounded down to an even number (H.264 with 4:2:0
    colour needs even sides) and at least 64."""
    try:
        w, h = (int(v) for v in str(text).lower().split("x"))
    except ValueError:
        raise CortexError(f"--size must be WIDTHxHEIGHT in pixels (e.g. 800x800), got '{text}'") from None
    if w < 64 or h < 64 or w > 8192 or h > 8192:
        raise CortexError(f"--size must be between 64x64 and 8192x8192 pixels, got '{text}'")
    return w - w % 2, h - h % 2


def write_movie(
    ds,
    path,
    color: str = "speed",
    frames: Sequence[int] | None = None,
    fps: float = 10.0,
    size=(800, 800),
    view=DEFAULT_VIEW,
    arrows: bool = True,
    max_arrows: int = MAX_ARROWS,
    renderer: Renderer | None = None,
    clim=None,
) -> Path:
    """Write the frames ``frames`` (indices, default all) of the trajectory ``ds`` as a movie.

    Returns ``path``. Each frame of the movie is ``size`` (width, height; even numbers) pixels.
    """
    fmt = movie_format(path)
    if color not in COLORS:
        raise CortexError(f"unknown colour {color!r}; choose one of: {', '.join(COLORS)}")
    if not fps > 0:
        raise CortexError(f"--fps must be > 0, got {fps:g}")
    require("movie", "cortex-ti movie")
    import imageio.v2 as iio

    path = Path(os.fspath(path))
    ks = list(range(ds.sizes["time"])) if frames is None else [int(k) for k in frames]
    if not ks:
        raise CortexError("the trajectory has no frames (yet)")
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{secrets.token_hex(4)}.tmp{path.suffix}")
    if fmt == "mp4":
        options = {
            "format": "FFMPEG",
            "fps": float(fps),
            "codec": "libx264",
            "pixelformat": "yuv420p",
            "quality": 8,
            "macro_block_size": 2,
            "ffmpeg_log_level": "error",
        }
    else:
        options = {"format": "GIF", "mode": "I", "duration": 1000.0 / float(fps), "loop": 0}
    try:
        with (
            frame_renderer(
                ds, color, ks, renderer, size=size, view=view, arrows=arrows, max_arrows=max_arrows, clim=clim
            ) as fr,
            iio.get_writer(tmp, **options) as writer,
        ):
            for k in ks:
                writer.append_data(fr.render(k))
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)
    return path
