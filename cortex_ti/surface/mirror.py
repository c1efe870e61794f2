r"""A remeshing that keeps a plane of mirror symmetry (``mesh.remesh.mirror``).

MMG's new triangulation of a mirror-symmetric surface is not mirror-symmetric: its discretisation
error has a part odd under the reflection, which seeds the odd modes of the shape. The up-down lobe
mode of a deep furrow grows from that seed by ``e^5 - e^7`` before the neck closes (issue 35,
docs/validation/division.md, "Bending rigidity against the lobe mode"). :func:`mirror_triangulate`
remeshes one half and reflects it:

1. the nodes within :data:`SNAP` times their mean edge length of the plane ``s = (x - p0) . a = 0``
   are moved onto it along ``a``; the surface is clipped there (a node at each crossing of an edge
   between ``s > 0`` and ``s < 0``), the half ``s >= 0`` kept: an open surface whose boundary loop
   lies in the plane, without a sliver of an edge along it;
2. that half is remeshed by :func:`~cortex_ti.surface.remesh.triangulate` (MMG keeps an open
   surface's boundary as a boundary, inserting nodes along it) with half the node budget; the
   repair after MMG moves a node of the boundary loop along the loop only
   (:func:`~cortex_ti.surface.quality.smooth_bad_vertices`), and the loop's nodes, which MMG leaves
   within ~1e-4 R0 of the plane (measured: 0 to 1.3e-4 at the frames of a 2562-node run), are put
   back on it along ``a``. (A repair that moved them toward all their neighbours left them up to
   0.07 R0 off the plane: put back, the triangles touching the plane lost 3-6 deg, issue 35);
3. the half is reflected, ``x' = x - 2 s a``, its triangles' orientation reversed, the loop's nodes
   shared by the two halves;
4. placed on the old curved surface (:func:`cortex_ti.surface.curved_remesh.remesh_curved`), a node
   on the plane stays on it (:func:`keep_on_plane`): on the concave meridian of a neck the closest
   point of a node outside the surface is one of a mirrored pair, off the plane.

The result is a closed triangulation symmetric about the plane to round-off. The state on it (the
curved cells' nodes placed on the old surface, the fields, the volume) is then as symmetric as the
old surface was: the remeshing no longer seeds the odd modes, the odd part already there is carried.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..errors import CortexError
from .division import _clip
from .remesh import RemeshOptions, RemeshResult, triangulate

__all__ = ["mirror_triangulate", "reflect_half", "keep_on_plane", "SNAP"]

#: a node closer to the plane than this times its mean edge length is moved onto it before the cut
SNAP = 0.3


def reflect_half(points: np.ndarray, faces: np.ndarray, p0, axis) -> tuple[np.ndarray, np.ndarray]:
    """The closed surface made of the open half ``(points, faces)`` (on the side ``s >= 0``, its
    boundary loop on the plane) and its mirror image: the loop's nodes put on the plane and shared.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> from cortex_ti.surface.division import euler_characteristic
    >>> m = icosphere(162)
    >>> hx, hf = _clip(m.points, m.faces.astype(int), m.points[:, 2] - 0.1, exact=True)
    >>> x, f = reflect_half(hx, hf, (0, 0, 0.1), (0, 0, 1))
    >>> euler_characteristic(f), bool(abs(x[:, 2] - 0.1).max() < 0.91)
    (2, True)
    """
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    p0 = np.asarray(p0, dtype=float)
    x = np.array(points, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    _, inverse, counts = np.unique(np.sort(directed, axis=1), axis=0, return_inverse=True, return_counts=True)
    on = np.zeros(len(x), dtype=bool)
    on[directed[counts[inverse.ravel()] == 1].ravel()] = True
    if not on.any():
        raise CortexError("the half to reflect has no boundary on the mirror plane")
    s = (x - p0) @ a
    x[on] -= np.outer(s[on], a)
    s[on] = 0.0
    if np.any(s[~on] <= 0.0):
        raise CortexError("the remeshed half crosses the mirror plane: it cannot be reflected")
    n = len(x)
    image = np.where(on, np.arange(n), n + np.cumsum(~on) - 1)
    reflected = x[~on] - 2.0 * np.outer(s[~on], a)
    out = np.vstack([f, image[f][:, ::-1]])
    return np.vstack([x, reflected]), np.ascontiguousarray(out, dtype=np.int32)


def mirror_triangulate(
    points: np.ndarray,
    faces: np.ndarray,
    p0,
    axis,
    options: RemeshOptions,
    kappa: np.ndarray | None = None,
    hausd_scale: float = 1.0,
) -> RemeshResult:
    """:func:`~cortex_ti.surface.remesh.triangulate` of the closed surface ``(points, faces)`` made
    mirror-symmetric about the plane through ``p0`` perpendicular to ``axis`` (module docstring); the
    half on the ``axis``' side is remeshed (``kappa``: the curvature at ``points``, taken at the
    half's nodes from the nearest node)."""
    from scipy.spatial import cKDTree

    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    points = np.asarray(points, dtype=float)
    x = np.array(points, dtype=float)
    f = np.asarray(faces, dtype=np.int64)
    s = (x - np.asarray(p0, dtype=float)) @ a
    near = np.abs(s) < SNAP * _mean_edge(x, f)  # onto the plane: no sliver of an edge at the cut
    x[near] -= np.outer(s[near], a)
    s[near] = 0.0
    hx, hf = _clip(x, f, s, exact=True)
    hk = None if kappa is None else np.asarray(kappa, dtype=float)[cKDTree(points).query(hx)[1]]
    opts = options if options.nodes is None else replace(options, nodes=max(4, (options.nodes + 1) // 2))
    half = triangulate(hx, hf.astype(np.int32), opts, hk, hausd_scale)
    x, f = reflect_half(half.points, half.faces, p0, a)
    return replace(half, points=x, faces=f, n_after=len(x), predicted=2.0 * half.predicted)


def _mean_edge(x: np.ndarray, f: np.ndarray) -> np.ndarray:
    """(N,) the mean length of each node's edges."""
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    length = np.linalg.norm(x[e[:, 0]] - x[e[:, 1]], axis=1)
    total = np.bincount(e.ravel(), np.repeat(length, 2), minlength=len(x))
    return total / np.maximum(np.bincount(e.ravel(), minlength=len(x)), 1)


def keep_on_plane(placed: np.ndarray, before: np.ndarray, p0, axis) -> np.ndarray:
    """``placed`` (N, 3) with the nodes whose ``before`` positions lie on the plane (to 1e-12) moved
    back onto it along ``axis`` (module docstring, step 4: a move of order the square of their
    distance from it times the meridian's curvature away from the surface)."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    p0 = np.asarray(p0, dtype=float)
    on = np.abs((before - p0) @ a) <= 1e-12
    out = np.array(placed, dtype=float)
    out[on] -= np.outer((out[on] - p0) @ a, a)
    return out
