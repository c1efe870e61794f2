"""One scene ready to solve: its mesh, topology, active tension and solver, and the velocity on
any shape of that mesh.

The flow of one solve: shape -> geometry (:mod:`cortex_ti.surface.geometry`) -> the system of
the scene's formulation (:data:`cortex_ti.physics.formulations.FORMULATIONS`: the terms of the
enabled effects) -> constrained solve (:mod:`cortex_ti.solve.constrained`) -> velocity. :meth:`Simulation.run` writes
the scene's
trajectory (:mod:`cortex_ti.simulation.run`): a static scene (no ``shape_evolution``) solves once
and writes one frame; it never enters a time loop.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path

import numpy as np

from ..dynamics.motion import MotionContext
from ..dynamics.remesh_policy import COARSE_EVERY, COARSE_RETRIGGER, RETRIGGER, RemeshPolicy  # noqa: F401
from ..dynamics.schemes import Evaluation
from ..dynamics.state import State
from ..physics.fields import tension_of
from ..scene.loader import Scene
from ..scene.settings import BUDGET_H_MAX  # noqa: F401  (its old home)
from ..solve.constrained import ConstrainedSolver, SolveInfo
from ..surface import curved_remesh
from ..surface.curved import midpoint_mask
from ..surface.curved_transport import cell_quadrature, curved_advective_rate
from ..surface.division import body_volumes, restore_body_volumes
from ..surface.fits import FIT_SCHEMES, StencilChooser
from ..surface.geometry import compute_geometry
from ..surface.mesh import Mesh
from ..surface.remesh import (
    closest_points,
    enclosed_volume,
    keep_amount,
    mean_edge_length,
    remesh,
    restore_volume,
)
from ..surface.topology import Topology, build_topology
from ..surface.transport import DENSITY, advective_rate, dual_areas, triangle_gradients
from .bodies import divide_due, remesh_by_body, solve_by_body, split_bodies
from .run import run_scene, run_summary
from .setup import SceneSetup, field_moves

__all__ = ["Simulation", "Solution"]

log = logging.getLogger(__name__)

#: settling (mesh.remesh.settle_steps) stops once a pseudo-step lowers the largest excess normal
#: speed by less than this factor: the stiff transient is gone (Simulation._settle)
SETTLE_SLOWDOWN = 0.9


@dataclass
class Solution:
    """The velocity field on one shape, the normals the shape moves along, and what it took."""

    points: np.ndarray
    velocity: np.ndarray
    pressure: float
    info: SolveInfo
    normal: np.ndarray  # (N, 3) the solver's normals (fitted surface)
    edge_length: np.ndarray  # (N,) mean edge length at each node (the local mesh size)
    seconds: dict = field(default_factory=dict)
    body_pressure: np.ndarray | None = None  # several bodies: each one's pressure (pressure is then NaN)

    @property
    def diagnostics(self) -> dict:
        """The solve's per-frame diagnostics (:data:`cortex_ti.simulation.run.SOLVE_DIAGNOSTICS`)."""
        return {
            "force_residual": self.info.force_residual,
            "relative_residual": self.info.relative_residual,
            "constraint_violation": self.info.constraint_violation,
            "kkt_residual": self.info.kkt_residual,
        }


