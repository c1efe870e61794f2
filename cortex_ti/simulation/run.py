"""Running a scene to its trajectory file, and what the run cost.

A static scene solves once and writes one frame. A dynamic scene advances the shape
(:func:`cortex_ti.dynamics.integrate.integrate`) and writes a frame every ``time.save_every``,
flushed as it goes to ``<output>.partial``; an interrupted run continues from there with
``resume`` (:class:`cortex_ti.io.trajectory.ResumeState`), and the finished file is renamed
atomically to ``output``. ``resume`` on a finished trajectory with a later ``time.t_end`` extends it:
its frames are copied to the partial file and the run continues from the last one.

How a run ended is one of :data:`STOP_REASONS` (the summary's ``stopped``); a run that fails or is
interrupted still leaves its :class:`RunReport` (real step and solve counts) on the simulation.
:func:`~cortex_ti.errors.interruptible` makes SIGTERM end a run the way Ctrl-C does
(:class:`~cortex_ti.errors.Interrupted`).
"""

from __future__ import annotations

import logging
import os
import shutil
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..about import provenance
from ..analysis.curved_measures import curved_measures
from ..analysis.diagnostics import DIAGNOSTIC_ATTRS, NECK_ATTRS, frame_diagnostics, neck_radius
from ..dynamics.guard import StabilityGuard, extensile_tension
from ..dynamics.integrate import RunStats, integrate
from ..dynamics.motion import ale_step_limit, ale_stiffest_rate
from ..dynamics.schemes import make_scheme
from ..dynamics.state import State
from ..errors import (
    CortexError,
    Interrupted,
    MeshError,
    SceneError,
    SolverError,
    StabilityError,
    check_interrupted,
    interruptible,
)
from ..io.claim import check_output, claim_output
from ..io.files import OutputError, describe_os_error
from ..io.trajectory import FIELD_PREFIX, ResumeState, TrajectoryWriter, partial_path
from ..physics.fields import tension_of
from ..physics.patterns import evaluate_active_stress
from ..surface.transport import DENSITY

if TYPE_CHECKING:  # pragma: no cover
    from .core import Simulation
    from .setup import SceneSetup

log = logging.getLogger(__name__)

__all__ = [
    "SOLVE_DIAGNOSTICS",
    "FRAME_EXTRAS",
    "STOP_REASONS",
    "EXIT_CODES",
    "Interrupted",
    "RunReport",
    "check_interrupted",
    "interruptible",
    "run_scene",
    "run_summary",
    "stop_reason",
    "step_scheme",
    "unphysical",
]

#: Why a run ended (the summary's ``stopped``): the value, and what it means.
STOP_REASONS = {
    "static": "a static scene: solved once",
    "t_end": "reached time.t_end",
    "steady": "max |v_n| fell below time.steady_tol",
    "neck": "the neck radius fell to time.stop_neck (the axisymmetric model: or to axisymmetric.stop_neck)",
    "interrupted": "SIGINT (Ctrl-C) or SIGTERM: the frames so far are kept for --resume",
    "guard": "the stability guard stopped it (dynamics.guard)",
    "solver": "a solve failed",
    "io": "writing a file failed (full disk, I/O error)",
    "input": "the input was refused (the scene, its mesh, a pattern, an option): most before the run started",
    "error": "another error",
}

#: Exit status of ``cortex-ti`` by how it ended.
EXIT_CODES = {
    "ok": 0,
    "error": 2,  # bad input, a failed solve, the guard, a file that cannot be written: one line
    "internal": 1,  # a bug: the traceback is kept
    "SIGINT": 130,  # 128 + 2, as a shell reports Ctrl-C
    "SIGTERM": 143,  # 128 + 15
}


def stop_reason(exc: BaseException | None) -> str:
    """The :data:`STOP_REASONS` value of a run that raised ``exc``."""
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted"
    if isinstance(exc, StabilityError):
        return "guard"
    if isinstance(exc, SolverError):
        return "solver"
    if isinstance(exc, (OutputError, OSError)):
        return "io"
    if isinstance(exc, (SceneError, MeshError)):
        return "input"
    return "error"


