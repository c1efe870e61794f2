"""Running a scene to its trajectory file.

A static scene solves once and writes one frame. A dynamic scene advances the shape
(:func:`cortex_ti.dynamics.integrate.integrate`, with the hooks of :class:`FileHooks`: the frames,
the remeshing, the neck stop, the commits) and writes a frame every ``time.save_every``,
flushed as it goes to ``<output>.partial``; an interrupted run continues from there with
``resume`` (:mod:`cortex_ti.simulation.resume`), and the finished file is renamed
atomically to ``output``. ``resume`` on a finished trajectory with a later ``time.t_end`` extends it:
its frames are copied to the partial file and the run continues from the last one.

:func:`run_scene` returns the run's :class:`~cortex_ti.simulation.report.RunReport`; a run that fails
or is interrupted raises with its report (why it stopped, its real step and solve counts) on the
exception's ``run_report``. :func:`~cortex_ti.errors.interruptible` makes SIGTERM end a run the way
Ctrl-C does (:class:`~cortex_ti.errors.Interrupted`).
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..about import provenance
from ..analysis.curved_measures import curved_measures
from ..analysis.diagnostics import DIAGNOSTIC_ATTRS, NECK_ATTRS, frame_diagnostics, neck_radius
from ..dynamics.guard import StabilityGuard, extensile_tension
from ..dynamics.integrate import RunHooks, RunStats, integrate
from ..dynamics.motion import ale_step_limit, ale_stiffest_rate
from ..dynamics.schemes import make_scheme
from ..errors import CortexError, Interrupted, SceneError, check_interrupted, interruptible
from ..io.claim import check_output, claim_output
from ..io.trajectory import FIELD_PREFIX, ResumeState, TrajectoryWriter, partial_path
from ..physics.fields import tension_of
from ..physics.patterns import evaluate_active_stress
from ..surface.transport import DENSITY
from .bodies import BODY_VARIABLES, MAX_BODIES, body_diagnostics
from .report import EXIT_CODES, STOP_REASONS, RunReport, _ProgressBar, run_summary, stop_reason
from .resume import (  # noqa: F401  (their old home: cortex_ti.simulation.run)
    extend_finished,
    frame_fields,
    history_path,
    read_history,
    resumed_state,
    write_history,
)

if TYPE_CHECKING:  # pragma: no cover
    from .core import Simulation
    from .setup import SceneSetup

log = logging.getLogger(__name__)

__all__ = [
    "SOLVE_DIAGNOSTICS",
    "FRAME_EXTRAS",
    "STOP_REASONS",
    "EXIT_CODES",
    "FileHooks",
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


def output_attrs(sim: Simulation) -> dict:
    """The global attributes of the scene's trajectory (with :func:`cortex_ti.provenance`)."""
    s = sim.settings
    return {
        "scene": sim.scene.to_yaml(),
        "effects": ",".join(sorted(s.effects)),
        "fit_scheme": s.numerics.fit,
        "solver_backend": s.solver_name,
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
    """Run ``sim``'s scene and write its trajectory to ``output`` (see the module docstring); returns
    what the run did. What is already at ``output`` is treated as the command line does
    (:func:`cortex_ti.io.claim.check_output`: refused unless ``resume`` or ``force``). A run that
    raises once started carries its :class:`RunReport` on the exception (``exc.run_report``)."""
    started = time.perf_counter()
    seen: dict = {}  # the counts so far, for the report of a run that does not finish
    with claim_output(output):
        check_output(output, resume, force)
        try:
            if sim.settings.dynamic:
                return _integrate_to_file(sim, output, resume, progress, seen, force)
            return _write_static(sim, output, force)
        except BaseException as exc:
            exc.run_report = _failed(output, exc, seen.get("stats"), started)
            raise


def _failed(output: Path, exc: BaseException, stats: RunStats | None, t0: float) -> RunReport:
    """What a run that raised ``exc`` did: why it stopped, its real counts, the file it kept."""
    reason = stop_reason(exc)
    partial = partial_path(output)
    if stats is not None:
        stats.stopped = reason
        stats.wall = time.perf_counter() - t0
    return RunReport(path=partial if partial.exists() else output, stats=stats, stopped=reason, solved=0)


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


class FileHooks(RunHooks):
    """The hooks of a run that writes its trajectory (:class:`~cortex_ti.dynamics.integrate.RunHooks`):
    each frame appended to ``writer`` with its diagnostics (held until the step's frames are
    committed), a remeshing starting a new segment of the file (and capping an ALE run's step for
    the new triangles), the stop at ``time.stop_neck``, and after each step the commit, a dense
    scheme's step history beside the partial file, the check for signals and the progress bar.
    ``seen["stats"]`` holds the counts so far."""

    def __init__(self, sim: Simulation, writer: TrajectoryWriter, scheme, output: Path, bar, seen: dict):
        s = sim.settings
        self.sim, self.writer, self.scheme, self.output, self.bar, self.seen = sim, writer, scheme, output, bar, seen
        self.axis = s.pattern_axis
        self.has_pressure = s.has("incompressibility")
        self.stored = stored_fields(sim)
        self.curved = s.numerics.formulation_entry.curved
        self.stop_neck = s.time.stop_neck
        self.division = s.division_neck is not None  # the bodies' variables and the neck at every frame
        self.neck, self.neck_t = np.inf, None  # the last frame's neck radius and time (time.stop_neck)
        self.saved = writer.n_frames  # frames the saved step history belongs to
        if s.mesh.remesh is None:
            self.remesh = None  # never asked

    def frame(self, t, ev, dt_next, final=False):
        sim = self.sim
        diag = frame_diagnostics(
            ev.points, sim.mesh.faces, ev.velocity, ev.normal, axis=self.axis, measures=not self.curved
        )
        if self.curved:  # the volume, area and radii of the curved cells, not of their flat vertex view
            diag.update(curved_measures(ev.points, sim.mesh.faces, axis=self.axis))
        if self.division:
            diag.update(body_diagnostics(ev.points, sim.mesh.faces, ev.pressure, ev.solution.body_pressure, sim.curved))
        if self.stop_neck is not None or self.division:
            radius = neck_radius(ev.points, sim.mesh.faces, axis=self.axis)[0] if sim.bodies is None else np.nan
            self.neck, self.neck_t = (radius if np.isfinite(radius) else np.inf), t
            sim.neck_seen = self.neck
            diag["neck_radius"] = radius
        fields = ev.state.fields
        self.writer.append(
            t,
            ev.points,
            ev.velocity,
            tension_of(fields, sim.mesh.n_nodes, sim.settings),
            ev.pressure if self.has_pressure else float("nan"),
            normal=ev.normal,
            dt=dt_next,
            hold=True,  # committed with the step's other frames, in progress()
            **ev.solution.diagnostics,
            **diag,
            **{spec.var: fields[spec.name] for spec in self.stored},
        )

    def remesh(self, state, t):
        new = self.sim.remesh_state(state, t)
        if new is not None:
            self.writer.start_segment(new.faces, new.n_nodes, new.points, attrs=self.sim.segment_attrs)
            self.sim.segment_attrs = None
            cap_ale_step(self.sim, self.scheme, t)  # the new reference triangles have their own stiffness
        return new

    def stop(self, t):
        """``time.stop_neck``: the run ends at the first frame whose neck is at or below it."""
        if self.stop_neck is None or self.neck > self.stop_neck:
            return None
        log.warning(
            "%s: the neck radius %.4g R0 at t = %.6g fell to time.stop_neck = %g: the surface would pinch into "
            "two, which this model does not go through; the run stops here, its frames kept",
            self.sim.settings.name,
            self.neck,
            self.neck_t,
            self.stop_neck,
        )
        return "neck"

    def progress(self, t, ev, dt, stats):
        writer = self.writer
        writer.commit()  # the frames of the step just made, in one write
        if self.scheme.dense and writer.n_frames != self.saved:  # the history those frames continue from
            write_history(self.output, self.scheme, dt, writer.n_frames, writer.last_time)
            self.saved = writer.n_frames
        check_interrupted()
        self.seen["stats"] = stats
        if self.bar is not None:
            self.bar(t, ev, dt, stats)


def _open_writer(sim: Simulation, output: Path, attrs: dict, resumed: bool, extended: bool, force: bool):
    """The trajectory writer of a dynamic run (a refused resume names the key that changed); a refused
    extension removes its copy of the finished file, which stays unchanged."""
    st = sim.settings.time
    division = sim.settings.division_neck is not None
    neck = st.stop_neck is not None or division
    try:
        return TrajectoryWriter(
            output,
            sim.state0.faces,  # the initial mesh (segment 0); a resumed remeshed run continues its last segment
            sim.state0.n_nodes,
            attrs,
            extra_vars={
                **FRAME_EXTRAS,
                **_DYNAMIC_EXTRAS,
                **({k: (("time",), v) for k, v in NECK_ATTRS.items()} if neck else {}),
                **(BODY_VARIABLES if division else {}),
                **{spec.var: (("time", "node"), dict(spec.attrs)) for spec in stored_fields(sim)},
            },
            resume=resumed,
            extra_dims={"body": MAX_BODIES} if division else None,
            node_vars=field_values(sim),
            force=force,
        )
    except BaseException as exc:
        if not extended:
            raise
        partial_path(output).unlink(missing_ok=True)
        prefix = f"cannot resume '{partial_path(output)}'"
        if isinstance(exc, CortexError) and str(exc).startswith(prefix):
            said = str(exc)[len(prefix) :].replace(
                "pass --force (or delete it) to start over", "pass --force to replace it"
            )
            raise CortexError(f"cannot extend '{output}'{said}") from None
        raise


def _integrate_to_file(
    sim: Simulation, output: Path, resume: bool, progress: bool, seen: dict, force: bool = False
) -> RunReport:
    st = sim.settings.time
    scheme = step_scheme(sim)
    start, t0, dt = sim.state0, 0.0, min(st.dt, scheme.dt_cap)
    extended = resume and extend_finished(output)
    state = ResumeState.read(output) if resume else None
    attrs = output_attrs(sim)
    done = state is not None and state.time >= st.t_end - 1e-9 * max(st.save_every, 1e-12)
    if done:  # the file already reaches past time.t_end: its scene records the t_end its frames reach
        attrs["scene"] = sim.scene.with_overrides([f"time.t_end={state.time!r}"]).to_yaml()
    # first, so that a refused resume (a changed scene: the key named) comes before any log line
    writer = _open_writer(sim, output, attrs, state is not None, extended, force)
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
    caveat = sim.settings.numerics.formulation_entry.caveat(sim.settings.numerics.active_force)
    if caveat:
        log.warning("scene '%s': numerics.formulation = %s: %s", sim.settings.name, sim.formulation, caveat)
    if done:
        log.info("%s reaches t = %.6g already (time.t_end = %.6g): nothing to compute", output, state.time, st.t_end)
        seen["stats"] = RunStats(t=state.time)
        return RunReport(path=writer.finish(), stats=seen["stats"], stopped="t_end")
    bar = _ProgressBar(t0, st.t_end) if progress else None
    hooks = FileHooks(sim, writer, scheme, output, bar, seen)
    try:
        stats = integrate(
            sim.evaluate,
            start,
            t0,
            st.t_end,
            dt,
            scheme,
            st.save_every,
            hooks,
            steady_tol=st.steady_tol,
            write_first=state is None,
            implicit=st.implicit_tension,
            guard=_guard(sim),
            save_times=st.save_times,
            restored=restored,
        )
    except BaseException:
        writer.close_partial()
        if seen.get("stats") is not None and writer.n_frames:
            seen["stats"].t = writer.last_time
        raise
    finally:
        if bar is not None:
            bar.close()
    if stats.stopped == "neck":  # a dense scheme's step may end past the frame that crossed
        stats.t = hooks.neck_t
    seen["stats"] = stats
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


def stored_fields(sim: Simulation) -> list:
    """The fields a trajectory stores as variables of their own: all but a prescribed tension that is
    the whole active tension (the ``active_stress`` variable already holds it)."""
    specs = sim.fields
    alone = [spec.name for spec in specs if spec.tension is not None] == ["prescribed_tension"]
    return [spec for spec in specs if not (alone and spec.name == "prescribed_tension")]


def _guard(sim) -> StabilityGuard:
    """The run's stability guard: the mesh, the tension, and (for a cortex without bending resistance,
    which a compressive stress wrinkles at the mesh scale) the in-plane viscosities, so that a stop
    can say where the stress is compressive."""
    ph = sim.physics
    flat = "bending_viscosity" not in ph.effects or (ph.eta_bar == 0.0 and ph.eta_bar_b == 0.0)
    flat = flat and ("bending_rigidity" not in ph.effects or ph.kappa == 0.0)  # rigidity resists bending too
    eta_s = ph.eta_s if "shear_viscosity" in ph.effects else 0.0
    eta_b = ph.eta_b if "bulk_viscosity" in ph.effects else 0.0
    return StabilityGuard(
        faces=sim.mesh.faces,
        zeta=sim.zeta,
        viscosity=(eta_s, eta_b) if flat else None,
        tension=lambda fields, n: tension_of(fields, n, sim.settings),
    )