class Simulation:
    """A scene ready to solve: mesh, topology, active tension and the chosen solver.

    ``Simulation(scene).solve(points)`` gives the velocity on a shape with the scene's mesh
    connectivity; ``run(output)`` writes the scene's trajectory. The settings are the scene's,
    resolved once (:attr:`settings`).
    """

    def __init__(self, scene: Scene, mesh: Mesh | None = None):
        self.scene = scene
        self.settings = scene.settings
        self.physics = self.settings.physics
        setup = SceneSetup(scene, mesh)  # what check sets up too (no Taichi): the same refusals
        self.topology: Topology = setup.topology
        self.mesh = setup.mesh
        self.stencils = self._stencils()
        self.state0 = setup.state0
        self.fields = setup.fields
        self.transport = setup.transport
        self.motion = setup.motion
        self.motion_context = setup.motion_context
        s = self.settings.solver
        self.solver = ConstrainedSolver(s.backend, reuse=s.reuse, rtol=s.rtol, refine=s.refine)
        self.seconds: dict[str, float] = {}  # time per stage, summed over the solves of evaluate()
        self.report = None  # what the last run() did (cortex_ti.simulation.run.RunReport)
        self.segment = 0  # how many times the mesh was replaced (remeshing)
        self.bodies = split_bodies(self, self.mesh)  # None: one body (simulation/bodies.py)
        self.cuts: list = []  # the divisions of the last run (simulation/bodies.py: Cut)
        self.neck_seen = math.inf  # the last frame's neck radius (division.neck_radius: when to search it)
        self.segment_attrs: dict | None = None  # what the next trajectory segment records (a cut)
        rem = self.settings.mesh.remesh
        self.remesh_policy = None  # when the mesh is remeshed, with which options (None: never)
        if rem is not None:  # (the remeshing extra is checked by SceneSetup)
            mean = mean_edge_length(self.mesh.points, self.mesh.faces)
            view = curved_remesh.corner_mesh if self.curved else None  # the curved cells' corners (remesh_policy)
            self.remesh_policy = RemeshPolicy(rem.min_angle, rem.sized(mean, self.mesh.n_nodes), rem.coarser, view)

    @property
    def remesh_options(self):
        """The options the mesh is remeshed with (size defaults resolved; None: never remeshed)."""
        return None if self.remesh_policy is None else self.remesh_policy.options

    @property
    def remesh_below(self) -> float | None:
        """The angle trigger of the current mesh (deg; None: never remeshed)."""
        return None if self.remesh_policy is None else self.remesh_policy.below

    def use_mesh(self, points: np.ndarray, faces: np.ndarray, reference: np.ndarray | None = None) -> None:
        """Solve on a new triangulation from now on (a remeshing, or resuming after one): the
        connectivity, fit stencils and ALE reference triangles (``reference``: the nodes the ALE
        motion relaxes the triangles toward, default ``points``) follow it, and the solver drops
        what belonged to the old mesh (its symbolic analysis is redone for the new pattern)."""
        self.mesh = Mesh(points, faces)
        self.topology = build_topology(self.mesh)
        ref = points if reference is None else reference
        self.stencils = self._stencils(ref)  # chosen on the nodes right after the remeshing, also on resume
        self.motion_context = MotionContext(self.mesh.faces, np.array(ref, dtype=float), self.settings.mesh.ale_time)
        self.solver.new_mesh()
        self.bodies = split_bodies(self, self.mesh)

    def continue_segment(self, points, triangles, reference, segment: int) -> None:
        """Resume on the mesh of segment ``segment`` of a remeshed run: its triangles, its ALE
        reference (the nodes right after that remeshing) and the trigger it had then."""
        self.use_mesh(points, triangles, reference)
        self.segment = segment
        if self.remesh_policy is not None:
            self.remesh_policy.judge(reference, triangles)

    def _judge_new_mesh(self, points: np.ndarray, faces: np.ndarray) -> float:
        """The triggers of a new mesh (:meth:`cortex_ti.dynamics.remesh_policy.RemeshPolicy.judge`)."""
        return self.remesh_policy.judge(points, faces)

    def remesh_state(self, state: State, t: float = float("nan")) -> State | None:
        """The state on a new mesh when the remeshing policy says so (:mod:`cortex_ti.dynamics.remesh_policy`:
        the smallest triangle angle below ``mesh.remesh.min_angle``, or the mesh too coarse), by
        :func:`cortex_ti.surface.remesh.remesh` (sized by curvature, the volume of ``state``
        restored, densities conserving their amount); None otherwise."""
        rem, policy = self.settings.mesh.remesh, self.remesh_policy
        if policy is None:
            return None
        divided = divide_due(self, state, t)  # division.neck_radius reached: the cut (simulation/bodies.py)
        if divided is not None:
            return divided
        why = policy.due(state.points, state.faces)
        if why is None and self.curved:
            return self._unfolded(state, t)
        if why is None:
            return None
        kinds = {spec.name: spec.kind for spec in self.fields}
        flow = None
        if rem.settle_steps > 0:  # the old mesh's flow, before the solver turns to the new mesh
            zeta = tension_of(state.fields, state.n_nodes, self.settings)
            flow = self.solve(state.points, rem.settle_dt, zeta).velocity
        how = curved_remesh.remesh_curved if self.curved else remesh
        if self.curved and rem.mirror:  # one half remeshed and reflected (cortex_ti.surface.mirror)
            how = partial(curved_remesh.remesh_curved, mirror=self.settings.pattern_axis)
        if self.bodies is not None:  # each body remeshed on its own, its own volume restored
            how = remesh_by_body(self)
        res = how(state.points, state.faces, dict(state.fields), kinds, policy.options)
        after = policy.judge(res.points, res.faces)
        log.info(
            "t = %.4g: %s: remeshed %d -> %d nodes (size scale %.3g, predicted %.0f nodes; smallest angle %.1f deg, "
            "volume offset %.2e)",
            t,
            why,
            res.n_before,
            res.n_after,
            res.scale,
            res.predicted,
            after,
            res.offset,
        )
        if after < rem.min_angle:
            log.warning(
                "t = %.4g: the remeshed surface's smallest angle %.1f deg is below mesh.remesh.min_angle = %g; "
                "this mesh is remeshed below %.3g deg",
                t,
                after,
                rem.min_angle,
                policy.below,
            )
        self.use_mesh(res.points, res.faces)
        fields = res.fields
        if flow is not None:
            points, fields, moved, steps = self._settle(state, flow, res.points, res.faces, res.fields, kinds, rem)
            self.use_mesh(points, res.faces)
            log.info(
                "t = %.4g: the remeshed surface settled in %d pseudo-steps, nodes moved %.2e at most", t, steps, moved
            )
        self.segment += 1
        return State(self.mesh.points, fields, self.mesh.faces)

    def _unfolded(self, state: State, t: float) -> State | None:
        """A surface of curved cells whose flow folded a cell over a crease sharper than itself (its
        area element below :data:`~cortex_ti.surface.curved_remesh.FOLD_RATIO` of its corner
        triangle's): those cells' midpoints put on their chords (:func:`~cortex_ti.surface.curved_remesh.unfold`),
        the curved volume restored and the densities' totals over the cells kept, on the same
        triangles; None when no cell folds. A remeshing would not help: the new cells across the
        same crease fold again within a step (measured at amplitude 12's neck, t = 2.26, 2562 nodes)."""
        points, count = curved_remesh.unfold(state.points, state.faces)
        if count == 0:
            return None
        faces = state.faces
        points = self._restore_curved(points, faces, state)
        fields = dict(state.fields)
        before, after = curved_remesh.curved_masses(state.points, faces), curved_remesh.curved_masses(points, faces)
        for spec in self.fields:
            if spec.kind == DENSITY and spec.name in fields:
                values = fields[spec.name]
                fields[spec.name] = keep_amount(values, float(np.dot(values, before)), after)
        log.info("t = %.4g: %d curved cells folded over a crease: their midpoints put on their chords", t, count)
        self.use_mesh(points, faces)
        self.segment += 1
        return State(self.mesh.points, fields, self.mesh.faces)

    def _restore_curved(self, x, faces, state: State, volumes=None) -> np.ndarray:
        """``x`` offset so that its curved cells enclose ``state``'s volume (after a cut each body its
        own: ``volumes``, or the bodies' of ``state``)."""
        if self.bodies is None:
            return curved_remesh.restore_curved_volume(
                x, faces, curved_remesh.curved_volume(state.points, state.faces)
            )[0]
        volumes = volumes or body_volumes(state.points, state.faces, curved_remesh.curved_volume)
        return restore_body_volumes(x, faces, volumes, curved_remesh.restore_curved_volume)

    def _settle(self, state: State, flow, points, faces, fields, kinds, rem, volumes=None):
        """Settle a remeshed surface into its own mesh's discrete equilibrium (``mesh.remesh.settle_steps``).

        The tension's nodal force is not a pointwise-consistent curvature on an irregular mesh, so a
        shape relaxed on the old triangles is off the new ones' equilibrium by an O(1) curvature at
        the mesh scale; its relaxation strains a few triangles of a deep neck into compression, where
        a cortex without bending resistance wrinkles at the mesh scale
        (docs/validation/remesh_constriction.md, "The mode after a remeshing"). Here the new nodes
        move, in ``settle_steps`` pseudo-steps of ``settle_dt`` that do not advance the clock, by the
        part of their semi-implicit normal velocity that the old mesh's flow ``flow`` (interpolated
        at their foot points) does not have: ``x += settle_dt ((v - v_old) . n) n``. The stiff
        mesh-scale part decays, the flow the two meshes share is not integrated. The pseudo-steps
        stop early once the largest excess falls by less than a factor :data:`SETTLE_SLOWDOWN` in one
        of them: what decays that slowly (at rates below ``(1/SETTLE_SLOWDOWN - 1) / settle_dt``, 111
        per t_a at the default 1e-3) is the smooth difference between the two meshes' flows, which the
        time steps follow, not the stiff transient (measured: the excess falls by 0.62-0.77 in the
        first pseudo-steps and by 0.9 from the 4th-6th on, the tail going like k^-0.6;
        docs/validation/remesh_constriction.md). Then the volume is
        restored as the remeshing restores it (each body's, ``volumes`` if given), the densities'
        amounts rescaled. Returns the points, the fields, the largest move and the pseudo-steps taken."""
        if self.curved:  # the old cells' quadratic flow at the feet on the old curved surface
            old = curved_remesh.interpolate_at(state.points, state.faces, flow, points)
        else:
            tri, bary = closest_points(state.points, state.faces, points)
            old = np.einsum("qk,qkc->qc", bary, flow[state.faces[tri]])
        zeta = tension_of(fields, len(points), self.settings)
        x = np.array(points, dtype=float)
        last, taken = math.inf, 0
        for k in range(rem.settle_steps):
            sol = self.solve(x, rem.settle_dt, zeta)
            excess = np.einsum("nc,nc->n", sol.velocity - old, sol.normal)
            largest = float(np.abs(excess).max())
            if log.isEnabledFor(logging.DEBUG):  # the old flow's normal speed only for the debug line
                old_n = float(np.abs(np.einsum("nc,nc->n", old, sol.normal)).max())
                log.debug("settling step %d: largest excess normal speed %.3g, the old flow's %.3g", k, largest, old_n)
            if largest > SETTLE_SLOWDOWN * last:  # the stiff part is gone: the rest is the new mesh's flow
                break
            last, taken = largest, k + 1
            x = x + rem.settle_dt * excess[:, None] * sol.normal
        if self.curved:  # the curved cells' volume (each body's) and the densities' totals over them
            x, _ = curved_remesh.unfold(x, faces)  # the settling may fold a cell across a crease again
            x = self._restore_curved(x, faces, state, volumes)
            before, after = curved_remesh.curved_masses(points, faces), curved_remesh.curved_masses(x, faces)
        elif self.bodies is not None:  # each daughter its own volume (the bodies keep their order)
            x = restore_body_volumes(x, faces, volumes or body_volumes(state.points, state.faces))
            before, after = dual_areas(points, faces), dual_areas(x, faces)
        else:
            x, _ = restore_volume(x, faces, enclosed_volume(state.points, state.faces))
            before, after = dual_areas(points, faces), dual_areas(x, faces)
        out = dict(fields)
        for name, values in fields.items():
            if kinds.get(name) == DENSITY:
                out[name] = keep_amount(values, float(np.dot(values, before)), after)
        return x, out, float(np.linalg.norm(x - points, axis=1).max()), taken

    def _moves(self, spec) -> bool:
        """Whether a field changes in a step (carried, diluted, diffusing or turning over)."""
        return field_moves(spec, self.settings)

    @property
    def zeta(self) -> np.ndarray:
        """The active tension of the initial state (what :meth:`solve` uses unless told otherwise)."""
        return tension_of(self.state0.fields, self.mesh.n_nodes, self.settings)

    @zeta.setter
    def zeta(self, value) -> None:
        """Set the initial state's tension (the scene's prescribed tension field)."""
        fields = dict(self.state0.fields)
        fields["prescribed_tension"] = np.asarray(value, dtype=float)
        self.state0 = State(self.state0.points, fields, self.state0.faces)

    def state_at(self, points: np.ndarray) -> State:
        """The initial state's fields on the shape ``points``."""
        return self.state0.with_points(points)

    def _stencils(self, points: np.ndarray | None = None) -> StencilChooser:
        """The fit stencils of the current mesh: on curved cells with the quartic fit the midpoints fitted
        through midpoints only, the nearest on ``points`` (default: the mesh's)
        (:mod:`cortex_ti.physics.galerkin_p2`, "the corner-midpoint mode"; with the quadratic fit, whose
        curvature is second order anyway, the wider stencil only lost accuracy)."""
        fit = self.settings.numerics.fit
        apart = None
        if self.curved and FIT_SCHEMES[fit].order >= 4:
            apart = midpoint_mask(self.mesh.faces, self.mesh.n_nodes)
        return StencilChooser(self.topology, fit, apart, self.mesh.points if points is None else points)

    @property
    def curved(self) -> bool:
        """Whether the surface is made of curved six-node cells (``rayleigh_p2``): remeshed by
        :func:`cortex_ti.surface.curved_remesh.remesh_curved`, its volume and amounts those of the cells."""
        return self.settings.numerics.formulation_entry.curved

    @property
    def formulation(self) -> str:
        """The discretisation of the force balance (``numerics.formulation``)."""
        return self.settings.numerics.formulation

    @property
    def stats(self):
        """Steps, solves and time of the last dynamic :meth:`run` (None before one)."""
        return None if self.report is None else self.report.stats

    def shape_geometry(self, points: np.ndarray):
        """Frames, areas and fit operators of the shape ``points`` (what the formulation needs: the curved
        cells only the fitted patch, without the operators)."""
        return compute_geometry(
            points,
            self.topology,
            self.stencils,
            residual=self.settings.numerics.uses_fit_residual,
            operators=not self.curved,
        )

    def system(self, geometry, dt: float = 0.0, zeta: np.ndarray | None = None, implicit_rate=None, faces=None):
        """The formulation's linear system on a shape (``dt > 0``: the semi-implicit step, centred on
        the nodes' rate ``implicit_rate`` if given) with the tension ``zeta`` (default: the initial
        state's; ``faces``: the triangles of the shape, default the mesh's). Once the mesh holds
        several bodies (after a cut), ``division.implicit_tension_weight`` replaces the numerics' weight."""
        num = self.settings.numerics
        if self.bodies is not None and self.settings.division_weight is not None:  # the daughters' weight
            num = replace(num, implicit_tension_weight=self.settings.division_weight)
        zeta = self.zeta if zeta is None else zeta
        faces = self.mesh.faces if faces is None else faces
        return num.formulation_entry.system(geometry, self.physics, zeta, faces, num, dt, implicit_rate)

    def solve(
        self,
        points: np.ndarray | None = None,
        dt: float = 0.0,
        zeta: np.ndarray | None = None,
        implicit_rate: np.ndarray | None = None,
    ) -> Solution:
        """Velocity and pressure on the shape ``points`` (default: the initial shape) with the
        tension ``zeta`` (default: the initial state's).

        ``dt > 0``: the velocity of a step of that length with the semi-implicit tension
        (:mod:`cortex_ti.physics.terms.implicit_tension`), centred on the nodes' rate
        ``implicit_rate`` (N, 3) if given (the ``bdf2`` scheme); 0 is the instantaneous velocity."""
        x = self.mesh.points if points is None else points
        if self.bodies is not None:  # each body its own volume constraint and gauge (simulation/bodies.py)
            return Solution(**solve_by_body(self, x, dt, zeta, implicit_rate))
        return self.solve_on(x, self.topology, self.stencils, self.mesh.faces, self.solver, dt, zeta, implicit_rate)

    def solve_on(self, x, topology, stencils, faces, solver, dt=0.0, zeta=None, implicit_rate=None) -> Solution:
        """:meth:`solve` on the closed surface ``x`` with its ``topology``, fit ``stencils``, triangles
        ``faces`` and ``solver`` (the whole mesh's, or one body's)."""
        t0 = time.perf_counter()
        geometry = compute_geometry(
            x, topology, stencils, residual=self.settings.numerics.uses_fit_residual, operators=not self.curved
        )
        t1 = time.perf_counter()
        system = self.system(geometry, dt, zeta, implicit_rate, faces)
        t2 = time.perf_counter()
        unknowns, pressure, info = solver.solve(system, x)
        t3 = time.perf_counter()
        return Solution(
            points=x,
            velocity=system.velocity(unknowns),
            pressure=pressure,
            info=info,
            normal=geometry.normal.copy(),
            edge_length=geometry.edge_length.copy(),
            seconds={"geometry": t1 - t0, "assembly": t2 - t1, "solve": t3 - t2},
        )

    def evaluate(self, state: State | np.ndarray, dt: float = 0.0, implicit_rate=None) -> Evaluation:
        """The dynamics on a state (positions: the initial state's fields on them): the solve with
        the state's tension (for a step ``dt``, centred on ``implicit_rate``, see :meth:`solve`), the mesh velocity of
        ``mesh.motion`` and the transport rates of the moving fields; counts the time per stage."""
        if not isinstance(state, State):
            state = self.state_at(state)
        points = state.points
        zeta = tension_of(state.fields, state.n_nodes, self.settings) if state.fields else None
        sol = self.solve(points, dt, zeta, implicit_rate)
        t0 = time.perf_counter()
        mesh_velocity, rates = None, {}
        if self.motion.name != "normal":
            mesh_velocity = self.motion.velocity(sol.velocity, sol.normal, points, self.motion_context)
        carried = [spec for spec in self.fields if spec.name in self.transport and spec.carried(self.settings)]
        if carried:
            w = (
                mesh_velocity
                if mesh_velocity is not None
                else (np.einsum("nc,nc->n", sol.velocity, sol.normal)[:, None] * sol.normal)
            )
            u = sol.velocity - w
            tri = quad = None
            for spec in carried:
                values, faces = state.fields[spec.name], self.mesh.faces
                if self.transport[spec.name].curved_density:  # Galerkin on the curved cells
                    quad = cell_quadrature(points, faces) if quad is None else quad
                    rates[spec.name] = curved_advective_rate(values, points, faces, u, quad)
                    continue
                tri = triangle_gradients(points, faces) if tri is None else tri
                rates[spec.name] = advective_rate(values, spec.kind, points, faces, u, tri)
        if mesh_velocity is not None or carried:
            sol.seconds["transport"] = time.perf_counter() - t0
        for k, v in sol.seconds.items():
            self.seconds[k] = self.seconds.get(k, 0.0) + v
        return Evaluation(
            points=points,
            velocity=sol.velocity,
            normal=sol.normal,
            pressure=sol.pressure,
            solution=sol,
            edge_length=sol.edge_length,
            state=state,
            mesh_velocity=mesh_velocity,
            field_rates=rates,
            transport=self.transport,
        )

    def run(self, output: str | Path, resume: bool = False, progress: bool = True, force: bool = False) -> Path:
        """Run the scene and write its trajectory file (atomically; dynamic runs resumable).
        An existing ``output``, or its ``.partial`` file with frames, is refused as the command line
        refuses it, unless ``resume`` (continue or extend it) or ``force`` (replace it).
        What the run did is in :attr:`report` (and :meth:`summary`), also when it raised."""
        self.seconds, self.report = {}, None
        try:
            self.report = run_scene(self, Path(output), resume=resume, progress=progress, force=force)
        except BaseException as exc:
            self.report = getattr(exc, "run_report", None)  # what it did before it raised
            raise
        return self.report.path

    def summary(self) -> dict:
        """What the last :meth:`run` took: steps, solves and time per stage (for cost tables)."""
        return run_summary(self)
