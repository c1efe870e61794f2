"""One scene, from YAML to velocities: the stages it calls for and nothing else.

The flow (see ``design.md``): scene -> mesh -> active tension on the initial shape
-> per solve: geometry -> the terms of the enabled effects -> constrained least
squares -> velocity. A static scene (no ``shape_evolution`` effect) solves once and
writes one frame; it never enters a time loop.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import __version__, runtime
from .assemble import assemble, scene_fit_residual_weight
from .dynamics import scene_implicit_tension
from .errors import CortexError
from .geometry import Geometry, StencilChooser, compute_geometry
from .io import TrajectoryWriter, last_frame, partial_path
from .linalg import ConstrainedLeastSquares, SolveInfo
from .mesh import Mesh, Topology, affine, build_topology, icosphere, load_mesh
from .scene import Scene
from .stress import evaluate_active_stress, scene_pattern_axis
from .terms import Physics

log = logging.getLogger(__name__)

#: Per-frame diagnostics of the solve written with every frame
SOLVE_DIAGNOSTICS = {
    "lsq_residual": (("time",), {"units": "zeta_0/R0", "long_name": "least-squares residual |M x + p P - r| of the force balance"}),
    "relative_residual": (("time",), {"units": "1", "long_name": "least-squares residual relative to |r|"}),
    "constraint_violation": (("time",), {"units": "1", "long_name": "largest relative violation of the constraints (Eqs. 35-37)"}),
    "kkt_residual": (("time",), {"units": "1", "long_name": "relative residual of the bordered normal equations"}),
}


def scene_mesh(scene: Scene) -> Mesh:
    """The icosphere or the user's mesh the scene names."""
    if scene["mesh.file"]:
        return load_mesh(scene["mesh.file"])
    return icosphere(int(scene["mesh.nodes"]), float(scene["mesh.radius"]))


def initial_shape(mesh: Mesh, scene: Scene) -> Mesh:
    """Apply the scene's initial affine map and shear (``mesh.transform``, ``mesh.shear``)."""
    matrix = np.eye(3)
    if scene["mesh.transform"] is not None:
        matrix = np.asarray(scene["mesh.transform"], dtype=float)
    gamma = float(scene["mesh.shear"])
    if gamma:
        shear = np.eye(3)
        shear[0, 2] = gamma
        matrix = shear @ matrix
    if np.array_equal(matrix, np.eye(3)):
        return mesh
    if not np.all(np.isfinite(matrix)) or abs(np.linalg.det(matrix)) < 1e-12:
        raise CortexError(f"scene '{scene.name}': mesh.transform/mesh.shear give a singular or non-finite map")
    return affine(mesh, matrix)


@dataclass
class Solution:
    """The velocity field on one shape and what it took to get it."""

    points: np.ndarray
    velocity: np.ndarray
    pressure: float
    info: SolveInfo
    seconds: dict = field(default_factory=dict)

    @property
    def diagnostics(self) -> dict:
        return {
            "lsq_residual": self.info.lsq_residual,
            "relative_residual": self.info.relative_residual,
            "constraint_violation": self.info.constraint_violation,
            "kkt_residual": self.info.kkt_residual,
        }


