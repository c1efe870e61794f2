"""Running a scene to its trajectory file, and what the run cost.

A static scene solves once and writes one frame. A dynamic scene advances the shape
(:func:`cortex_ti.dynamics.integrate.integrate`) and writes a frame every ``time.save_every``,
flushed as it goes to ``<output>.partial``; an interrupted run continues from there with
``resume`` (:class:`cortex_ti.io.trajectory.ResumeState`), and the finished file is renamed
atomically to ``output``.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import __version__
from ..analysis.diagnostics import DIAGNOSTIC_ATTRS, frame_diagnostics
from ..dynamics.guard import StabilityGuard
from ..dynamics.integrate import RunStats, integrate
from ..dynamics.schemes import make_scheme
from ..errors import CortexError
from ..io.trajectory import ResumeState, TrajectoryWriter

if TYPE_CHECKING:  # pragma: no cover
    from .simulation import Simulation

log = logging.getLogger(__name__)

__all__ = ["SOLVE_DIAGNOSTICS", "FRAME_EXTRAS", "RunReport", "run_scene", "run_summary"]

#: Per-frame diagnostics of the solve written with every frame
SOLVE_DIAGNOSTICS = {
    "force_residual": (("time",), {"units": "zeta_0/R0", "long_name": "force the solve leaves unbalanced: "
                                   "|K x + F^T lambda - f| (rayleigh_p1), |M x + p P - r| (paper); "
                                   "lsq_residual in older files"}),
    "relative_residual": (("time",), {"units": "1", "long_name": "force_residual relative to |f| (or |r|)"}),
    "constraint_violation": (("time",), {"units": "1", "long_name": "largest relative violation of the constraints (Eqs. 35-37)"}),
    "kkt_residual": (("time",), {"units": "1", "long_name": "relative residual of the bordered normal equations"}),
}

#: Everything a frame holds beyond the standard variables: the solver's normals, the solve's and
#: the shape's diagnostics, and (dynamic runs) the step the integrator takes next.
FRAME_EXTRAS = {
    "normal": (("time", "node", "xyz"), {"units": "1", "long_name": "unit normal of the fitted surface at the nodes "
                                                                  "(the direction the nodes move along)"}),
    **SOLVE_DIAGNOSTICS,
}
_DYNAMIC_EXTRAS = {
    **{k: (("time",), v) for k, v in DIAGNOSTIC_ATTRS.items()},
    "dt": (("time",), {"units": "t_a", "long_name": "time step the integrator takes next"}),
}


@dataclass
class RunReport:
    """What a run did: the file it wrote and, for a dynamic run, its steps and solves."""

    path: Path
    stats: RunStats | None = None      # None for a static run

    @property
    def solves(self) -> int:
        return 1 if self.stats is None else self.stats.solves


def output_attrs(sim: "Simulation") -> dict:
    """The global attributes of the scene's trajectory."""
    s = sim.settings
    return {
        "scene": sim.scene.to_yaml(),
        "effects": ",".join(sorted(s.effects)),
        "fit_scheme": s.numerics.fit,
        "solver_backend": s.solver.backend,
        "n_nodes": sim.mesh.n_nodes,
        "cortex_ti_version": __version__,
    }


def run_scene(sim: "Simulation", output: Path, resume: bool = False, progress: bool = True) -> RunReport:
    """Run ``sim``'s scene and write its trajectory to ``output`` (see the module docstring)."""
    sim.seconds = {}
    if sim.settings.dynamic:
        return _run_dynamic(sim, output, resume, progress)
    return _run_static(sim, output)


def _run_static(sim: "Simulation", output: Path) -> RunReport:
    with TrajectoryWriter(output, sim.mesh.faces, sim.mesh.n_nodes, output_attrs(sim),
                          extra_vars=FRAME_EXTRAS) as writer:
        ev = sim.evaluate(sim.mesh.points)
        sol = ev.solution
        log.info("solved %d nodes: residual %.2e, constraints %.1e, %s",
                 sim.mesh.n_nodes, sol.info.relative_residual, sol.info.constraint_violation,
                 ", ".join(f"{k} {v:.3f} s" for k, v in sol.seconds.items()))
        if not np.all(np.isfinite(sol.velocity)):
            raise CortexError("the solve produced non-finite velocities")
        pressure = sol.pressure if sim.settings.has("incompressibility") else float("nan")
        writer.append(0.0, sol.points, sol.velocity, sim.zeta, pressure, normal=sol.normal, **sol.diagnostics)
    return RunReport(path=output)