#: Per-frame diagnostics of the solve written with every frame
SOLVE_DIAGNOSTICS = {
    "force_residual": (
        ("time",),
        {
            "units": "zeta_0/R0",
            "long_name": "force the solve leaves unbalanced: "
            "|K x + F^T lambda - f| (rayleigh_p1), |M x + p P - r| (paper); "
            "lsq_residual in older files",
        },
    ),
    "relative_residual": (("time",), {"units": "1", "long_name": "force_residual relative to |f| (or |r|)"}),
    "constraint_violation": (
        ("time",),
        {"units": "1", "long_name": "largest relative violation of the constraints (Eqs. 35-37)"},
    ),
    "kkt_residual": (("time",), {"units": "1", "long_name": "relative residual of the bordered normal equations"}),
}

#: Everything a frame holds beyond the standard variables: the solver's normals, the solve's and
#: the shape's diagnostics, and (dynamic runs) the step the integrator takes next.
FRAME_EXTRAS = {
    "normal": (
        ("time", "node", "xyz"),
        {
            "units": "1",
            "long_name": "unit normal of the fitted surface at the nodes (the direction the nodes move along)",
        },
    ),
    **SOLVE_DIAGNOSTICS,
}
_DYNAMIC_EXTRAS = {
    **{k: (("time",), v) for k, v in DIAGNOSTIC_ATTRS.items()},
    "dt": (("time",), {"units": "t_a", "long_name": "time step the integrator takes next"}),
}


@dataclass
class RunReport:
    """What a run did: the file it wrote (or the partial file it kept) and, for a dynamic run, its
    steps and solves; ``stopped`` one of :data:`STOP_REASONS`."""

    path: Path
    stats: RunStats | None = None  # None for a static run
    stopped: str = "static"
    solved: int = 1  # solves of a static run (0 if it failed before its solve)

    @property
    def solves(self) -> int:
        return self.solved if self.stats is None else self.stats.solves


def output_attrs(sim: Simulation) -> dict:
    """The global attributes of the scene's trajectory (with :func:`cortex_ti.provenance`)."""
    s = sim.settings
    return {
        "scene": sim.scene.to_yaml(),
        "effects": ",".join(sorted(s.effects)),
        "fit_scheme": s.numerics.fit,
        "solver_backend": s.solver.backend,
        "n_nodes": sim.mesh.n_nodes,
        **provenance(),
    }


def field_values(sim: Simulation) -> dict:
    """The node values of each ``field`` pattern of the scene (``field_values_<i>``, pattern i), written
    once into the trajectory so that it answers for itself after the field's file moved
    (:attr:`cortex_ti.io.trajectory.Trajectory.scene`)."""
    out = {}
    for i, pattern in enumerate(sim.settings.patterns):
        if pattern.get("type") == "field":
            out[f"{FIELD_PREFIX}{i}"] = (
                evaluate_active_stress(sim.mesh.points, [pattern]),
                {
                    "units": "zeta_0",
                    "long_name": f"values of the field pattern active_stress.{i} at the nodes "
                    f"(read from {pattern.get('file')}, times its scale)",
                },
            )
    return out


def run_scene(
    sim: Simulation, output: Path, resume: bool = False, progress: bool = True, force: bool = False
) -> RunReport:
    """Run ``sim``'s scene and write its trajectory to ``output`` (see the module docstring). What is
    already at ``output`` is treated as the command line does (:func:`cortex_ti.io.claim.check_output`:
    refused unless ``resume`` or ``force``)."""
    sim.seconds = {}
    sim.report = None
    with claim_output(output):
        check_output(output, resume, force)
        if sim.settings.dynamic:
            return _run_dynamic(sim, output, resume, progress, force)
        return _run_static(sim, output, force)


def _failed(sim: Simulation, output: Path, exc: BaseException, stats: RunStats | None, t0: float) -> None:
    """Leave what a run that raised ``exc`` did on ``sim.report``: why it stopped, its real counts."""
    reason = stop_reason(exc)
    partial = partial_path(output)
    if stats is not None:
        stats.stopped = reason
        stats.wall = time.perf_counter() - t0
    sim.report = RunReport(path=partial if partial.exists() else output, stats=stats, stopped=reason, solved=0)


