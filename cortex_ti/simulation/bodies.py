"""Several bodies in one run: the solve by body, the division (the cut at the neck) and the remeshing
of each body on its own.

A triangulation whose connected components are several closed surfaces (after a division,
:mod:`cortex_ti.surface.division`) is solved body by body: without a surrounding fluid the bodies do
not interact, so the bordered system of the whole is block diagonal, one block per body with its own
volume constraint and rigid-motion gauge; :func:`solve_by_body` solves each block with the body's own
topology, fit stencils and factorisation and puts the velocities together. Everything else of a step
(the scheme, its error control, the guard, the transport of the fields) works on the whole mesh as
before.

:func:`divide_due` is asked after every accepted step (the remeshing hook): once the neck radius
(:func:`cortex_ti.analysis.sections.neck_radius`, along the pattern's axis) is at or below
``division.neck_radius``, the surface is cut at the neck plane
(:func:`cortex_ti.surface.division.cut_at_plane`), the run goes on with the two daughters on a new
segment of its trajectory, whose group records the cut (:data:`CUT_ATTRS`). The neck is searched
(about 0.1 s at 2562 nodes) at every step only once a frame's neck is within :data:`NEAR` times the
threshold, at the frames before. With ``division.ring: dissolve`` the patterns' extra tension (the
ring) is gone from the daughters at the cut (:func:`dissolved_tension`): the ring disassembles at
abscission, and the daughters round up under the base tension.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING

import numpy as np

from ..analysis.sections import neck_radius
from ..dynamics.state import State
from ..physics.patterns import evaluate_active_stress
from ..solve.constrained import ConstrainedSolver
from ..solve.system import SolveInfo
from ..surface import curved_remesh
from ..surface.curved import midpoint_mask
from ..surface.curved_division import cut_curved
from ..surface.division import body_labels, cut_at_plane, face_labels, remesh_bodies
from ..surface.fits import FIT_SCHEMES, StencilChooser
from ..surface.measures import area_centroid, enclosed_volume
from ..surface.mesh import Mesh
from ..surface.topology import build_topology

if TYPE_CHECKING:  # pragma: no cover
    from .core import Simulation

__all__ = [
    "Body",
    "split_bodies",
    "solve_by_body",
    "divide_due",
    "dissolved_tension",
    "remesh_by_body",
    "body_diagnostics",
    "NEAR",
    "CUT_ATTRS",
    "MAX_BODIES",
    "BODY_VARIABLES",
]

log = logging.getLogger(__name__)

#: the neck is searched at every step once a frame's neck is below this many times division.neck_radius
NEAR = 1.5

#: the attributes of the trajectory segment a division starts (its group ``mesh_<k>``)
CUT_ATTRS = {
    "division_time": "t_a: the time of the cut",
    "division_neck": "R0: the neck radius at the cut",
    "division_volume": "R0^3: the enclosed volume before the cut",
    "division_volumes": "R0^3: the volumes of the two sides of the neck plane (the daughters', by body)",
}


@dataclass
class Body:
    """One closed surface of a mesh with several: its nodes in the whole mesh, its triangles in its
    own numbering, and what a solve on it needs."""

    nodes: np.ndarray
    faces: np.ndarray
    topology: object
    stencils: StencilChooser
    solver: ConstrainedSolver


def split_bodies(sim: Simulation, mesh: Mesh) -> list[Body] | None:
    """The bodies of ``mesh`` (None for one: the whole mesh is solved as it always was)."""
    n, labels = body_labels(mesh.faces, mesh.n_nodes)
    if n == 1:
        return None
    flab = face_labels(mesh.faces, labels)
    s = sim.settings.solver
    out = []
    for b in range(n):
        nodes = np.flatnonzero(labels == b)
        local = np.full(mesh.n_nodes, -1, dtype=np.int64)
        local[nodes] = np.arange(nodes.size)
        sub = Mesh(mesh.points[nodes], local[mesh.faces[flab == b]])
        topology = build_topology(sub)
        apart = (
            midpoint_mask(sub.faces, nodes.size)
            if sim.curved and FIT_SCHEMES[sim.settings.numerics.fit].order >= 4
            else None
        )
        out.append(
            Body(
                nodes,
                sub.faces,
                topology,
                StencilChooser(topology, sim.settings.numerics.fit, apart, sub.points),
                ConstrainedSolver(s.backend, reuse=s.reuse, rtol=s.rtol, refine=s.refine),
            )
        )
    return out


def solve_by_body(sim: Simulation, x: np.ndarray, dt: float, zeta, implicit_rate) -> dict:
    """The solve of :meth:`~cortex_ti.simulation.core.Simulation.solve` body by body (module
    docstring): the fields of its :class:`~cortex_ti.simulation.core.Solution`, the velocities,
    normals and edge lengths put together; the pressure of each body in ``body_pressure`` (the
    solution's ``pressure`` is NaN: there is not one); the residuals combined (norms in quadrature,
    violations their largest)."""
    zeta = sim.zeta if zeta is None else np.asarray(zeta)
    n = x.shape[0]
    velocity, normal, edge = np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n)
    pressures, infos, seconds = [], [], {}
    for body in sim.bodies:
        idx = body.nodes
        rate = None if implicit_rate is None else implicit_rate[idx]
        sol = sim.solve_on(x[idx], body.topology, body.stencils, body.faces, body.solver, dt, zeta[idx], rate)
        velocity[idx], normal[idx], edge[idx] = sol.velocity, sol.normal, sol.edge_length
        pressures.append(sol.pressure)
        infos.append(sol.info)
        for k, v in sol.seconds.items():
            seconds[k] = seconds.get(k, 0.0) + v
    info = SolveInfo(
        backend=infos[0].backend,
        force_residual=math.hypot(*(i.force_residual for i in infos)),
        rhs_norm=math.hypot(*(i.rhs_norm for i in infos)),
        constraint_violation=max(i.constraint_violation for i in infos),
        kkt_residual=max(i.kkt_residual for i in infos),
        iterations=sum(i.iterations for i in infos),
        refactored=any(i.refactored for i in infos),
    )
    return {
        "points": x,
        "velocity": velocity,
        "pressure": float("nan"),
        "info": info,
        "normal": normal,
        "edge_length": edge,
        "seconds": seconds,
        "body_pressure": np.array(pressures, dtype=float),
    }


@dataclass(frozen=True)
class Cut:
    """A division: its time, the neck radius, the volume before and the two sides' volumes, and each
    density's amounts on the two sides."""

    time: float
    neck: float
    volume: float
    volumes: tuple
    amounts: dict

    @property
    def attrs(self) -> dict:
        """The attributes of the trajectory segment the cut starts (:data:`CUT_ATTRS`)."""
        return {
            "division_time": self.time,
            "division_neck": self.neck,
            "division_volume": self.volume,
            "division_volumes": np.array(self.volumes, dtype=float),
        }