def _run_dynamic(sim: "Simulation", output: Path, resume: bool, progress: bool) -> RunReport:
    st = sim.settings.time
    scheme = make_scheme(st.scheme, sim.evaluate, tol=st.tol, dt_max=st.dt_max)
    points, t0, dt = sim.mesh.points, 0.0, st.dt
    state = ResumeState.read(output) if resume else None
    if state is not None:
        points, t0 = state.points, state.time
        if scheme.adaptive and state.dt is not None:
            # continue with the controller's step (a fixed-step scheme takes the scene's, so
            # --resume --set time.dt=... after a stability stop does what it says)
            dt = min(state.dt, st.dt_max)
        sim.zeta = state.active_stress
        log.info("resuming %s at t = %.4g (frame %d, dt = %.3g)", output, t0, state.n_frames, dt)
    elif resume:
        log.info("nothing to resume at %s.partial; starting from t = 0", output)
    faces, axis = sim.mesh.faces, sim.settings.pattern_axis
    has_p = sim.settings.has("incompressibility")
    writer = TrajectoryWriter(output, faces, sim.mesh.n_nodes, output_attrs(sim),
                              extra_vars={**FRAME_EXTRAS, **_DYNAMIC_EXTRAS}, resume=state is not None)

    def on_frame(t, ev, dt_next, final=False):
        diag = frame_diagnostics(ev.points, faces, ev.velocity, ev.normal, axis=axis)
        writer.append(t, ev.points, ev.velocity, sim.zeta, ev.pressure if has_p else float("nan"),
                      normal=ev.normal, dt=dt_next, **ev.solution.diagnostics, **diag)

    bar = _ProgressBar(t0, st.t_end) if progress else None
    try:
        stats = integrate(sim.evaluate, points, t0, st.t_end, dt, scheme, st.save_every, on_frame,
                          steady_tol=st.steady_tol, progress=bar, write_first=state is None,
                          implicit=st.implicit_tension, guard=StabilityGuard(faces=faces),
                          save_times=st.save_times)
    except BaseException:
        writer.close_partial()
        raise
    finally:
        if bar is not None:
            bar.close()
    path = writer.finish()
    per = {k: v / max(stats.solves, 1) * 1e3 for k, v in sim.seconds.items()}
    log.info("%s: t = %.4g reached (%s) in %.1f s: %d steps, %d rejected, %d solves; per solve %s",
             sim.settings.name, stats.t, stats.stopped, stats.wall, stats.steps, stats.rejected, stats.solves,
             ", ".join(f"{k} {v:.1f} ms" for k, v in per.items()))
    return RunReport(path=path, stats=stats)


def run_summary(sim: "Simulation") -> dict:
    """What ``sim``'s last run took (steps, solves, time per stage), and how it was set up."""
    s = sim.settings
    st = sim.stats
    solves = st.solves if st is not None else 1
    out = {"scene": s.name, "model": s.model, "n_nodes": sim.mesh.n_nodes, "fit": s.numerics.fit,
           "solver_backend": s.solver.backend, "effects": sorted(s.effects),
           "steps": st.steps if st is not None else 0, "rejected": st.rejected if st is not None else 0,
           "solves": solves, "t_reached": st.t if st is not None else 0.0,
           "stopped": st.stopped if st is not None else "static",
           "implicit_tension": s.time.implicit_tension,
           "formulation": s.numerics.formulation,
           "fit_residual_weight": s.numerics.fit_residual_weight}
    out.update({f"ms_{k}_per_solve": 1e3 * v / max(solves, 1) for k, v in sim.seconds.items()})
    out.update(factorizations=sim.solver.n_factorizations, krylov_iterations=sim.solver.n_iterations)
    return out


class _ProgressBar:
    """tqdm bar over simulated time; silent when stderr is not a terminal."""

    def __init__(self, t0: float, t_end: float):
        from tqdm import tqdm

        self._bar = tqdm(total=round(t_end, 6), initial=round(t0, 6), unit="t_a", disable=None,
                         bar_format="{l_bar}{bar}| t={n:.3f}/{total:.3f} [{elapsed}<{remaining}{postfix}]")
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