def _run_static(sim: Simulation, output: Path, force: bool = False) -> RunReport:
    t0 = time.perf_counter()
    try:
        return _write_static(sim, output, force)
    except BaseException as exc:
        _failed(sim, output, exc, None, t0)
        raise


def _write_static(sim: Simulation, output: Path, force: bool = False) -> RunReport:
    with TrajectoryWriter(
        output,
        sim.mesh.faces,
        sim.mesh.n_nodes,
        output_attrs(sim),
        extra_vars=FRAME_EXTRAS,
        node_vars=field_values(sim),
        force=force,
    ) as writer:
        check_interrupted()
        ev = sim.evaluate(sim.mesh.points)
        sol = ev.solution
        log.info(
            "solved %d nodes: residual %.2e, constraints %.1e, %s",
            sim.mesh.n_nodes,
            sol.info.relative_residual,
            sol.info.constraint_violation,
            ", ".join(f"{k} {v:.3f} s" for k, v in sol.seconds.items()),
        )
        if not np.all(np.isfinite(sol.velocity)):
            raise CortexError("the solve produced non-finite velocities")
        pressure = sol.pressure if sim.settings.has("incompressibility") else float("nan")
        writer.append(0.0, sol.points, sol.velocity, sim.zeta, pressure, normal=sol.normal, **sol.diagnostics)
    return RunReport(path=output)


def extend_finished(output: Path) -> bool:
    """``resume`` of a finished trajectory: copy ``output`` to its partial file (under a temporary
    name, then renamed) so that the run continues from its last frame; the finished file stays until
    the longer one replaces it. True if it copied."""
    partial = partial_path(output)
    if partial.exists() or not output.is_file():
        return False
    tmp = partial.with_name(partial.name + ".copy")
    try:
        shutil.copyfile(output, tmp)
        os.replace(tmp, partial)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise OutputError(
            f"cannot copy '{output}' to '{partial}' to extend it ({describe_os_error(exc)}); '{output}' is unchanged"
        ) from None
    return True


def _run_dynamic(sim: Simulation, output: Path, resume: bool, progress: bool, force: bool = False) -> RunReport:
    start = time.perf_counter()
    seen: dict = {}
    try:
        return _integrate_to_file(sim, output, resume, progress, seen, force)
    except BaseException as exc:
        _failed(sim, output, exc, seen.get("stats"), start)
        raise


def cap_ale_step(sim: Simulation, scheme, t: float | None = None) -> None:
    """With ``mesh.motion: ale``, keep the scheme's steps within the stability limit of the explicit
    mesh velocity about the current reference triangles (:func:`cortex_ti.dynamics.motion.ale_step_limit`):
    an adaptive scheme's largest step is capped there, unless the scene asked for a larger
    ``time.dt_max``, and a fixed step above it is refused, each with one line naming the keys."""
    s = sim.settings
    if s.mesh.motion != "ale":
        return
    limit = ale_step_limit(scheme.explicit_interval, sim.motion_context)
    when = "" if t is None else f" (the mesh remeshed at t = {t:.4g})"
    asked = (s.time.dt_max if s.time.dt_max_set else None) if scheme.adaptive else s.time.dt
    if asked is not None and asked > limit:
        key = "dt_max" if scheme.adaptive else "dt"
        raise SceneError(
            f"scene '{s.name}': time.{key} = {float(asked):g} is above the largest step {limit:.3g} with which "
            f"time.scheme = {s.time.scheme} keeps the ALE mesh velocity stable on this mesh{when} (its stiffest "
            f"mode decays at up to {ale_stiffest_rate(sim.motion_context):.3g} per t_a, mesh.ale_time = "
            f"{s.mesh.ale_time:g}): lower time.{key} or raise mesh.ale_time"
        )
    if scheme.adaptive:
        scheme.dt_max = min(scheme.dt_max, limit)
        scheme.dt_cap = min(scheme.dt_cap, limit)


