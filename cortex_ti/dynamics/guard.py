"""The stability guard: stops a run that goes unstable or stops meaning anything, naming what to try.

A fixed-step scheme whose step is too large for the problem blows up: high-frequency normal
modes grow by a factor each step. :class:`StabilityGuard` watches the normal speed, the force
balance residual and the mesh, and stops such a run with a
:class:`~cortex_ti.errors.StabilityError` that names the step size to try, before the output
fills with garbage.

When it stops a run it says which of three things it sees (:meth:`StabilityGuard.diagnosis`): a
**closing neck** (the surface comes within two edge lengths of itself across the body: a pinch
toward division, a physical singularity the model does not go through), an **unstable step**
(shorten it; unless an adaptive scheme has already shortened it a hundredfold, which no step
fixes), or a **distorted mesh** (its triangles collapse while the flow does not blow up: remesh).

Not every blow-up is numerical. A cortex under *extensile* active tension (zeta < 0) is
physically unstable: a negative tension does work on any wrinkle that adds area, so its shape
modes grow at a rate set by the physics, and a smaller step or a finer mesh only changes when
the run blows up, not whether. :func:`extensile_tension` detects such a
scene (a dynamic run warns at its start) and the guard, given the tension, says so instead of
suggesting a smaller step.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..analysis.diagnostics import mesh_quality, surface_stress
from ..errors import StabilityError
from .schemes import RESOLUTION_HINT, Evaluation

__all__ = ["StabilityGuard", "extensile_tension", "closing_neck", "unresolved_spot"]

#: a neck closer than this many edge lengths across the body is closing (the guard's diagnosis)
NECK_EDGES = 2.0
#: an adaptive step below this fraction of the largest step taken is not what a shorter step fixes
STEP_COLLAPSE = 1e-2
#: a myosin peak above this many times the field's median is a spot ...
SPOT_CONTRAST = 3.0
#: ... which the mesh no longer resolves when fewer nodes than this (a node and its two rings of
#: neighbours on a regular mesh: 1 + 6 + 12) lie at or above half its height over the median
SPOT_NODES = 19
#: ... and they lie within this many edge lengths of the peak (two rings, with room for distortion)
SPOT_EDGES = 4.0


def extensile_tension(zeta) -> str | None:
    """A sentence on the extensile part of a tension field (``None`` if ``zeta >= 0`` everywhere)."""
    if zeta is None:
        return None
    z = np.asarray(zeta, dtype=float)
    neg = z < 0.0
    if not np.any(neg):
        return None
    share = "everywhere" if np.all(neg) else f"at {int(neg.sum())} of {z.size} nodes"
    return (
        f"the active tension is extensile (zeta < 0 {share}, down to {float(z.min()):.3g}): a cortex under "
        "extensile tension is physically unstable (its shape modes grow whatever the step and the mesh)"
    )


def closing_neck(points, faces, normals, within: float = NECK_EDGES) -> tuple[int, float] | None:
    """Where the surface comes within ``within`` edge lengths of itself across the body: two nodes
    more than two rings apart whose outward normals face each other (``n_i . n_j < -0.9``) closer
    than ``within`` times the mean length of the edges at either. Returns (that node, the gap) for
    the narrowest such gap relative to the edge length, None if there is none.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> closing_neck(m.points, m.faces, m.points) is None  # a sphere has no neck
    True"""
    import scipy.sparse as sp
    from scipy.spatial import cKDTree

    points, faces = np.asarray(points, dtype=float), np.asarray(faces)
    n = points.shape[0]
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    a = sp.csr_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(n, n))
    a = ((a + a.T + sp.identity(n)) > 0).astype(np.float64)
    near = (a @ a).tocsr()  # within two rings
    length = np.linalg.norm(points[e[:, 0]] - points[e[:, 1]], axis=1)
    edge_length = np.bincount(e.ravel(), np.repeat(length, 2), minlength=n) / np.maximum(
        np.bincount(e.ravel(), minlength=n), 1
    )
    pairs = cKDTree(points).query_pairs(within * float(edge_length.max()), output_type="ndarray")
    if pairs.size == 0:
        return None
    i, j = pairs[:, 0], pairs[:, 1]
    d = np.linalg.norm(points[i] - points[j], axis=1)
    facing = np.einsum("ij,ij->i", normals[i], normals[j]) < -0.9
    apart = np.asarray(near[i, j]).ravel() == 0
    ratio = d / np.minimum(edge_length[i], edge_length[j])
    hit = facing & apart & (ratio < within)
    if not hit.any():
        return None
    k = np.flatnonzero(hit)[np.argmin(ratio[hit])]
    return int(i[k]), float(d[k])


def unresolved_spot(density, points=None, edge_length=None) -> tuple[int, float, int] | None:
    """A myosin spot narrower than the mesh resolves: the peak of ``density`` (N,) when it exceeds
    :data:`SPOT_CONTRAST` times the median and fewer than :data:`SPOT_NODES` nodes lie at or above
    half its height over the median, all of them (with ``points`` and ``edge_length``) within
    :data:`SPOT_EDGES` edge lengths of the peak: a spot, not a thin band such as a ring one node wide.
    Returns (the peak's node, peak / median, those nodes) or None. A density that concentrates
    without a bound (the linear tension law past its onset) ends in such a spot: the discretisation
    then fails, whatever the step (the solve turns singular).

    >>> import numpy as np
    >>> c = np.ones(100); c[7] = 5.0
    >>> unresolved_spot(c)  # one node
    (7, 5.0, 1)
    >>> c[:30] = 5.0
    >>> unresolved_spot(c) is None  # thirty
    True"""
    spot = _spot(density)
    if spot is None or spot[2].size >= SPOT_NODES:
        return None
    peak, ratio, high = spot
    if points is not None and edge_length is not None:
        reach = float(np.linalg.norm(points[high] - points[peak], axis=1).max())
        if reach > SPOT_EDGES * float(edge_length[peak]):
            return None
    return peak, ratio, high.size


def _spot(density) -> tuple[int, float, np.ndarray] | None:
    """The peak of ``density`` when above :data:`SPOT_CONTRAST` times the median: (its node, peak /
    median, the nodes at or above half its height over the median); None otherwise."""
    c = np.asarray(density, dtype=float)
    base = float(np.median(c))
    peak = int(np.argmax(c))
    top = float(c[peak])
    if not (base > 0.0 and top > SPOT_CONTRAST * base):
        return None
    return peak, top / base, np.flatnonzero(c - base >= 0.5 * (top - base))


@dataclass
class StabilityGuard:
    """Stops a run that is going unstable or has stopped meaning anything, naming what to try.

    Checked after every step:

    * signs of an explicit instability: non-finite positions; a node displaced by more than
      ``max_fraction`` of its shortest edge in one step; or the largest normal speed growing by
      more than ``growth`` per step for ``patience`` consecutive steps while exceeding its
      running minimum by ``jump``;
    * signs of an unresolved shape, which a damped (semi-implicit) step can otherwise carry on
      through: the force balance no longer satisfied (relative least-squares residual above
      ``max_residual``; resolved runs stay below 3e-3), or the mesh collapsing (the smallest
      triangle angle below ``angle_fraction`` of its value at the start of the run);
    * a myosin field collapsed into a spot the mesh cannot resolve (:func:`unresolved_spot`): a
      resolution problem, not the step's.
    """

    growth: float = 1.5
    patience: int = 3
    jump: float = 10.0
    max_fraction: float = 0.5
    max_residual: float = 0.05
    angle_fraction: float = 0.2
    faces: np.ndarray | None = None
    zeta: np.ndarray | None = None  # the tension the nodes carry: tells a physical instability
    viscosity: tuple[float, float] | None = None  # (eta_s, eta_b) of a cortex without bending resistance
    tension: object = None  # (fields, N) -> the tension of a state's fields (default: ``zeta`` if it fits)
    _history: list = field(default_factory=list)
    _angle0: float | None = None
    _largest_dt: float = 0.0

    def new_mesh(self, faces: np.ndarray) -> None:
        """The run remeshed: judge the mesh by its new triangles (against the smallest angle at the
        start of the run, as before)."""
        self.faces = faces

    def _min_angle(self, points) -> float:
        return mesh_quality(points, self.faces)["min_angle_deg"]

    def diagnosis(self, t: float, dt: float, points, ev: Evaluation) -> str | None:
        """What a stop means when it is not the step (None: it may be): a closing neck, or an adaptive
        step already fallen a hundredfold below the largest one taken before it."""
        if self.faces is not None and ev.normal is not None:
            neck = closing_neck(points, self.faces, ev.normal)
            if neck is not None:
                i, gap = neck
                return (
                    f"the neck is closing: at t={t:.4g} the surface is {gap:.3g} R0 across at node {i}, within "
                    f"{NECK_EDGES:g} edge lengths: a pinch toward division, a physical singularity the model does not "
                    "go through (neither a smaller step nor remeshing helps)"
                )
        if self._largest_dt > 0 and dt < STEP_COLLAPSE * self._largest_dt:
            return (
                f"the adaptive step has already fallen from {self._largest_dt:.3g} to {dt:.3g}, so a shorter "
                f"one will not help: {self.compression(ev) or 'a mode of this shape or mesh grows at any step'} "
                "(`cortex-ti modes RUN.h5.partial --time T` lists the growing modes of a frame)"
            )
        return None

    def compression(self, ev: Evaluation) -> str | None:
        """A sentence on the triangles where the cortex's surface stress (tension plus viscous,
        :func:`~cortex_ti.analysis.diagnostics.surface_stress`) is compressive, None if there are none
        (or the guard was not given the viscosities). Without bending resistance a compressed cortex
        wrinkles at the mesh scale whatever the step: after a remeshing of a deep furrow the new
        mesh's relaxation compresses a few triangles at the neck where the continuum stays under
        tension (docs/validation/remesh_constriction.md, "The mode after a remeshing")."""
        if self.viscosity is None or self.faces is None or ev.velocity is None:
            return None
        zeta = self._tension(ev)
        if zeta is None:
            return None
        sigma = surface_stress(ev.points, self.faces, ev.velocity, zeta, *self.viscosity)[:, 0]
        bad = np.flatnonzero(sigma < 0.0)
        if bad.size == 0:
            return None
        k = int(bad[np.argmin(sigma[bad])])
        where = np.asarray(ev.points)[self.faces[k]].mean(axis=0)
        return (
            f"the surface stress (tension + viscous) is compressive on {bad.size} triangle"
            f"{'s' if bad.size > 1 else ''} (down to {float(sigma[k]):.3g} at ({where[0]:.3f}, {where[1]:.3f}, "
            f"{where[2]:.3f})), where a cortex without bending resistance wrinkles at the mesh scale at any step "
            "(after a remeshing, mesh.remesh.settle_steps removes the transient that compresses it)"
        )

    def _tension(self, ev: Evaluation):
        """The tension of the evaluated state (its fields), else the one the guard was given if it fits."""
        n = len(ev.points)
        if self.tension is not None and ev.state is not None:
            return np.asarray(self.tension(ev.state.fields, n), dtype=float)
        if self.zeta is not None and np.shape(self.zeta) == (n,):
            return np.asarray(self.zeta, dtype=float)
        return None

    def failed_solve(self, error: Exception, ev: Evaluation) -> Exception:
        """What a solve that failed in a step from ``ev`` means: a myosin field gathering into a spot
        (its peak above :data:`SPOT_CONTRAST` times the median) outruns the mesh, the solve breaks
        before the spot is narrower than :func:`unresolved_spot` waits for (``myosin_noise`` at 2562
        nodes: the solve fails at t = 12.44 with the peak 31.7 times the median on 36 nodes at half
        height): a resolution problem, said as one, with the solver's message. Otherwise ``error``."""
        fields = ev.state.fields if ev.state is not None else {}
        if "myosin" not in fields:
            return error
        spot = _spot(fields["myosin"])
        if spot is None:
            return error
        _, ratio, high = spot
        nodes = high.size
        return StabilityError(
            f"the myosin is collapsing into a spot (its peak {ratio:.3g} times the median density, {nodes} nodes at "
            "half height) faster than the mesh resolves it: a resolution problem, not the time step; a finer mesh "
            f"(mesh.nodes) follows the spot further (the solver: {error})"
        )

    def check(self, t: float, dt: float, old_points, new_points, ev: Evaluation, edge_length: np.ndarray) -> None:
        physical = extensile_tension(self.zeta)

        def advice(growing: bool) -> str:
            """What to do, said once the guard stops (the neck search is not paid on every step)."""
            if physical is not None:
                return (
                    f"{physical}; this is the physics, not the numerics: a smaller step or a finer mesh "
                    "only changes when it blows up"
                )
            finite = np.all(np.isfinite(new_points))
            other = self.diagnosis(t, dt, new_points if finite else old_points, ev)
            if other is not None:
                return other
            if not growing:
                return (
                    "the flow does not blow up, the mesh is distorted: remesh (mesh.remesh.min_angle, e.g. 25) or "
                    "move the nodes tangentially (mesh.motion: ale)"
                )
            return (
                f"try time.dt={dt / 4:.3g} or time.scheme=adaptive; if smaller steps blow up too, the "
                f"mesh is too coarse for the force balance: {RESOLUTION_HINT}"
            )

        unstable = "the shape is unstable" if physical else "the explicit scheme is unstable"
        if not np.all(np.isfinite(new_points)) or not np.all(np.isfinite(ev.velocity)):
            raise StabilityError(f"the step dt={dt:.3g} produced non-finite values at t={t:.4g}; {advice(True)}")
        move = np.linalg.norm(new_points - old_points, axis=1)
        worst = int(np.argmax(move / edge_length))
        if move[worst] > self.max_fraction * edge_length[worst]:
            raise StabilityError(
                f"the step dt={dt:.3g} at t={t:.4g} moves node {worst} by {move[worst]:.3g}, "
                f"{move[worst] / edge_length[worst]:.2f} of its edge length: {unstable}; {advice(True)}"
            )
        vmax = float(np.max(np.abs(ev.normal_speed)))
        self._history.append(vmax)
        h = self._history
        growing = len(h) > 1 and h[-1] > self.growth * h[-2]
        if len(h) > self.patience:
            recent = h[-self.patience - 1 :]
            if all(
                b > self.growth * a for a, b in zip(recent[:-1], recent[1:], strict=False)
            ) and vmax > self.jump * min(h):
                raise StabilityError(
                    f"max |v_n| grew from {recent[0]:.3g} to {vmax:.3g} in {self.patience} steps of dt={dt:.3g} "
                    f"(t={t:.4g}): {unstable}{'' if physical else ' at this step'}; {advice(True)}"
                )
        fields = ev.state.fields if ev.state is not None else {}
        if "myosin" in fields:
            spot = unresolved_spot(fields["myosin"], new_points, edge_length)
            if spot is not None:
                node, ratio, nodes = spot
                raise StabilityError(
                    f"the myosin has collapsed into a spot the mesh cannot resolve at t={t - dt:.4g}: its peak at "
                    f"node {node}, {ratio:.3g} times the median density, has {nodes} node{'s' if nodes > 1 else ''} "
                    f"at half height (fewer than {SPOT_NODES}, a node and its two rings): a resolution problem, not "
                    "the time step; a finer mesh (mesh.nodes) follows the spot further"
                )
        residual = ev.solution.info.relative_residual
        if residual > self.max_residual:
            raise StabilityError(
                f"the force balance is no longer satisfied at t={t - dt:.4g}: relative least-squares residual "
                f"{residual:.2g} > {self.max_residual:g} (resolved runs stay below 3e-3); the shape is not resolved: "
                f"{physical + '; ' if physical else ''}{RESOLUTION_HINT}"
            )
        if self.faces is not None:
            if self._angle0 is None:
                self._angle0 = self._min_angle(old_points)
            angle = self._min_angle(new_points)
            if angle < self.angle_fraction * self._angle0:
                raise StabilityError(
                    f"the mesh is collapsing at t={t:.4g}: smallest triangle angle {angle:.2g} deg, from "
                    f"{self._angle0:.3g} at the start; {advice(growing)}"
                )
        self._largest_dt = max(self._largest_dt, dt)  # after the checks: a diagnosis compares with the steps before
