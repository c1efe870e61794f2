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
from .assemble import assemble
from .errors import CortexError
from .geometry import Geometry, StencilChooser, compute_geometry
from .io import TrajectoryWriter
from .linalg import ConstrainedLeastSquares, SolveInfo
from .mesh import Mesh, Topology, build_topology, icosphere, load_mesh
from .scene import Scene
from .stress import evaluate_active_stress
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
        self.solver = ConstrainedLeastSquares(scene["solver.backend"], reuse=bool(scene["solver.reuse"]),
                                              rtol=float(scene["solver.rtol"]))
        self.geometry: Geometry | None = None

    def solve(self, points: np.ndarray | None = None) -> Solution:
        """Velocity and pressure on the shape ``points`` (default: the initial shape)."""
        runtime.ensure()
        x = self.mesh.points if points is None else points
        t0 = time.perf_counter()
        self.geometry = compute_geometry(x, self.topology, self.stencils)
        t1 = time.perf_counter()
        system = assemble(self.geometry, self.physics, self.zeta)
        t2 = time.perf_counter()
        unknowns, pressure, info = self.solver.solve(system, x)
        t3 = time.perf_counter()
        velocity = system.velocity(unknowns)
        return Solution(points=x, velocity=velocity, pressure=pressure, info=info,
                        seconds={"geometry": t1 - t0, "assembly": t2 - t1, "solve": t3 - t2})

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

    def run(self, output: str | Path) -> Path:
        """Run the scene and write its trajectory file (atomically)."""
        if self.scene.has("shape_evolution"):
            raise CortexError(
                f"scene '{self.scene.name}' asks for shape_evolution, which this version cannot run yet; "
                "remove it from effects to solve the static force balance"
            )
        attrs = self.output_attrs()
        with TrajectoryWriter(output, self.mesh.faces, self.mesh.n_nodes, attrs,
                              extra_vars=SOLVE_DIAGNOSTICS) as writer:
            sol = self.solve()
            log.info("solved %d nodes: residual %.2e, constraints %.1e, %s",
                     self.mesh.n_nodes, sol.info.relative_residual, sol.info.constraint_violation,
                     ", ".join(f"{k} {v:.3f} s" for k, v in sol.seconds.items()))
            if not np.all(np.isfinite(sol.velocity)):
                raise CortexError("the solve produced non-finite velocities")
            pressure = sol.pressure if self.scene.has("incompressibility") else float("nan")
            writer.append(0.0, sol.points, sol.velocity, self.zeta, pressure, **sol.diagnostics)
        return Path(output)