def step_scheme(sim: Simulation | SceneSetup):
    """The scene's time scheme as a run builds it, its steps capped (or refused) by the ALE limit
    (:func:`cap_ale_step`): what ``cortex-ti check`` asks of a dynamic scene without running it."""
    st = sim.settings.time
    evaluate = getattr(sim, "evaluate", None)  # a SceneSetup (check) has none: the scheme is not stepped
    scheme = make_scheme(st.scheme, evaluate, tol=st.tol, dt_max=st.dt_max, implicit=st.implicit_tension)
    cap_ale_step(sim, scheme)
    return scheme


def unphysical(sim: Simulation | SceneSetup) -> list[str]:
    """Sentences on values a scene may legally hold but that no cortex has: an extensile active
    tension (its sign opposite to the contractile one the model is made for; the guard says so if
    it stops the run) and a negative density field. A run logs them as warnings at its start, and
    ``cortex-ti check`` too."""
    out = []
    physical = extensile_tension(sim.zeta)
    if physical is not None:
        out.append(f"{physical}; the guard will say so if it stops the run")
    for spec in sim.fields:
        if spec.kind != DENSITY:
            continue
        values = np.asarray(sim.state0.fields[spec.name], dtype=float)
        neg = values < 0.0
        if np.any(neg):
            out.append(
                f"the initial {spec.name} density is negative at {int(neg.sum())} of {values.size} nodes "
                f"(down to {values.min():.3g}): a density is an amount per area, never below 0"
            )
    return out


