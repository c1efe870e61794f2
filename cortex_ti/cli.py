"""Command line: ``cortex-ti run | check | export | plot | movie | view | modes | twin | angles | scenes | schema``.

Every problem with the input (scene, mesh, values) and every operating-system or file error
(a folder that cannot be written, a full disk, a file that is not a trajectory) is reported as
one line naming it, with exit status 2 and no stray file; an unexpected internal error keeps
its traceback (exit status 1) so it can be reported. SIGINT ends a command with status 130,
SIGTERM with 143 (:data:`cortex_ti.simulation.run.EXIT_CODES`); a run then keeps its frames for
``--resume`` and writes its summary with ``status: interrupted``.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import time
from pathlib import Path

from .errors import CortexError, check_interrupted, interruptible, interruption

log = logging.getLogger("cortex_ti")


def _parser() -> argparse.ArgumentParser:
    from .viz.commands import add_commands, add_renderer_option

    p = argparse.ArgumentParser(
        prog="cortex-ti", description="Three-dimensional viscous active cell cortex (Bächer et al. 2021)."
    )
    p.add_argument("-v", "--verbose", action="count", default=0, help="more log output (-vv for debug)")
    p.add_argument(
        "--debug",
        action="store_true",
        help="after an error's one line, print the traceback behind it (e.g. of an error in a python pattern)",
    )
    sub = p.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="run a scene and write its trajectory (HDF5, opens with xarray)")
    run.add_argument("scene", help="scene YAML file, or the name of a built-in scene (see 'cortex-ti scenes')")
    run.add_argument("-o", "--output", required=True, type=Path, help="output file (.h5)")
    run.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scene value, e.g. --set mesh.nodes=642 (repeatable)",
    )
    run.add_argument("--arch", default=None, help="Taichi architecture: cpu (default), gpu, cuda, vulkan, metal")
    run.add_argument(
        "--threads", default=None, help="CPU threads for Taichi and BLAS (default: $CORTEX_TI_THREADS, else all cores)"
    )
    run.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted run from OUTPUT.partial, or extend a finished OUTPUT to a later "
        "time.t_end (only the scene's time section may change)",
    )
    run.add_argument(
        "--force",
        action="store_true",
        help="replace OUTPUT (and start over instead of resuming OUTPUT.partial) if it exists",
    )
    run.add_argument(
        "--summary",
        type=Path,
        default=None,
        metavar="FILE.json",
        help="also write what the run took (status, wall time, steps, solves, peak memory) as JSON; "
        "written for a failed run too, with the error",
    )

    chk = sub.add_parser("check", help="validate a scene, its mesh and its active-stress patterns without solving")
    chk.add_argument("scene")
    chk.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")

    exp = sub.add_parser(
        "export",
        help="write a trajectory for ParaView: one .vtkhdf file with its time steps "
        "(default), or a .pvd with frames named after the run",
    )
    exp.add_argument("trajectory", type=Path)
    exp.add_argument(
        "-o",
        "--output",
        type=Path,
        default=None,
        help="file (.vtkhdf or .pvd) or folder (default: next to the trajectory, named after it)",
    )
    exp.add_argument("--format", dest="fmt", default=None, help="vtkhdf (default) or pvd; default from -o's suffix")
    exp.add_argument("--every", type=int, default=1, help="export every k-th frame")
    exp.add_argument("--force", action="store_true", help="replace an existing export of the same run")

    plot = sub.add_parser(
        "plot",
        help="draw a frame of a trajectory in 3D (colour, velocity arrows) next to its "
        "time series; works on the .partial file of a running simulation",
    )
    plot.add_argument("trajectory", type=Path, help="trajectory file (.h5, or .h5.partial of a run in progress)")
    plot.add_argument("-o", "--output", required=True, type=Path, help="figure file: .png, .pdf or .svg")
    which = plot.add_mutually_exclusive_group()
    which.add_argument(
        "--frame", type=int, default=None, help="frame index (negative: from the end; default -1, the last)"
    )
    which.add_argument("--time", type=float, default=None, help="time: the frame nearest to it (the earlier on a tie)")
    plot.add_argument("--color", default="speed", help="speed (default), active_stress or normal_velocity")
    plot.add_argument("--no-arrows", action="store_true", help="no velocity arrows")
    plot.add_argument(
        "--series",
        default=None,
        metavar="NAME,NAME,...",
        help="per-frame variables to draw against time (default: pole_radius, furrow_radius, "
        "orientation_angle, those the file has); '' for none",
    )
    plot.add_argument(
        "--view",
        default=None,
        metavar="ELEV,AZIM",
        help="camera angles in degrees (default 20,-60; write --view=-20,30 for a negative elevation)",
    )
    plot.add_argument("--dpi", type=float, default=150.0, help="resolution of a .png (default 150)")
    add_renderer_option(plot)
    add_commands(sub)  # movie, view (cortex_ti.viz.commands)

    modes = sub.add_parser(
        "modes",
        help="the growing and the stiffest modes of a stored frame (eigenvalues of the linearised normal "
        "dynamics on the frame's own mesh, each body of a divided one on its own): where they live, whether they "
        "are mesh-scale, the run's scheme's explicit step limit; densely up to 3000 nodes, by ARPACK above",
    )
    modes.add_argument("trajectory", type=Path, help="trajectory file (.h5, or .h5.partial of a run in progress)")
    modes.add_argument(
        "--time", type=float, nargs="+", default=None, help="the frames nearest these times (default: the last)"
    )
    modes.add_argument(
        "--dt", type=float, nargs="+", default=None, help="the steps to linearise at (default: the frame's own)"
    )
    modes.add_argument("--growing", type=int, default=4, help="growing modes shown (largest real part; default 4)")
    modes.add_argument("--stiffest", type=int, default=0, help="stiff modes shown (most negative real part)")
    modes.add_argument(
        "--sparse",
        action="store_true",
        help="ARPACK (largest and smallest real part, relative residual 1e-8) also at 3000 nodes or fewer",
    )

    twin = sub.add_parser(
        "twin",
        help="3D runs against the axisymmetric solution of their own scene (solved here at the files' frame "
        "times): radii over the frames and velocity profiles",
    )
    twin.add_argument("trajectories", type=Path, nargs="+", help="3D trajectory files of axisymmetric scenes")
    twin.add_argument(
        "--convergence", action="store_true", help="error ratios between the files (one scene at several N)"
    )

    angles = sub.add_parser(
        "angles", help="where and when a stored run's smallest triangle angle falls: per frame, and the worst triangles"
    )
    angles.add_argument("trajectory", type=Path, help="trajectory file (.h5, or .h5.partial of a run in progress)")
    angles.add_argument("--below", type=float, default=30.0, help="count the triangles below this angle (deg, 30)")
    angles.add_argument("--worst", type=int, default=4, help="the worst triangles listed (default 4)")

    sub.add_parser("scenes", help="list the built-in scenes")
    sub.add_parser(
        "schema",
        help="print the scene schema (JSON schema, with every registered fit, scheme, solver backend and pattern type)",
    )
    return p


def _threads(args) -> int | None:
    """``--threads``, else ``CORTEX_TI_THREADS``, checked: a bad value is one line, before Taichi starts
    (Taichi aborts on 0 threads; :func:`cortex_ti.errors.thread_count`, which the Python door uses too)."""
    from .errors import thread_count

    return thread_count(args.threads, "--threads")


def _writable_file(path: Path, what: str) -> None:
    """Check before the run that ``path`` can be written (its folder created, a file made in it and
    removed), so that a run is not lost to a summary that cannot be written afterwards."""
    from .io.files import describe_os_error, refuse_file_parent

    if path.is_dir():
        raise CortexError(f"{what} '{path}' is a folder; name a file")
    refuse_file_parent(path, what)
    probe = path.with_name(path.name + ".partial")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if probe.exists():  # a leftover of a killed run (write_json replaces it): can we write there?
            with open(probe, "a"):
                return
        with open(probe, "x"):
            pass
    except OSError as exc:
        raise CortexError(f"cannot write {what} '{path}': {describe_os_error(exc)}") from None
    probe.unlink()


def _run(args) -> int:
    from .io.claim import check_output, claim_output
    from .io.trajectory import committed_frames, partial_path
    from .scene import load_scene
    from .simulation.run import stop_reason

    t0 = time.perf_counter()
    sim = None
    if args.summary is not None:  # first: every exit after this one writes it
        _writable_file(args.summary, "--summary")

    def kept() -> tuple[int, float | None]:
        try:
            return committed_frames(partial_path(args.output))
        except CortexError:
            return 0, None

    def summary(status: str, exc: BaseException | None = None, stopped: str | None = None) -> None:
        """Write --summary; one that cannot be written is a warning: it does not turn a finished run
        into a failure, nor hide the error that ended one."""
        if args.summary is None:
            return
        import resource

        from .io import write_json

        info = sim.summary() if sim is not None else {}
        if exc is not None:
            info["stopped"] = stopped or stop_reason(exc)
            n, t = kept()  # how far it got: the last complete frame
            if n:
                info["t_reached"] = t
            info["frames_kept"] = n
        error = None if exc is None else f"{type(exc).__name__}: {exc}"
        info.update(
            status=status,
            error=error,
            wall_s=time.perf_counter() - t0,
            output=str(args.output),
            peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        )
        try:
            write_json(info, args.summary)
        except OSError as err:
            from .io.files import describe_os_error

            print(
                f"cortex-ti: warning: cannot write the summary '{args.summary}': {describe_os_error(err)}",
                file=sys.stderr,
            )

    try:  # input errors first, before Taichi starts; each one still writes the summary
        if args.force and args.resume:
            raise CortexError("--force starts over and --resume continues: pass one of them")
        scene = load_scene(args.scene, args.overrides)
        settings = scene.settings
        threads = _threads(args)
    except CortexError as exc:
        summary("failed", exc, stopped="input")
        raise

    with interruptible(), claim_output(args.output):
        # refused: no summary, as the one at --summary may be that of the run whose output this protects
        check_output(args.output, args.resume, args.force)
        try:
            from .models import make_runner

            sim = make_runner(scene, args.arch, threads)  # the scene's model (cortex_ti.models.MODELS)
            check_interrupted()  # a signal whose exception start-up code swallowed
            out = sim.run(args.output, resume=args.resume, force=args.force)
        except BaseException as caught:
            exc = interruption(caught)
            if exc is None:
                summary("failed", caught)
                raise
            summary("interrupted", exc)
            n, t = kept()
            where = (
                f"{n} frame{'s' if n > 1 else ''} to t = {t:.6g} kept in {partial_path(args.output)}; "
                "continue with --resume"
                if n
                else "no frame was complete, nothing was kept"
            )
            print(f"cortex-ti: interrupted ({exc.name}); {where}", file=sys.stderr)
            return exc.exit_code
        summary("ok")
    log.info("wrote %s (%s, %.1f s)", out, settings.describe_numerics(), time.perf_counter() - t0)
    print(out)
    return 0


def _check(args) -> int:
    """``run`` without the run: the scene, its mesh, fields and patterns (read, imported and called),
    the mesh motion, transport and remeshing set up as the run sets them up, and a dynamic scene's
    steps against what its scheme can honour; values that are legal but unphysical are warned of."""
    from .scene import load_scene

    scene = load_scene(args.scene, args.overrides)
    settings = scene.settings
    effects = ", ".join(sorted(scene.effects))
    if settings.model == "axisymmetric":
        from .models import make_runner

        make_runner(scene)  # the model's set-up (no Taichi), with its warning on an extensile tension
        from .axisymmetric.run import axisymmetric_tension

        axisymmetric_tension(settings)  # runs python patterns, refuses one that varies about z
        print(f"{scene.name}: valid ({settings.describe_numerics()}, effects: {effects})")
    else:
        from .simulation.run import step_scheme, unphysical
        from .simulation.setup import SceneSetup

        # everything a run sets up before its first solve, as the run sets it up (without Taichi):
        # the mesh, its topology, fields and patterns evaluated on the mesh before
        # mesh.transform/shear, the transport of each field, the mesh motion, the remeshing's extra
        sim = SceneSetup(scene)
        if settings.dynamic:
            step_scheme(sim)  # the ALE step limit, as a run refuses it
        for sentence in unphysical(sim):
            log.warning("scene '%s': %s", scene.name, sentence)
        print(f"{scene.name}: valid ({sim.mesh.n_nodes} nodes, effects: {effects})")
        print(f"  numerics: {settings.describe_numerics()}")
    if settings.dynamic:
        print(f"  time: {settings.time.describe()}")
    return 0


def _export(args) -> int:
    from .io.export import EXPORT_FORMATS, export_trajectory

    fmt = args.fmt
    if fmt is None:
        by_suffix = {suffix: name for name, suffix in EXPORT_FORMATS.items()}
        fmt = by_suffix.get(args.output.suffix.lower(), "vtkhdf") if args.output is not None else "vtkhdf"
    if fmt not in EXPORT_FORMATS:
        raise CortexError(f"unknown --format '{fmt}'; choose one of: {', '.join(EXPORT_FORMATS)}")
    if args.every < 1:
        raise CortexError(f"--every must be >= 1, got {args.every}")
    if not args.trajectory.exists():
        raise CortexError(f"trajectory file '{args.trajectory}' does not exist")
    print(export_trajectory(args.trajectory, args.output, fmt, args.every, force=args.force))
    return 0


def _plot(args) -> int:
    from .io import load_trajectory
    from .io.files import refuse_file_parent
    from .viz.commands import announce, parse_view
    from .viz.figure import frame_figure
    from .viz.plotting import COLORS, DEFAULT_SERIES, figure_format, frame_index, save_figure, series_names
    from .viz.render import Renderer, choose_renderer

    # the arguments first, so that a typo costs no reading
    figure_format(args.output)
    refuse_file_parent(Path(args.output), "the figure")  # before anything is said or drawn
    if args.color not in COLORS:
        raise CortexError(f"unknown --color '{args.color}'; choose one of: {', '.join(COLORS)}")
    view = parse_view(args.view)
    if not args.dpi > 0:
        raise CortexError(f"--dpi must be > 0, got {args.dpi:g}")
    ds = load_trajectory(args.trajectory)
    available = series_names(ds)
    if args.series is None:
        series = [name for name in DEFAULT_SERIES if name in available]
    else:
        series = [name.strip() for name in args.series.split(",") if name.strip()]
        unknown = [name for name in series if name not in available]
        if unknown:
            raise CortexError(
                f"unknown series {', '.join(repr(n) for n in unknown)}: '{args.trajectory}' has "
                f"{', '.join(available) or 'no per-frame variables'}"
            )
    frame = args.frame if args.frame is not None else args.time if args.time is not None else -1
    frame = frame_index(ds, frame)  # refused before anything is said or drawn
    if "mesh_id" in ds and args.renderer == "auto":  # the PyVista pictures keep one mesh
        renderer = Renderer("matplotlib", "a remeshed run (frames on several meshes)")
    else:
        renderer = choose_renderer(args.renderer)
    announce(renderer)
    fig = frame_figure(ds, frame, args.color, not args.no_arrows, series, view=view, dpi=args.dpi, renderer=renderer)
    print(save_figure(fig, args.output))
    return 0


def _modes(args) -> int:
    from .simulation.modes import frame_modes

    print(frame_modes(args.trajectory, args.time, args.dt, args.growing, args.stiffest, args.sparse))
    return 0


def _twin(args) -> int:
    from .axisymmetric.compare import twin_report

    print(twin_report(args.trajectories, args.convergence))
    return 0


def _angles(args) -> int:
    from .io.angles import angle_report

    print(angle_report(args.trajectory, args.below, args.worst))
    return 0


def _scenes(_args) -> int:
    from .scene import builtin_scene_names, load_scene

    for name in builtin_scene_names():
        desc = " ".join(load_scene(name)["description"].split())
        print(f"{name:28s} {desc[:90]}")
    return 0


def _schema(_args) -> int:
    import json

    from .scene import full_schema

    print(json.dumps(full_schema(), indent=2))
    return 0


def main(argv: list[str] | None = None) -> int:
    """The command line (``argv`` None: the program's own arguments, and then a signal that arrives
    after the command is done, while the interpreter shuts down, is ignored: what it did stands)."""
    program = argv is None
    with interruptible(restore=not program):  # first: a signal from now on ends the command as documented
        try:
            status = _main(argv)
        except BaseException as caught:
            exc = interruption(caught)
            if exc is None:
                raise
            print(f"cortex-ti: interrupted ({exc.name})", file=sys.stderr)
            status = exc.exit_code
        if program:
            for sig in (signal.SIGINT, signal.SIGTERM):
                signal.signal(sig, signal.SIG_IGN)
        return status


def _main(argv: list[str] | None) -> int:
    from .io.files import describe_os_error

    args = _parser().parse_args(argv)
    # our own messages: INFO by default, DEBUG with -v; other libraries stay at WARNING
    logging.basicConfig(level=logging.WARNING, format="%(levelname)s %(name)s: %(message)s")
    log.setLevel(logging.DEBUG if args.verbose else logging.INFO)
    try:
        commands = {
            "run": _run,
            "check": _check,
            "export": _export,
            "plot": _plot,
            "modes": _modes,
            "twin": _twin,
            "angles": _angles,
            "scenes": _scenes,
            "schema": _schema,
        }
        return commands[args.command](args) if args.command in commands else args.handler(args)
    except CortexError as exc:
        check_interrupted()  # a signal some library reported as its own error is the signal
        behind = exc.__cause__ is not None and not isinstance(exc.__cause__, CortexError)
        hint = " (--debug shows its traceback)" if behind and not args.debug else ""
        print(f"cortex-ti: error: {exc}{hint}", file=sys.stderr)
        if args.debug:
            import traceback

            traceback.print_exception(exc.__cause__ or exc, file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `cortex-ti scenes | head`: the reader left; say nothing more
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except OSError as exc:  # a file or folder the command could not read or write
        check_interrupted()
        print(f"cortex-ti: error: {describe_os_error(exc)}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
