"""The quality of a triangulation (its smallest angles) and the local repair of its worst triangles.

MMG's quality measure does not bound the smallest angle: a remeshing leaves a few triangles below
it, obtuse ones at the transitions of the size field and needles at a fine neck. The repair here
(written by hand, numpy) flips the longest edge of a bad triangle where that is the local Delaunay
improvement and moves its nodes tangentially towards their neighbours' centroid, kept on the
surface; :func:`cortex_ti.surface.remesh.remesh` runs it after MMG (docs/method/remeshing.md).
"""

from __future__ import annotations

import numpy as np

from .closest import closest_points
from .measures import min_angles
from .mesh import vertex_normals

__all__ = ["min_angles", "flip_bad_edges", "smooth_bad_vertices", "repair"]


def _pair_quality(points: np.ndarray, tris: list) -> float:
    return float(min_angles(points, np.asarray(tris)).min())


def flip_bad_edges(points: np.ndarray, faces: np.ndarray, goal: float, sweeps: int = 5) -> np.ndarray:
    """Flip the longest edge of every triangle whose smallest angle is below ``goal`` (degrees) when
    that raises the smallest angle of the two triangles sharing it, keeps both triangles facing the
    way the old pair faced and creates no edge that exists already. A few triangles at the
    transitions of the size field come out of MMG obtuse (an angle near 120 deg opposite an edge
    too long for its neighbours); the flip is the local Delaunay repair. Returns new faces."""
    faces = np.array(faces, dtype=np.int64)
    for _ in range(sweeps):
        bad = np.flatnonzero(min_angles(points, faces) < goal)
        if bad.size == 0:
            break
        half = {}
        for t, (a, b, c) in enumerate(faces.tolist()):
            half[(a, b)], half[(b, c)], half[(c, a)] = t, t, t
        neighbours = {}
        for a, b in half:
            neighbours.setdefault(a, set()).add(b)
        flipped = 0
        for t in bad.tolist():
            tri = faces[t].tolist()
            x = points[tri]
            length = np.linalg.norm(x[[1, 2, 0]] - x, axis=1)
            k = int(np.argmax(length))  # edge k: corner k -> k+1
            a, b, c = tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]
            s = half.get((b, a))
            if s is None or faces[t].tolist() != tri:
                continue
            d = next(v for v in faces[s].tolist() if v not in (a, b))
            if d in neighbours.get(c, ()) or c == d:
                continue
            old = [[a, b, c], [b, a, d]]
            new = [[c, a, d], [d, b, c]]
            n_old = sum(np.cross(points[q[1]] - points[q[0]], points[q[2]] - points[q[0]]) for q in old)
            if any(
                np.dot(np.cross(points[q[1]] - points[q[0]], points[q[2]] - points[q[0]]), n_old) <= 0.0 for q in new
            ):
                continue
            if _pair_quality(points, new) <= _pair_quality(points, old):
                continue
            faces[t], faces[s] = new
            for q, f in ((new[0], t), (new[1], s)):
                half[(q[0], q[1])], half[(q[1], q[2])], half[(q[2], q[0])] = f, f, f
            half.pop((a, b), None)
            half.pop((b, a), None)
            neighbours[a].discard(b)
            neighbours[b].discard(a)
            neighbours.setdefault(c, set()).add(d)
            neighbours.setdefault(d, set()).add(c)
            flipped += 1
        if flipped == 0:
            break
    return faces.astype(np.int32)


def smooth_bad_vertices(points: np.ndarray, faces: np.ndarray, goal: float, sweeps: int = 5) -> np.ndarray:
    """Move each node of a triangle with an angle below ``goal`` (degrees) to the centroid of its
    neighbours, in its tangent plane and then back onto the surface (the closest point of the
    triangulation before the move), when that raises the smallest angle of its triangles.
    Returns the new points."""
    reference = np.array(points, dtype=float)
    points = reference.copy()
    normals = vertex_normals(points, faces)
    order = np.argsort(faces.ravel(), kind="stable")
    bounds = np.searchsorted(faces.ravel()[order], np.arange(points.shape[0] + 1))
    for _ in range(sweeps):
        angles = min_angles(points, faces)
        bad = np.flatnonzero(angles < goal)
        if bad.size == 0:
            break
        nodes = np.unique(faces[bad])
        trials = np.empty((nodes.size, 3))
        for j, i in enumerate(nodes.tolist()):
            ring = np.setdiff1d(faces[order[bounds[i] : bounds[i + 1]] // 3], [i])
            step = points[ring].mean(axis=0) - points[i]
            trials[j] = points[i] + step - np.dot(step, normals[i]) * normals[i]
        tri, bary = closest_points(reference, faces, trials)
        trials = np.einsum("qk,qkc->qc", bary, reference[faces[tri]])
        moved = 0
        for j, i in enumerate(nodes.tolist()):
            star = order[bounds[i] : bounds[i + 1]] // 3
            before = min_angles(points, faces[star]).min()
            saved = points[i].copy()
            points[i] = trials[j]
            if min_angles(points, faces[star]).min() <= before:
                points[i] = saved
            else:
                moved += 1
        if moved == 0:
            break
    return points


def repair(points: np.ndarray, faces: np.ndarray, goal: float) -> tuple[np.ndarray, np.ndarray]:
    """Flips, then tangential smoothing, then flips again of the triangles below ``goal`` (degrees):
    the new ``(points, faces)``."""
    faces = flip_bad_edges(points, faces, goal)
    points = smooth_bad_vertices(points, faces, goal)
    return points, flip_bad_edges(points, faces, goal)