class Simulation:
    """A scene ready to solve: mesh, topology, active tension and the chosen solver."""

    def __init__(self, scene: Scene, mesh: Mesh | None = None):
        self.scene = scene
        self.physics = Physics.from_scene(scene)
        self.mesh = mesh or scene_mesh(scene)
        self.topology: Topology = build_topology(self.mesh)
        self.stencils = StencilChooser(self.topology, scene["numerics.fit"])
        if scene.has("active_stress"):
            self.zeta = evaluate_active_stress(self.mesh.points, scene["active_stress"])
        else:
            self.zeta = np.zeros(self.mesh.n_nodes)
        # the stress is carried by the nodes: assign it first, then deform the initial shape
        self.mesh = initial_shape(self.mesh, scene)
        self.solver = ConstrainedLeastSquares(scene["solver.backend"], reuse=bool(scene["solver.reuse"]),
                                              rtol=float(scene["solver.rtol"]))
        self.fit_residual_weight = scene_fit_residual_weight(scene)
        self.geometry: Geometry | None = None
        self.seconds: dict[str, float] = {}   # time spent per stage, summed over solves

    def solve(self, points: np.ndarray | None = None, dt: float = 0.0) -> Solution:
        """Velocity and pressure on the shape ``points`` (default: the initial shape).

        ``dt > 0``: the velocity of a step of that length with the semi-implicit tension
        (:mod:`cortex_ti.terms.implicit_tension`); 0 is the instantaneous velocity."""
        runtime.ensure()
        x = self.mesh.points if points is None else points
        t0 = time.perf_counter()
        self.geometry = compute_geometry(x, self.topology, self.stencils, residual=self.fit_residual_weight > 0)
        t1 = time.perf_counter()
        system = assemble(self.geometry, self.physics, self.zeta, self.fit_residual_weight, implicit_dt=dt)
        t2 = time.perf_counter()
        unknowns, pressure, info = self.solver.solve(system, x)
        t3 = time.perf_counter()
        velocity = system.velocity(unknowns)
        return Solution(points=x, velocity=velocity, pressure=pressure, info=info,
                        seconds={"geometry": t1 - t0, "assembly": t2 - t1, "solve": t3 - t2})

    def summary(self) -> dict:
        """What the last :meth:`run` took: steps, solves and time per stage (for cost tables)."""
        st = getattr(self, "stats", None)
        solves = st.solves if st is not None else 1
        out = {"scene": self.scene.name, "n_nodes": self.mesh.n_nodes, "fit": self.scene["numerics.fit"],
               "solver_backend": self.solver.backend, "effects": self.effects_ran(),
               "steps": st.steps if st is not None else 0, "rejected": st.rejected if st is not None else 0,
               "solves": solves, "t_reached": st.t if st is not None else 0.0,
               "stopped": st.stopped if st is not None else "static",
               "implicit_tension": self.scene.has("shape_evolution") and scene_implicit_tension(self.scene),
               "fit_residual_weight": self.fit_residual_weight}
        out.update({f"ms_{k}_per_solve": 1e3 * v / max(solves, 1) for k, v in self.seconds.items()})
        return out

    def effects_ran(self) -> list[str]:
        return sorted(self.physics.effects)

    def output_attrs(self) -> dict:
        return {
            "scene": self.scene.to_yaml(),
            "effects": ",".join(self.effects_ran()),
            "fit_scheme": self.scene["numerics.fit"],
            "solver_backend": self.solver.backend,
            "n_nodes": self.mesh.n_nodes,
            "cortex_ti_version": __version__,
        }

    def evaluate(self, points: np.ndarray, dt: float = 0.0):
        """Solve on ``points`` (for a step ``dt``, see :meth:`solve`) and package what the
        time integration needs."""
        from .dynamics import Evaluation

        sol = self.solve(points, dt)
        self._accumulate(sol)
        return Evaluation(points=points, velocity=sol.velocity, normal=self.geometry.normal.copy(),
                          pressure=sol.pressure, solution=sol, edge_length=self.geometry.edge_length.copy())

    def _accumulate(self, sol: Solution) -> None:
        for k, v in sol.seconds.items():
            self.seconds[k] = self.seconds.get(k, 0.0) + v

    @property
    def pattern_axis(self) -> np.ndarray:
        """The axis of the active-stress pattern (:func:`cortex_ti.stress.scene_pattern_axis`)."""
        return scene_pattern_axis(self.scene)

    def run(self, output: str | Path, resume: bool = False, progress: bool = True) -> Path:
        """Run the scene and write its trajectory file (atomically; dynamic runs resumable)."""
        if self.scene.has("shape_evolution"):
            return self._run_dynamics(Path(output), resume, progress)
        attrs = self.output_attrs()
        with TrajectoryWriter(output, self.mesh.faces, self.mesh.n_nodes, attrs,
                              extra_vars=SOLVE_DIAGNOSTICS) as writer:
            self.seconds = {}
            sol = self.solve()
            self._accumulate(sol)
            log.info("solved %d nodes: residual %.2e, constraints %.1e, %s",
                     self.mesh.n_nodes, sol.info.relative_residual, sol.info.constraint_violation,
                     ", ".join(f"{k} {v:.3f} s" for k, v in sol.seconds.items()))
            if not np.all(np.isfinite(sol.velocity)):
                raise CortexError("the solve produced non-finite velocities")
            pressure = sol.pressure if self.scene.has("incompressibility") else float("nan")
            writer.append(0.0, sol.points, sol.velocity, self.zeta, pressure, **sol.diagnostics)
        return Path(output)

    def _run_dynamics(self, output: Path, resume: bool, progress: bool) -> Path:
        from .diagnostics import DIAGNOSTIC_ATTRS, frame_diagnostics
        from .dynamics import StabilityGuard, integrate, make_scheme

        sc = self.scene
        t_end, dt, save_every = float(sc["time.t_end"]), float(sc["time.dt"]), float(sc["time.save_every"])
        extra = dict(SOLVE_DIAGNOSTICS)
        extra.update({k: (("time",), v) for k, v in DIAGNOSTIC_ATTRS.items()})
        extra["dt"] = (("time",), {"units": "t_a", "long_name": "time step the integrator takes next"})
        points, t0 = self.mesh.points, 0.0
        if resume and partial_path(output).exists():
            last = last_frame(partial_path(output))
            if last["n_frames"]:
                points, t0 = last["points"], float(last["time"])
                if sc["time.scheme"] in ("adaptive", "adaptive_euler"):
                    # continue with the controller's step (a fixed-step scheme takes the scene's,
                    # so --resume --set time.dt=... after a stability stop does what it says)
                    dt = min(float(last["extra"]["dt"]), float(sc["time.dt_max"]))
                self.zeta = np.asarray(last["active_stress"], dtype=float)
                log.info("resuming %s at t = %.4g (frame %d, dt = %.3g)", output, t0, last["n_frames"], dt)
            else:
                resume = False
        elif resume:
            log.info("nothing to resume at %s; starting from t = 0", partial_path(output))
            resume = False
        axis = self.pattern_axis
        faces = self.mesh.faces
        has_p = sc.has("incompressibility")
        self.seconds = {}
        writer = TrajectoryWriter(output, faces, self.mesh.n_nodes, self.output_attrs(), extra_vars=extra,
                                  resume=resume)

        def on_frame(t, ev, dt_next, final=False):
            diag = frame_diagnostics(ev.points, faces, ev.velocity, ev.normal, axis=axis)
            writer.append(t, ev.points, ev.velocity, self.zeta, ev.pressure if has_p else float("nan"),
                          dt=dt_next, **ev.solution.diagnostics, **diag)

        scheme = make_scheme(sc["time.scheme"], self.evaluate, tol=float(sc["time.tol"]),
                             dt_max=float(sc["time.dt_max"]))
        bar = _progress_bar(t0, t_end) if progress else None
        try:
            stats = integrate(self.evaluate, points, t0, t_end, dt, scheme, save_every, on_frame,
                              steady_tol=float(sc["time.steady_tol"]), progress=bar, write_first=not resume,
                              implicit=scene_implicit_tension(sc), guard=StabilityGuard(faces=faces))
        except BaseException:
            writer.close_partial()
            raise
        finally:
            if bar is not None:
                bar.close()
        path = writer.finish()
        self.stats = stats
        per = {k: v / max(stats.solves, 1) * 1e3 for k, v in self.seconds.items()}
        log.info("%s: t = %.4g reached (%s) in %.1f s: %d steps, %d rejected, %d solves; per solve %s",
                 sc.name, stats.t, stats.stopped, stats.wall, stats.steps, stats.rejected, stats.solves,
                 ", ".join(f"{k} {v:.1f} ms" for k, v in per.items()))
        return path


class _progress_bar:
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