def divide_due(sim: Simulation, state: State, t: float) -> State | None:
    """The daughters' state when the neck is at or below ``division.neck_radius`` (module
    docstring), the cut recorded in ``sim.cuts`` and ``sim.segment_attrs``; None otherwise (no
    division asked, already divided, or the neck still wider)."""
    limit = sim.settings.division_neck
    if limit is None or sim.bodies is not None or sim.neck_seen > NEAR * limit:
        return None
    axis = sim.settings.pattern_axis
    radius, height = neck_radius(state.points, state.faces, axis=axis)
    if not np.isfinite(radius) or radius > limit:
        return None
    points, faces = state.points, state.faces
    p0 = area_centroid(points, faces) + height * axis
    # the band: the mean length of the edges across the plane (of the curved cells' corner mesh)
    x, f = curved_remesh.corner_mesh(points, faces) if sim.curved else (points, faces)
    s = (x - p0) @ axis
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    crossing = e[(s[e[:, 0]] >= 0.0) != (s[e[:, 1]] >= 0.0)]
    band = float(np.linalg.norm(x[crossing[:, 0]] - x[crossing[:, 1]], axis=1).mean())
    kinds = {spec.name: spec.kind for spec in sim.fields}
    volume = curved_remesh.curved_volume(points, faces) if sim.curved else enclosed_volume(points, faces)
    rem = sim.settings.mesh.remesh
    # the daughters are settled (Simulation._settle) against no flow: the flow before the cut (a closing
    # neck) has no counterpart on the caps, and what the settling removes is the mesh-scale transient
    flow = np.zeros_like(points) if rem.settle_steps > 0 else None
    how = cut_curved if sim.curved else cut_at_plane
    res = how(points, faces, p0, axis, band, dict(state.fields), kinds, sim.remesh_policy.options)
    after = sim.remesh_policy.judge(res.points, res.faces)
    cut = Cut(float(t), float(radius), float(volume), tuple(res.volumes), res.amounts)
    sim.cuts.append(cut)
    sim.segment_attrs = cut.attrs
    log.info(
        "t = %.4g: the neck %.4g R0 fell to division.neck_radius = %g: cut into two (volumes %.6g + %.6g of %.6g; "
        "%d nodes, smallest angle %.1f deg)",
        t,
        radius,
        limit,
        res.volumes[0],
        res.volumes[1],
        volume,
        len(res.points),
        after,
    )
    sim.use_mesh(res.points, res.faces)
    fields = dict(res.fields)
    if sim.settings.division_ring == "dissolve" and "prescribed_tension" in fields:
        fields["prescribed_tension"] = dissolved_tension(sim.settings.patterns, res.points)
        log.info("t = %.4g: the ring dissolved at the cut (division.ring: dissolve)", t)
    if flow is not None:
        x, fields, moved, steps = sim._settle(state, flow, res.points, res.faces, fields, kinds, rem, list(res.volumes))
        sim.use_mesh(x, res.faces)
        log.info("t = %.4g: the daughters settled in %d pseudo-steps, nodes moved %.2e at most", t, steps, moved)
    sim.segment += 1
    return State(sim.mesh.points, fields, sim.mesh.faces)


