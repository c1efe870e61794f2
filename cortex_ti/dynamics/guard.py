"""The stability guard: stops a run that goes unstable or stops meaning anything, naming what to try.

A fixed-step scheme whose step is too large for the problem blows up: high-frequency normal
modes grow by a factor each step. :class:`StabilityGuard` watches the normal speed, the force
balance residual and the mesh, and stops such a run with a
:class:`~cortex_ti.errors.StabilityError` that names the step size to try, before the output
fills with garbage.

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

from ..analysis.diagnostics import mesh_quality
from ..errors import StabilityError
from .schemes import RESOLUTION_HINT, Evaluation

__all__ = ["StabilityGuard", "extensile_tension"]


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
      triangle angle below ``angle_fraction`` of its value at the start of the run).
    """

    growth: float = 1.5
    patience: int = 3
    jump: float = 10.0
    max_fraction: float = 0.5
    max_residual: float = 0.05
    angle_fraction: float = 0.2
    faces: np.ndarray | None = None
    zeta: np.ndarray | None = None  # the tension the nodes carry: tells a physical instability
    _history: list = field(default_factory=list)
    _angle0: float | None = None

    def new_mesh(self, faces: np.ndarray) -> None:
        """The run remeshed: judge the mesh by its new triangles (against the smallest angle at the
        start of the run, as before)."""
        self.faces = faces

    def _min_angle(self, points) -> float:
        return mesh_quality(points, self.faces)["min_angle_deg"]

    def check(self, t: float, dt: float, old_points, new_points, ev: Evaluation, edge_length: np.ndarray) -> None:
        physical = extensile_tension(self.zeta)
        if physical is not None:
            suggestion = (
                f"{physical}; this is the physics, not the numerics: a smaller step or a finer mesh "
                "only changes when it blows up"
            )
        else:
            suggestion = (
                f"try time.dt={dt / 4:.3g} or time.scheme=adaptive; if smaller steps blow up too, the "
                f"mesh is too coarse for the force balance: {RESOLUTION_HINT}"
            )
        if not np.all(np.isfinite(new_points)) or not np.all(np.isfinite(ev.velocity)):
            raise StabilityError(f"the step dt={dt:.3g} produced non-finite values at t={t:.4g}; {suggestion}")
        move = np.linalg.norm(new_points - old_points, axis=1)
        worst = int(np.argmax(move / edge_length))
        if move[worst] > self.max_fraction * edge_length[worst]:
            raise StabilityError(
                f"the step dt={dt:.3g} at t={t:.4g} moves node {worst} by {move[worst]:.3g}, "
                f"{move[worst] / edge_length[worst]:.2f} of its edge length: "
                f"{'the shape is unstable' if physical else 'the explicit scheme is unstable'}; {suggestion}"
            )
        vmax = float(np.max(np.abs(ev.normal_speed)))
        self._history.append(vmax)
        h = self._history
        if len(h) > self.patience:
            recent = h[-self.patience - 1 :]
            if all(
                b > self.growth * a for a, b in zip(recent[:-1], recent[1:], strict=False)
            ) and vmax > self.jump * min(h):
                raise StabilityError(
                    f"max |v_n| grew from {recent[0]:.3g} to {vmax:.3g} in {self.patience} steps of dt={dt:.3g} "
                    f"(t={t:.4g}): "
                    f"{'the shape is unstable' if physical else 'the explicit scheme is unstable at this step'}; "
                    f"{suggestion}"
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
                    f"{self._angle0:.3g} at the start; either the step is unstable ({suggestion}) or the shape is "
                    "not resolved"
                )
