"""The closest point of a triangulated surface to given points: which triangle, where in it.

Written by hand (numpy/scipy): a k-d tree of the surface's nodes picks candidate triangles, the
point-triangle distance is the standard region test (Voronoi regions of vertices, edges and face),
vectorised. Remeshing carries fields and projects nodes with it (:mod:`cortex_ti.surface.remesh`,
:mod:`cortex_ti.surface.quality`); tested against a brute-force search over every triangle.
"""

from __future__ import annotations

import numpy as np

__all__ = ["closest_points"]


def _closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentric coordinates ``(..., 3)`` of the closest point of triangle ``abc`` to ``p``
    (all ``(..., 3)``): the point-triangle region test (Voronoi regions of vertices, edges, face)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = np.einsum("...c,...c->...", ab, ap), np.einsum("...c,...c->...", ac, ap)
    bp = p - b
    d3, d4 = np.einsum("...c,...c->...", ab, bp), np.einsum("...c,...c->...", ac, bp)
    cp = p - c
    d5, d6 = np.einsum("...c,...c->...", ab, cp), np.einsum("...c,...c->...", ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        v_face, w_face = vb / denom, vc / denom
        t_ab = d1 / (d1 - d3)
        t_ac = d2 / (d2 - d6)
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
    u = 1.0 - v_face - w_face
    v, w = v_face, w_face
    # the order of the tests matters: the first region that holds wins
    regions = [
        ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), (0.0, 1.0 - t_bc, t_bc)),  # edge bc
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), (1.0 - t_ac, 0.0, t_ac)),  # edge ac
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), (1.0 - t_ab, t_ab, 0.0)),  # edge ab
        ((d6 >= 0) & (d5 <= d6), (0.0, 0.0, 1.0)),  # vertex c
        ((d3 >= 0) & (d4 <= d3), (0.0, 1.0, 0.0)),  # vertex b
        ((d1 <= 0) & (d2 <= 0), (1.0, 0.0, 0.0)),  # vertex a
    ]
    for mask, (ru, rv, rw) in regions:
        u = np.where(mask, ru, u)
        v = np.where(mask, rv, v)
        w = np.where(mask, rw, w)
    return np.stack([u, v, w], axis=-1)


def closest_points(points: np.ndarray, faces: np.ndarray, queries: np.ndarray, k: int = 4):
    """The closest point of the triangulated surface ``(points, faces)`` to each query ``(Q, 3)``:
    its triangle ``(Q,)`` and barycentric coordinates ``(Q, 3)``.

    The candidates are the triangles around the ``k`` nearest nodes (a k-d tree): the closest point
    of a surface to a point within about an edge length of it lies in one of them unless the surface
    folds back closer than that. Tested against a brute-force search over every triangle.
    """
    n = points.shape[0]
    k = min(k, n)
    from scipy.spatial import cKDTree  # only a remeshing needs it (a tenth of a second to import)

    _, near = cKDTree(points).query(queries, k=k)
    near = near.reshape(len(queries), k)
    # node -> its triangles, padded with the first one
    order = np.argsort(faces.ravel(), kind="stable")
    node_of = faces.ravel()[order]
    start = np.searchsorted(node_of, np.arange(n))
    count = np.bincount(node_of, minlength=n)
    width = int(count.max())
    slot = np.minimum(np.arange(width)[None, :], count[:, None] - 1)
    incident = (order[start[:, None] + slot] // 3).astype(np.int64)  # (N, width)
    cand = incident[near].reshape(len(queries), k * width)  # (Q, C)
    x = points[faces[cand]]  # (Q, C, 3, 3)
    q = queries[:, None, :]
    bary = _closest_on_triangles(np.broadcast_to(q, x[:, :, 0].shape), x[:, :, 0], x[:, :, 1], x[:, :, 2])
    foot = np.einsum("qck,qckd->qcd", bary, x)
    dist = np.einsum("qcd,qcd->qc", foot - q, foot - q)
    best = np.argmin(dist, axis=1)
    rows = np.arange(len(queries))
    return cand[rows, best], bary[rows, best]