def dissolved_tension(patterns, points: np.ndarray) -> np.ndarray:
    """The prescribed tension of the daughters once the ring has dissolved (``division.ring:
    dissolve``): the patterns evaluated on ``points`` with every ``amplitude`` set to 0 (a ring or a
    fold leaves its base tension ``zeta0``; a pattern without an amplitude is kept as it is).

    >>> pat = {"type": "ring", "zeta0": 1.0, "amplitude": 12.0, "sigma": 10.0, "p": 4}
    >>> dissolved_tension([pat], np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])).tolist()
    [1.0, 1.0]
    """
    return evaluate_active_stress(points, [dict(p, amplitude=0.0) if "amplitude" in p else dict(p) for p in patterns])


def remesh_by_body(sim: Simulation):
    """The remeshing of a mesh of several bodies: :func:`cortex_ti.surface.division.remesh_bodies`
    (each body on its own, its own volume restored and each density's amount on it kept; curved
    cells by :func:`~cortex_ti.surface.curved_remesh.remesh_curved`)."""
    return partial(remesh_bodies, method=curved_remesh.remesh_curved) if sim.curved else remesh_bodies


#: the most bodies a trajectory holds (one cut per run: the size of its ``body`` dimension)
MAX_BODIES = 2

#: the per-frame variables of a run with division (``division.neck_radius`` set); a one-body run has none
BODY_VARIABLES = {
    "n_bodies": (("time",), {"units": "1", "long_name": "number of bodies (closed surfaces) of the frame"}),
    "body_volume": (
        ("time", "body"),
        {"units": "R0^3", "long_name": "enclosed volume of each body (NaN for a body not there)"},
    ),
    "body_area": (("time", "body"), {"units": "R0^2", "long_name": "area of each body's triangles"}),
    "body_centroid": (("time", "body", "xyz"), {"units": "R0", "long_name": "area centroid of each body"}),
    "body_pressure": (
        ("time", "body"),
        {"units": "zeta_0/R0", "long_name": "pressure difference P of each body (its volume constraint's multiplier)"},
    ),
}


def body_diagnostics(points: np.ndarray, faces: np.ndarray, pressure: float, body_pressure, curved=False) -> dict:
    """The values of :data:`BODY_VARIABLES` for one frame (the bodies in the order of
    :func:`~cortex_ti.surface.division.body_labels`; ``curved``: the volumes the curved cells')."""
    from ..surface.measures import surface_area

    n, labels = body_labels(faces, len(points))
    flab = face_labels(faces, labels)
    out = {
        "n_bodies": float(n),
        "body_volume": np.full(MAX_BODIES, np.nan),
        "body_area": np.full(MAX_BODIES, np.nan),
        "body_centroid": np.full((MAX_BODIES, 3), np.nan),
        "body_pressure": np.full(MAX_BODIES, np.nan),
    }
    for b in range(min(n, MAX_BODIES)):
        f = faces[flab == b]
        out["body_volume"][b] = curved_remesh.curved_volume(points, f) if curved else enclosed_volume(points, f)
        out["body_area"][b] = surface_area(points, f)
        out["body_centroid"][b] = area_centroid(points, f)
        out["body_pressure"][b] = pressure if body_pressure is None else body_pressure[b]
    return out
