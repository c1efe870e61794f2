"""Movies of a trajectory (``cortex-ti movie``): its frames coloured by one quantity, with the
time in the upper left corner, as MP4 (H.264 by the ffmpeg that the imageio-ffmpeg wheel
carries) or GIF (Pillow, through imageio).

The colour limits and the zoom are those of all the frames in the movie, so that a colour and a
size mean the same in every frame. The pictures come from
:func:`cortex_ti.viz.render.frame_renderer` (PyVista off screen, or matplotlib without OpenGL).
The destination is checked before the first frame is drawn (a folder that can be written, some
free space); the file is written under a temporary name in the target folder, checked (an MP4 is
decoded: ffmpeg reports a full disk only in its log) and renamed when complete. A full disk, a
read-only folder or a codec error is one :class:`~cortex_ti.io.files.OutputError`, nothing left.
"""

from __future__ import annotations

import contextlib
import io
import os
import secrets
from collections.abc import Sequence
from pathlib import Path

from ..errors import CortexError
from ..io.files import OutputError, check_destination, describe_os_error, write_synced
from .extra import require
from .plotting import COLORS, DEFAULT_VIEW, MAX_ARROWS
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
    check_destination(path, _least_bytes(size, len(ks)))  # before the first frame is drawn
    tmp = path.with_name(f".{path.stem}.{secrets.token_hex(4)}.tmp{path.suffix}")
    if fmt == "mp4":
        target = tmp  # ffmpeg writes a file; checked below by decoding it
        options = {
            "format": "FFMPEG",
            "fps": float(fps),
            "codec": "libx264",
            "pixelformat": "yuv420p",
            "quality": 8,
            "macro_block_size": 2,
            "ffmpeg_log_level": "quiet",
        }
    else:  # Pillow writes the GIF in memory, Python writes it out: a full disk is one OSError
        target = io.BytesIO()  # (imageio's "<bytes>" keeps only the first frame of a GIF)
        options = {"format": "GIF", "mode": "I", "duration": 1000.0 / float(fps), "loop": 0}
    writer = None
    try:
        with frame_renderer(
            ds, color, ks, renderer, size=size, view=view, arrows=arrows, max_arrows=max_arrows, clim=clim
        ) as fr:
            try:
                writer = iio.get_writer(target, **options)
            except (OSError, RuntimeError, ValueError) as exc:
                raise _failed(path, exc) from None
            for k in ks:
                picture = fr.render(k)  # an error in drawing is not the file's: not caught here
                try:
                    writer.append_data(picture)
                except (OSError, RuntimeError, ValueError) as exc:
                    raise _failed(path, exc) from None
            try:
                writer.close()
                if fmt == "gif":
                    write_synced(tmp, target.getvalue())
                else:
                    _check_mp4(tmp, len(ks))
            except (OSError, RuntimeError, ValueError) as exc:
                raise _failed(path, exc) from None
            finally:
                writer = None
        os.replace(tmp, path)
    finally:
        if writer is not None:
            with contextlib.suppress(Exception):  # closed now, not again with a traceback at exit
                writer.close()
        tmp.unlink(missing_ok=True)
    return path


def _least_bytes(size, n_frames: int) -> int:
    """A lower bound of a movie's size, for the free-space check: 1/100 byte per pixel and frame (an
    H.264 movie of these pictures takes more; a GIF far more)."""
    return int(size[0] * size[1] * n_frames / 100) + (1 << 16)


def _check_mp4(path: Path, n_frames: int) -> None:
    """Fsync ``path`` and decode it: ffmpeg reports a failed write (a full disk) in its log only, and
    leaves a file no player opens; refused unless all ``n_frames`` frames read back."""
    import imageio_ffmpeg

    with open(path, "rb+") as fh:
        os.fsync(fh.fileno())
    try:
        count, _ = imageio_ffmpeg.count_frames_and_secs(str(path))
    except (OSError, RuntimeError):  # its message is ffmpeg's whole banner
        raise OSError("the movie written does not decode (a full disk?)") from None
    if count != n_frames:
        raise OSError(f"the movie written reads back {count} of its {n_frames} frames (a full disk?)")


def _failed(path: Path, exc: BaseException) -> OutputError:
    if isinstance(exc, OSError) and exc.errno:
        why = describe_os_error(exc)
    else:  # ffmpeg's errors come with its banner: the first line says what failed
        lines = str(exc).strip().splitlines()
        why = lines[0][:200] if lines else type(exc).__name__
    return OutputError(f"cannot write the movie '{path}': {why}; nothing was written")
