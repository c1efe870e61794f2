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

    A node on the boundary of an open surface (on an edge of one triangle) moves along the boundary
    only: to the middle of the arc of the circle through it and its two boundary neighbours
    (:func:`_arc_middle`; a circular loop, a neck's section, stays on itself). MMG keeps an open
    surface's boundary (the mirror plane's loop, :mod:`cortex_ti.surface.mirror`); a move toward all
    its neighbours left it (by up to 0.056 R0 off the plane at a 2562-node neck, measured; the mirror
    put it back, and the triangles touching the plane lost 3-6 deg: issue 35's 24.5 deg). Returns the
    new points."""
    reference = np.array(points, dtype=float)
    along = _boundary(faces)
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
        inner = np.ones(nodes.size, dtype=bool)
        for j, i in enumerate(nodes.tolist()):
            if i in along:  # along the boundary: the middle of the arc through it and its two neighbours
                inner[j] = False
                trials[j] = _arc_middle(points[along[i][0]], points[i], points[along[i][1]])
                continue
            ring = np.setdiff1d(faces[order[bounds[i] : bounds[i + 1]] // 3], [i])
            step = points[ring].mean(axis=0) - points[i]
            trials[j] = points[i] + step - np.dot(step, normals[i]) * normals[i]
        if inner.any():
            tri, bary = closest_points(reference, faces, trials[inner])
            trials[inner] = np.einsum("qk,qkc->qc", bary, reference[faces[tri]])
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


def _boundary(faces: np.ndarray) -> dict:
    """For each node on a boundary loop of a triangulation (its edges of one triangle), its two
    neighbours along it (a node where the boundary is not a simple loop is left out: it stays)."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, counts = np.unique(edges, axis=0, return_counts=True)
    loop = unique[counts == 1]
    ends: dict = {}
    for a, b in loop.tolist():
        ends.setdefault(a, []).append(b)
        ends.setdefault(b, []).append(a)
    return {i: n for i, n in ends.items() if len(n) == 2}


def _arc_middle(a: np.ndarray, x: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The point halfway between ``a`` and ``b`` on the circle through ``a``, ``x`` and ``b`` (on the arc
    through ``x``): a node of a boundary loop moved along the loop's curve, not along its chords (which
    at a coarse loop lie far inside it: the midpoint of a 4-node loop's neighbours is at 0.7 of its
    radius). Collinear points: the midpoint of ``a`` and ``b``.

    >>> p = _arc_middle(np.array([1.0, 0, 0]), np.array([0.0, 1.0, 0]), np.array([-0.6, 0.8, 0]))
    >>> bool(np.allclose(p, [np.sqrt(0.2), np.sqrt(0.8), 0.0], atol=1e-14))  # on the unit circle, halfway
    True
    """
    u, v = a - x, b - x
    w = np.cross(u, v)
    ww = float(np.dot(w, w))
    mid = 0.5 * (a + b)
    if ww <= 1e-24 * float(np.dot(u, u) * np.dot(v, v)):
        return mid
    centre = x + (np.dot(u, u) * np.cross(v, w) + np.dot(v, v) * np.cross(w, u)) / (2.0 * ww)
    radius = float(np.linalg.norm(a - centre))
    d = mid - centre
    if float(np.linalg.norm(d)) <= 1e-12 * radius:  # a and b opposite: the side of x
        d = x - centre
        d = d - np.dot(d, b - a) / np.dot(b - a, b - a) * (b - a)
    elif np.dot(d, x - centre) < 0.0:  # x on the far arc
        d = -d
    return centre + radius * d / np.linalg.norm(d)


def repair(points: np.ndarray, faces: np.ndarray, goal: float) -> tuple[np.ndarray, np.ndarray]:
    """Flips, then tangential smoothing, then flips again of the triangles below ``goal`` (degrees):
    the new ``(points, faces)``."""
    faces = flip_bad_edges(points, faces, goal)
    points = smooth_bad_vertices(points, faces, goal)
    return points, flip_bad_edges(points, faces, goal)