def _integrate_to_file(
    sim: Simulation, output: Path, resume: bool, progress: bool, seen: dict, force: bool = False
) -> RunReport:
    st = sim.settings.time
    scheme = step_scheme(sim)
    start, t0, dt = sim.state0, 0.0, min(st.dt, scheme.dt_cap)
    extended = resume and extend_finished(output)
    state = ResumeState.read(output) if resume else None
    axis = sim.settings.pattern_axis
    has_p = sim.settings.has("incompressibility")
    stored = stored_fields(sim)
    attrs = output_attrs(sim)
    done = state is not None and state.time >= st.t_end - 1e-9 * max(st.save_every, 1e-12)
    if done:  # the file already reaches past time.t_end: its scene records the t_end its frames reach
        attrs["scene"] = sim.scene.with_overrides([f"time.t_end={state.time!r}"]).to_yaml()
    try:  # first, so that a refused resume (a changed scene: the key named) comes before any log line
        writer = TrajectoryWriter(
            output,
            sim.state0.faces,  # the initial mesh (segment 0); a resumed remeshed run continues its last segment
            sim.state0.n_nodes,
            attrs,
            extra_vars={
                **FRAME_EXTRAS,
                **_DYNAMIC_EXTRAS,
                **({k: (("time",), v) for k, v in NECK_ATTRS.items()} if st.stop_neck is not None else {}),
                **{spec.var: (("time", "node"), dict(spec.attrs)) for spec in stored},
            },
            resume=state is not None,
            node_vars=field_values(sim),
            force=force,
        )
    except BaseException as exc:
        if not extended:
            raise
        # the copy of the finished file made to extend it goes: the finished file is unchanged
        partial_path(output).unlink(missing_ok=True)
        prefix = f"cannot resume '{partial_path(output)}'"
        if isinstance(exc, CortexError) and str(exc).startswith(prefix):
            said = str(exc)[len(prefix) :].replace(
                "pass --force (or delete it) to start over", "pass --force to replace it"
            )
            raise CortexError(f"cannot extend '{output}'{said}") from None
        raise
    if extended:
        log.info("extending the finished run %s from its last frame", output)
    history = read_history(output, state) if state is not None and scheme.dense else None
    if state is None:
        history_path(output).unlink(missing_ok=True)  # a stale one belongs to another run
    restored = None
    if state is not None:
        t0 = state.time
        if scheme.dense:
            # a multistep scheme continues from its step history when the file's frames have it
            # (read_history); else it restarts with its Euler start of time.dt from the last frame
            if history is not None:
                restored = (history, float(history["dt"]))
        elif scheme.adaptive and state.dt is not None:
            # continue with the controller's step (a fixed-step scheme takes the scene's, so
            # --resume --set time.dt=... after a stability stop does what it says)
            dt = min(state.dt, scheme.dt_max)
        try:
            start = resumed_state(sim, state)
        except BaseException:
            writer.close_partial()
            raise
        if state.segment > 0:  # continued on a remeshed segment: its reference triangles' limit too
            cap_ale_step(sim, scheme)
            dt = min(dt, scheme.dt_cap)
        log.info("resuming %s at t = %.4g (frame %d, dt = %.3g)", output, t0, state.n_frames, dt)
    elif resume:
        log.info("nothing to resume at %s.partial; starting from t = 0", output)
    for sentence in unphysical(sim):
        log.warning("scene '%s': %s; the run goes on", sim.settings.name, sentence)
    caveat = sim.settings.numerics.formulation_entry.dynamic_caveat
    if caveat:
        log.warning("scene '%s': numerics.formulation = %s: %s", sim.settings.name, sim.formulation, caveat)

    neck = {"radius": np.inf, "t": None}  # the last frame's neck, with time.stop_neck
    curved = sim.settings.numerics.formulation_entry.curved

    def on_frame(t, ev, dt_next, final=False):
        diag = frame_diagnostics(ev.points, sim.mesh.faces, ev.velocity, ev.normal, axis=axis)
        if curved:  # the volume, area and radii of the curved cells, not of their flat vertex view
            diag.update(curved_measures(ev.points, sim.mesh.faces, axis=axis))
        if st.stop_neck is not None:
            radius = neck_radius(ev.points, sim.mesh.faces, axis=axis)[0]
            neck.update(radius=radius if np.isfinite(radius) else np.inf, t=t)
            diag["neck_radius"] = radius
        fields = ev.state.fields
        writer.append(
            t,
            ev.points,
            ev.velocity,
            tension_of(fields, sim.mesh.n_nodes, sim.settings),
            ev.pressure if has_p else float("nan"),
            normal=ev.normal,
            dt=dt_next,
            hold=True,  # committed with the step's other frames, in watch()
            **ev.solution.diagnostics,
            **diag,
            **{spec.var: fields[spec.name] for spec in stored},
        )

    if done:
        log.info("%s reaches t = %.6g already (time.t_end = %.6g): nothing to compute", output, state.time, st.t_end)
        seen["stats"] = RunStats(t=state.time)
        return RunReport(path=writer.finish(), stats=seen["stats"], stopped="t_end")
    bar = _ProgressBar(t0, st.t_end) if progress else None
    remesh = None
    if sim.settings.mesh.remesh is not None:

        def remesh(state, t):
            new = sim.remesh_state(state, t)
            if new is not None:
                cap_ale_step(sim, scheme, t)  # the new reference triangles have their own stiffness
            return new

        sim.on_remesh = lambda new: writer.start_segment(new.faces, new.n_nodes, new.points)

    def stop_at_neck(t):
        """``time.stop_neck``: the run ends at the first frame whose neck is at or below it."""
        if neck["radius"] > st.stop_neck:
            return None
        log.warning(
            "%s: the neck radius %.4g R0 at t = %.6g fell to time.stop_neck = %g: the surface would pinch into "
            "two, which this model does not go through; the run stops here, its frames kept",
            sim.settings.name,
            neck["radius"],
            neck["t"],
            st.stop_neck,
        )
        return "neck"

    saved = {"frames": writer.n_frames}

    def watch(t, ev, dt, stats):
        writer.commit()  # the frames of the step just made, in one write
        if scheme.dense and writer.n_frames != saved["frames"]:  # the history those frames continue from
            write_history(output, scheme, dt, writer.n_frames, writer.last_time)
            saved["frames"] = writer.n_frames
        check_interrupted()
        seen["stats"] = stats  # the counts so far, for the summary of a run that does not finish
        if bar is not None:
            bar(t, ev, dt, stats)

    try:
        stats = integrate(
            sim.evaluate,
            start,
            t0,
            st.t_end,
            dt,
            scheme,
            st.save_every,
            on_frame,
            steady_tol=st.steady_tol,
            progress=watch,
            write_first=state is None,
            implicit=st.implicit_tension,
            guard=_guard(sim),
            save_times=st.save_times,
            remesh=remesh,
            stop=stop_at_neck if st.stop_neck is not None else None,
            restored=restored,
        )
    except BaseException:
        sim.on_remesh = None
        writer.close_partial()
        if seen.get("stats") is not None and writer.n_frames:
            seen["stats"].t = writer.last_time
        raise
    finally:
        if bar is not None:
            bar.close()
    if stats.stopped == "neck":  # a dense scheme's step may end past the frame that crossed
        stats.t = neck["t"]
    seen["stats"] = stats
    sim.on_remesh = None
    path = writer.finish()
    history_path(output).unlink(missing_ok=True)
    per = {k: v / max(stats.solves, 1) * 1e3 for k, v in sim.seconds.items()}
    log.info(
        "%s: t = %.4g reached (%s) in %.1f s: %d steps, %d rejected, %d solves; per solve %s",
        sim.settings.name,
        stats.t,
        stats.stopped,
        stats.wall,
        stats.steps,
        stats.rejected,
        stats.solves,
        ", ".join(f"{k} {v:.1f} ms" for k, v in per.items()),
    )
    return RunReport(path=path, stats=stats, stopped=stats.stopped)


