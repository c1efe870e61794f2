"""When a run remeshes, and with which settings: :class:`RemeshPolicy`.

How a surface is remeshed (the size field, the new triangulation, the volume and amounts kept) is
:mod:`cortex_ti.surface.remesh`; this module decides *when*, from the scene's ``mesh.remesh``
(:class:`~cortex_ti.scene.settings.RemeshSettings`, resolved by the settings against the initial
mesh: :meth:`~cortex_ti.scene.settings.RemeshSettings.sized`):

* the angle trigger: the smallest triangle angle below ``min_angle``;
* the resolution trigger (``coarser``, checked every :data:`COARSE_EVERY` accepted steps): the mesh
  coarser than its size field by that factor where it is coarsest;
* after a remeshing, the triggers of the new mesh (:meth:`RemeshPolicy.judge`): a mesh that misses a
  trigger itself would be remeshed at every step, so its own triggers are :data:`RETRIGGER` times its
  smallest angle (only when that is below ``min_angle``) and :data:`COARSE_RETRIGGER` times its
  coarseness.

On a surface of curved cells (``rayleigh_p2``) the angle trigger judges the corner triangles
(``angle_view``), not the four flat sub-triangles of each cell: the remesher makes and repairs the
corner triangles, while the sub-triangles of a well-shaped cell across a strongly curved neck are
distorted by the curvature itself (the cell's midpoints lie off its chords on the surface), which no
remeshing removes: judged on them, amplitude 12's neck at 2562 nodes came out of the remesher with
sub-triangles at 21.5 - 26.5 deg where the corners were at 34 deg, was remeshed again soon, and the run failed
(docs/validation/remesh_constriction.md, "Curved cells"). A corner triangle sheared by the flow shears
its sub-triangles alike, so the trigger still sees the flow's distortion.

The policy holds no mesh: it is asked with points and triangles and keeps only its triggers.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..surface.remesh import budget_scale, edge_curvature, min_angles, node_coarseness, sizes

if TYPE_CHECKING:  # pragma: no cover
    from ..surface.remesh import RemeshOptions

__all__ = ["RETRIGGER", "COARSE_EVERY", "COARSE_RETRIGGER", "RemeshPolicy"]

#: a remeshed surface below the trigger is remeshed again below this fraction of its smallest angle
RETRIGGER = 0.9
#: the resolution trigger (mesh.remesh.coarser) is checked every this many accepted steps
COARSE_EVERY = 10
#: a remeshed surface coarser than the resolution trigger is remeshed again past this multiple of it
COARSE_RETRIGGER = 1.25


class RemeshPolicy:
    """The triggers of a run's remeshing (module docstring) and the options it remeshes with.

    ``min_angle`` (deg) and ``coarser`` (None: no resolution trigger) are the scene's
    ``mesh.remesh`` values; ``options`` the :class:`~cortex_ti.surface.remesh.RemeshOptions` with the
    size defaults resolved. :attr:`below` and :attr:`coarse_below` are the triggers of the current mesh.
    """

    def __init__(self, min_angle: float, options: RemeshOptions, coarser: float | None = None, angle_view=None):
        self.angle_view = angle_view  # (points, faces) -> the triangles whose angles are judged (None: these)
        self.min_angle = float(min_angle)
        self.coarser = coarser
        self.options = options
        self.below = self.min_angle  # the angle trigger of the current mesh
        self.coarse_below = coarser  # the resolution trigger of the current mesh
        self._checks = 0  # accepted steps since the last check of the resolution

    def due(self, points: np.ndarray, faces: np.ndarray) -> str | None:
        """Why the mesh ``(points, faces)`` is remeshed now (a sentence for the log), or None. Asked
        once per accepted step (the resolution is checked every :data:`COARSE_EVERY` askings)."""
        angle = self.smallest_angle(points, faces)
        if angle < self.below:
            return f"smallest angle {angle:.2f} deg < {self.below:.3g}"
        coarse = self.coarseness(points, faces)
        if coarse is None or coarse < self.coarse_below:
            return None
        return f"mesh {coarse:.2f} times coarser than its size field (> {self.coarse_below:.3g})"

    def judge(self, points: np.ndarray, faces: np.ndarray) -> float:
        """Set the triggers of a new mesh (module docstring; the run's min_angle_deg shows them).
        Returns its smallest angle."""
        after = self.smallest_angle(points, faces)
        self.below = self.min_angle if after >= self.min_angle else RETRIGGER * after
        if self.coarse_below is not None:
            own = self.coarseness(points, faces, now=True)
            self.coarse_below = max(self.coarser, COARSE_RETRIGGER * own)
        return after

    def smallest_angle(self, points: np.ndarray, faces: np.ndarray) -> float:
        """The smallest angle (deg) of the triangles the angle trigger judges: the mesh's own, or those
        of ``angle_view`` (a surface of curved cells: its corner triangles,
        :func:`cortex_ti.surface.curved_remesh.corner_mesh`)."""
        mesh = (points, faces) if self.angle_view is None else self.angle_view(points, faces)
        return float(min_angles(*mesh).min())

    def coarseness(self, points: np.ndarray, faces: np.ndarray, now: bool = False) -> float | None:
        """How much coarser than its size field the mesh is where it is coarsest (the largest ratio
        of a node's mean edge length to its target length, the field scaled by the budget on this
        mesh, ungraded); None when the resolution trigger is off or not due (every
        :data:`COARSE_EVERY` askings, unless ``now``)."""
        if self.coarse_below is None:
            return None
        self._checks += 1
        if not now and self._checks < COARSE_EVERY:
            return None
        self._checks = 0
        o = self.options
        kappa = edge_curvature(points, faces)
        scale = o.edge_angle
        if o.nodes is not None:
            scale = budget_scale(points, faces, o.nodes, o.h_min, o.h_max, None, kappa)
        return node_coarseness(points, faces, sizes(kappa, scale, o.h_min, o.h_max))
