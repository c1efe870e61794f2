"""The ``movie`` and ``view`` subcommands of ``cortex-ti`` and the ``--renderer`` choice of
``plot``: their arguments and what they run (:func:`add_commands` is called by
:mod:`cortex_ti.cli`; each subcommand carries its handler as ``args.handler``).

Light on purpose: building the parser imports no matplotlib nor VTK (every ``cortex-ti run``
builds it); the handlers import what they use.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import CortexError
from .extra import RENDERERS

__all__ = ["add_commands", "add_renderer_option", "announce", "parse_view"]


def parse_view(text: str | None):
    """``"ELEV,AZIM"`` in degrees (default :data:`cortex_ti.viz.plotting.DEFAULT_VIEW`)."""
    if text is None:
        from .plotting import DEFAULT_VIEW

        return DEFAULT_VIEW
    try:
        elev, azim = (float(v) for v in text.split(","))
    except ValueError:
        raise CortexError(f"--view must be ELEV,AZIM in degrees (e.g. 20,-60), got '{text}'") from None
    return elev, azim


def add_renderer_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--renderer",
        default="auto",
        choices=RENDERERS,
        help="3D pictures by PyVista off screen (needs OpenGL: EGL or OSMesa) or matplotlib; "
        "auto (default): PyVista where it works; one line on stderr says which and why",
    )


def announce(renderer) -> None:
    """The one line saying which renderer draws, on stderr."""
    print(renderer.line, file=sys.stderr)


def _colour(name: str) -> str:
    from .plotting import COLORS

    if name not in COLORS:
        raise CortexError(f"unknown --color '{name}'; choose one of: {', '.join(COLORS)}")
    return name


def add_commands(sub) -> None:
    """Add ``movie`` and ``view`` to the subcommands ``sub`` of the ``cortex-ti`` parser."""
    colours = "speed, active_stress, normal_velocity"  # cortex_ti.viz.plotting.COLORS, checked when run
    movie = sub.add_parser(
        "movie",
        help="write a movie of a trajectory (.mp4 or .gif), coloured by a quantity, "
        "the time in the corner (needs the [viz] extra)",
    )
    movie.add_argument("trajectory", type=Path, help="trajectory file (.h5, or .h5.partial of a run in progress)")
    movie.add_argument("-o", "--output", required=True, type=Path, help="movie file: .mp4 or .gif")
    movie.add_argument("--color", default="speed", help=f"colour quantity: {colours} (default speed)")
    movie.add_argument("--fps", type=float, default=10.0, help="frames per second (default 10)")
    movie.add_argument("--every", type=int, default=1, help="every k-th frame of the trajectory (default 1)")
    movie.add_argument(
        "--size", default="800x800", help="WIDTHxHEIGHT in pixels, rounded down to even numbers (default 800x800)"
    )
    movie.add_argument("--view", default=None, metavar="ELEV,AZIM", help="camera angles in degrees (default 20,-60)")
    movie.add_argument("--no-arrows", action="store_true", help="no velocity arrows")
    add_renderer_option(movie)
    movie.set_defaults(handler=_movie)

    view = sub.add_parser(
        "view",
        help="view a trajectory in the browser: a time slider and a choice of "
        "quantity (trame + PyVista; needs the [viz] extra)",
    )
    view.add_argument("trajectory", type=Path, help="trajectory file (.h5, or .h5.partial of a run in progress)")
    view.add_argument("--port", type=int, default=8080, help="port (default 8080; 0: any free port)")
    view.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1, this machine only)")
    view.add_argument("--color", default="speed", help=f"initial colour quantity: {colours} (default speed)")
    view.add_argument("--no-browser", action="store_true", help="do not open a browser window")
    view.set_defaults(handler=_view)


def _movie(args) -> int:
    from ..io import load_trajectory
    from .extra import require
    from .movie import movie_format, parse_size, write_movie
    from .render import choose_renderer

    # the arguments first, so that a typo costs no reading
    movie_format(args.output)
    color = _colour(args.color)
    if not args.fps > 0:
        raise CortexError(f"--fps must be > 0, got {args.fps:g}")
    if args.every < 1:
        raise CortexError(f"--every must be >= 1, got {args.every}")
    size = parse_size(args.size)
    view = parse_view(args.view)
    require("movie", "cortex-ti movie")
    ds = load_trajectory(args.trajectory)
    renderer = choose_renderer(args.renderer)
    announce(renderer)
    frames = range(0, ds.sizes["time"], args.every)
    print(write_movie(ds, args.output, color, frames, args.fps, size, view, not args.no_arrows, renderer=renderer))
    return 0


def _view(args) -> int:
    from ..io import load_trajectory
    from .extra import require

    color = _colour(args.color)
    if not 0 <= args.port < 65536:
        raise CortexError(f"--port must be between 0 and 65535, got {args.port}")
    require("view", "cortex-ti view")
    ds = load_trajectory(args.trajectory)
    from .viewer import serve

    return serve(
        ds,
        name=args.trajectory.name,
        color=color,
        host=args.host,
        port=args.port,
        open_browser=not args.no_browser,
        reload=lambda: load_trajectory(args.trajectory),
    )