def history_path(output: str | os.PathLike) -> Path:
    """Beside ``<output>.partial``: the step history of a dense scheme (bdf2) at its last frame."""
    return Path(os.fspath(partial_path(output)) + ".history.npz")


def write_history(output, scheme, dt: float, n_frames: int, frame_time: float) -> None:
    """Save ``scheme``'s step history (:meth:`~cortex_ti.dynamics.schemes.BDF2.checkpoint`), the
    step it proposes next and the frames of the partial file it belongs to, atomically (a
    temporary file renamed over the last one)."""
    path = history_path(output)
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        np.savez(
            f,
            dt=np.array(float(dt)),
            n_frames=np.array(int(n_frames)),
            frame_time=np.array(frame_time),
            **scheme.checkpoint(),
        )
    os.replace(tmp, path)


def read_history(output, state: ResumeState) -> dict | None:
    """The saved step history that continues the partial file's last frame, or None (no file, or one
    of other frames: the run was killed between its frames and its history)."""
    path = history_path(output)
    if not path.exists():
        return None
    try:
        with np.load(path) as data:
            history = {k: data[k] for k in data.files}
    except (OSError, ValueError, KeyError) as exc:
        log.warning("cannot read %s (%s): restarting the scheme from the last frame", path, exc)
        return None
    if int(history["n_frames"]) != state.n_frames or float(history["frame_time"]) != state.time:
        log.info("%s belongs to other frames: restarting the scheme from the last frame", path)
        return None
    newest = history[f"{int(history['n']) - 1}__points"]
    if int(history["n"]) < 2 or newest.shape != np.shape(state.points):
        return None  # at the start (one state): the restart is the same computation
    return history


def stored_fields(sim: Simulation) -> list:
    """The fields a trajectory stores as variables of their own: all but a prescribed tension that is
    the whole active tension (the ``active_stress`` variable already holds it)."""
    specs = sim.fields
    alone = [spec.name for spec in specs if spec.tension is not None] == ["prescribed_tension"]
    return [spec for spec in specs if not (alone and spec.name == "prescribed_tension")]


def frame_fields(sim: Simulation, stored: dict, active_stress: np.ndarray, where: str) -> dict:
    """``sim``'s fields at a stored frame: each from its variable in ``stored`` (variable name ->
    nodal values), a prescribed tension that is the whole tension from ``active_stress`` (a
    trajectory stores it only there; files written before the fields existed hold only that)."""
    fields = {}
    for spec in sim.fields:
        if spec.var in stored:
            fields[spec.name] = np.asarray(stored[spec.var], dtype=float)
        elif spec.name == "prescribed_tension":
            fields[spec.name] = np.asarray(active_stress, dtype=float)
        else:
            raise CortexError(f"{where} holds no values of the field {spec.var!r}")
    return fields


def resumed_state(sim: Simulation, resume: ResumeState) -> State:
    """The state of the last complete frame of an interrupted run: its points and every field
    (:func:`frame_fields`)."""
    fields = frame_fields(sim, resume.fields, resume.active_stress, f"cannot resume {resume.path}: it")
    points = np.asarray(resume.points, dtype=float)
    if resume.segment > 0:  # the run had remeshed: continue on the frame's mesh
        sim.continue_segment(points, resume.triangles, resume.reference, resume.segment)
    return State(points, fields, sim.mesh.faces)


def run_summary(sim: Simulation) -> dict:
    """What ``sim``'s last run took (steps, solves, time per stage), and how it was set up."""
    s = sim.settings
    report = sim.report
    st = sim.stats
    solves = report.solves if report is not None else 0
    stopped = report.stopped if report is not None else "static"
    out = {
        "scene": s.name,
        "model": s.model,
        "n_nodes": sim.mesh.n_nodes,
        "fit": s.numerics.fit,
        "solver_backend": s.solver.backend,
        "effects": sorted(s.effects),
        "steps": st.steps if st is not None else 0,
        "rejected": st.rejected if st is not None else 0,
        "solves": solves,
        "t_reached": st.t if st is not None else 0.0,
        "stopped": stopped,
        "implicit_tension": s.time.implicit_tension,
        "formulation": s.numerics.formulation,
        "fit_residual_weight": s.numerics.fit_residual_weight,
    }
    out.update({f"ms_{k}_per_solve": 1e3 * v / max(solves, 1) for k, v in sim.seconds.items()})
    out.update(factorizations=sim.solver.n_factorizations, krylov_iterations=sim.solver.n_iterations)
    if s.mesh.remesh is not None:
        out.update(
            remeshes=st.remeshes if st is not None else 0,
            remesh_seconds=st.remesh_wall if st is not None else 0.0,
            symbolic_analyses=sim.solver.n_analyses,
            final_nodes=sim.mesh.n_nodes,
        )
    return out


class _ProgressBar:
    """tqdm bar over simulated time; silent when stderr is not a terminal."""

    def __init__(self, t0: float, t_end: float):
        from tqdm import tqdm

        self._bar = tqdm(
            total=round(t_end, 6),
            initial=round(t0, 6),
            unit="t_a",
            disable=None,
            bar_format="{l_bar}{bar}| t={n:.3f}/{total:.3f} [{elapsed}<{remaining}{postfix}]",
        )
        self._t = t0
        self._start = time.perf_counter()

    def __call__(self, t, ev, dt, stats):
        if self._bar.disable:
            return
        self._bar.update(round(t - self._t, 6))
        self._t = t
        rate = stats.steps / max(time.perf_counter() - self._start, 1e-9)
        vmax = float(np.max(np.abs(ev.normal_speed)))
        self._bar.set_postfix_str(f"{rate:.1f} steps/s, dt={dt:.2g}, max|v_n|={vmax:.2e}", refresh=False)

    def close(self):
        self._bar.close()


def _guard(sim) -> StabilityGuard:
    """The run's stability guard: the mesh, the tension, and (for a cortex without bending resistance,
    which a compressive stress wrinkles at the mesh scale) the in-plane viscosities, so that a stop
    can say where the stress is compressive."""
    ph = sim.physics
    flat = "bending_viscosity" not in ph.effects or (ph.eta_bar == 0.0 and ph.eta_bar_b == 0.0)
    eta_s = ph.eta_s if "shear_viscosity" in ph.effects else 0.0
    eta_b = ph.eta_b if "bulk_viscosity" in ph.effects else 0.0
    return StabilityGuard(
        faces=sim.mesh.faces,
        zeta=sim.zeta,
        viscosity=(eta_s, eta_b) if flat else None,
        tension=lambda fields, n: tension_of(fields, n, sim.settings),
    )
