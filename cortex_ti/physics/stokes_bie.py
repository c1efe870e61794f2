r"""The Stokes single-layer operator on a closed triangulated surface (boundary integral method).

For two fluids of the same viscosity ``mu`` on either side of a closed surface ``Gamma`` the
velocity everywhere is the far field plus the single-layer potential of the force density ``f``
the surface puts on the fluids (the jump of the fluids' traction),

.. math:: u(x) = u_\infty(x) + \frac{1}{8\pi\mu}\oint_\Gamma G(x - y)\,f(y)\,dA_y,\qquad
          G(r) = \frac{I}{|r|} + \frac{r\,r^T}{|r|^3},

and, with no slip, ``u`` on ``Gamma`` is the surface's velocity. :func:`single_layer_matrix`
discretises this map: ``f`` linear on every flat triangle (P1, one vector per node), ``u``
collocated at the nodes, so ``u_i = sum_j C_ij f_j`` (3 x 3 blocks, a dense ``(3N, 3N)`` matrix).

Quadrature (docs/method/fluids.md):

* every triangle against every node with Radon's 7-point rule (degree 5);
* where the node is a vertex of the triangle (the weakly singular ``1/r``), replaced by a Duffy
  rule: ``y = a + u (b - a) + u v (c - b)`` collapses the triangle onto the node ``a``, the area
  element ``2 A u du dv`` cancels the ``1/u`` of the kernel, and the integrand is smooth in
  ``(u, v)``: an ``n x n`` Gauss-Legendre product rule;
* where the node is near the triangle (its centroid within ``near`` times the triangle's
  circumradius-like size ``rho``, the largest centroid-vertex distance), replaced by the 7-point
  rule on the ``4**levels`` subtriangles of the triangle's regular splitting.

No Taichi: NumPy in chunks of targets (the far part is ``N x 7F`` kernel evaluations).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

__all__ = [
    "radon7",
    "duffy_rule",
    "split_rule",
    "stokeslet",
    "stresslet_flux",
    "single_layer_matrix",
    "double_layer_matrix",
    "node_areas",
]


def radon7() -> tuple[np.ndarray, np.ndarray]:
    """Radon's 7-point rule on a triangle (exact for degree 5): barycentric points (7, 3) and
    weights (7,) summing to 1 (fractions of the area)."""
    s = math.sqrt(15.0)
    a1, b1 = (6.0 - s) / 21.0, (9.0 + 2.0 * s) / 21.0
    a2, b2 = (6.0 + s) / 21.0, (9.0 - 2.0 * s) / 21.0
    pts = [(1 / 3, 1 / 3, 1 / 3)]
    pts += [(a1, a1, b1), (a1, b1, a1), (b1, a1, a1)]
    pts += [(a2, a2, b2), (a2, b2, a2), (b2, a2, a2)]
    w = [9.0 / 40.0] + [(155.0 - s) / 1200.0] * 3 + [(155.0 + s) / 1200.0] * 3
    return np.array(pts), np.array(w)


def duffy_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The collapsed ``n x n`` Gauss-Legendre rule whose points cluster at vertex 0: barycentric
    points ``(1 - u, u (1 - v), u v)`` and weights ``2 u w_u w_v`` (fractions of the area)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    u, v = np.meshgrid(x, x, indexing="ij")
    wu, wv = np.meshgrid(w, w, indexing="ij")
    u, v, wt = u.ravel(), v.ravel(), (2.0 * u * wu * wv).ravel()
    return np.stack([1.0 - u, u * (1.0 - v), u * v], axis=1), wt


def split_rule(levels: int) -> tuple[np.ndarray, np.ndarray]:
    """Radon's rule on each of the ``4**levels`` subtriangles of the regular splitting."""
    tris = [np.eye(3)]
    for _ in range(levels):
        nxt = []
        for t in tris:
            m01, m12, m20 = (t[0] + t[1]) / 2, (t[1] + t[2]) / 2, (t[2] + t[0]) / 2
            nxt += [np.array(s) for s in ((t[0], m01, m20), (m01, t[1], m12), (m20, m12, t[2]), (m01, m12, m20))]
        tris = nxt
    b, w = radon7()
    pts = np.concatenate([b @ t for t in tris])
    return pts, np.tile(w, len(tris)) / len(tris)


def stokeslet(r: np.ndarray) -> np.ndarray:
    """``G(r) = I / |r| + r r^T / |r|^3`` for ``r`` (..., 3): (..., 3, 3)."""
    d = np.sqrt(np.einsum("...c,...c->...", r, r))
    inv = 1.0 / d
    g = (r[..., :, None] * r[..., None, :]) * (inv**3)[..., None, None]
    idx = np.arange(3)
    g[..., idx, idx] += inv[..., None]
    return g


def node_areas(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``int phi_i dA`` of the P1 hat functions on the flat triangles: a third of the adjacent
    triangles' areas (N,)."""
    e1 = points[faces[:, 1]] - points[faces[:, 0]]
    e2 = points[faces[:, 2]] - points[faces[:, 0]]
    area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    return np.bincount(faces.ravel(), weights=np.repeat(area / 3.0, 3), minlength=points.shape[0])


def stresslet_flux(r: np.ndarray, nrm: np.ndarray) -> np.ndarray:
    """``r r^T (r . n) / |r|^5`` for ``r`` (..., 3), ``n`` (..., 3): (..., 3, 3), the double layer's
    kernel up to its factor."""
    d2 = np.einsum("...c,...c->...", r, r)
    rn = np.einsum("...c,...c->...", r, nrm)
    return (r[..., :, None] * r[..., None, :]) * (rn / d2**2.5)[..., None, None]


def _pair_blocks(x, tri, area, bary, w, double=False, chunk: int = 8192) -> np.ndarray:
    """In chunks of ``chunk`` pairs (the temporaries are (chunk, Q, 3, 3)): :func:`_pair_chunk`."""
    out = np.empty((len(x), 3, 3, 3))
    for s in range(0, len(x), chunk):
        out[s : s + chunk] = _pair_chunk(x[s : s + chunk], tri[s : s + chunk], area[s : s + chunk], bary, w, double)
    return out


def _pair_chunk(x, tri, area, bary, w, double=False) -> np.ndarray:
    """``int_T k(x, y) phi_k(y) dA_y`` for pairs (target x (P, 3), triangle corners tri (P, 3, 3))
    with one rule (bary (Q, 3), w (Q,)): (P, 3 corners, 3, 3); ``k`` the Stokeslet ``G(x - y)``
    or, ``double``, ``stresslet_flux(y - x, n_T)``."""
    y = np.einsum("qk,pkc->pqc", bary, tri)
    if double:
        nt = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        nt /= np.linalg.norm(nt, axis=1)[:, None]
        g = stresslet_flux(y - x[:, None, :], np.broadcast_to(nt[:, None, :], y.shape))
    else:
        g = stokeslet(x[:, None, :] - y)  # (P, Q, 3, 3)
    return np.einsum("pqab,qk,q,p->pkab", g, bary, w, area)


def single_layer_matrix(points: np.ndarray, faces: np.ndarray, mu: float = 1.0, **quadrature) -> np.ndarray:
    """The collocation matrix ``C`` (3N, 3N) of the single layer ``(1 / 8 pi mu) oint G f dA``:
    ``u_i = sum_j C[3i:3i+3, 3j:3j+3] f_j`` for ``f`` linear on every flat triangle (module
    docstring for the quadrature; ``near``, ``duffy_points``, ``near_levels`` its parameters)."""
    return _layer(points, faces, False, **quadrature) / (8.0 * math.pi * mu)


def double_layer_matrix(points: np.ndarray, faces: np.ndarray, **quadrature) -> np.ndarray:
    """The collocation matrix ``Kd`` (3N, 3N) of the double layer normalised so that a rigid
    motion gives half itself: ``Kd[u](x) = (3 / 4 pi) oint (y-x)(y-x)^T ((y-x) . n) / |y-x|^5
    (u(y) - u(x)) dA_y + u(x) / 2``, ``n`` the outward normal, ``u`` linear on every flat
    triangle (the singularity subtracted: the rigid motions exactly, and a node's own flat triangles
    contribute nothing, ``(y - x) . n = 0`` on them). With it, the traction ``f = sigma . n`` of the
    inner and outer Stokes flows that take the surface velocity ``u`` are
    ``S[f_in] / mu_in = u / 2 - Kd u`` and ``S[f_out] / mu_out = -u / 2 - Kd u``
    (``S`` the single layer at ``mu = 1``)."""
    raw = _layer(points, faces, True, **quadrature) * (3.0 / (4.0 * math.pi))
    n = raw.shape[0] // 3
    rows = raw.reshape(n, 3, n, 3).sum(2)  # (N, 3, 3): the row sums of every block row
    out = raw.reshape(n, 3, n, 3)
    idx = np.arange(n)
    out[idx, :, idx, :] += 0.5 * np.eye(3)[None] - rows
    return out.reshape(3 * n, 3 * n)


def near_pairs(
    x: np.ndarray,
    faces: np.ndarray,
    double: bool,
    *,
    near: float = 3.0,
    duffy_points: int = 8,
    near_levels: int = 2,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The (node, triangle) pairs whose 7-point value is replaced (the node's own triangles and the
    near ones, module docstring), the replacement minus the 7-point value and the 7-point value:
    ``(pi, pf, corr, plain)``, ``corr`` and ``plain`` (P, 3 corners, 3, 3) with the kernel's raw factor
    (no ``1 / 8 pi``)."""
    x = np.ascontiguousarray(x, float)
    faces = np.asarray(faces, np.int64)
    nf = faces.shape[0]
    tri = x[faces]
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    bary, w = radon7()
    cen = tri.mean(1)
    rho = np.linalg.norm(tri - cen[:, None, :], axis=2).max(1)
    tree = cKDTree(x)
    cand = tree.query_ball_point(cen, near * rho.max())
    pf = np.repeat(np.arange(nf), [len(k) for k in cand])
    pi = np.concatenate([np.asarray(k, np.int64) for k in cand])
    keep = np.linalg.norm(x[pi] - cen[pf], axis=1) < near * rho[pf]
    pf, pi = pf[keep], pi[keep]
    vert = faces[pf] == pi[:, None]
    own = vert.any(1)
    plain = _pair_blocks(x[pi], tri[pf], area[pf], bary, w, double)
    corr = -plain
    # own triangles: roll the corners so that the target is corner 0, Duffy rule there
    k0 = np.argmax(vert[own], axis=1)
    roll = (k0[:, None] + np.arange(3)[None]) % 3
    fo = np.take_along_axis(faces[pf[own]], roll, axis=1)
    blk = _pair_blocks(x[pi[own]], x[fo], area[pf[own]], *duffy_rule(duffy_points), double)
    back = np.argsort(roll, axis=1)  # rolled corner -> original corner
    corr[own] += np.take_along_axis(blk, back[:, :, None, None], axis=1)
    sb, sw = split_rule(near_levels)
    corr[~own] += _pair_blocks(x[pi[~own]], tri[pf[~own]], area[pf[~own]], sb, sw, double)
    return pi, pf, corr, plain


def _layer(
    points: np.ndarray,
    faces: np.ndarray,
    double: bool,
    *,
    near: float = 3.0,
    duffy_points: int = 8,
    near_levels: int = 2,
    chunk: int = 48,
) -> np.ndarray:
    x = np.ascontiguousarray(points, float)
    faces = np.asarray(faces, np.int64)
    n, nf = x.shape[0], faces.shape[0]
    tri = x[faces]  # (F, 3, 3)
    area = 0.5 * np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    bary, w = radon7()
    nq = len(w)
    y = np.einsum("qk,fkc->fqc", bary, tri).reshape(-1, 3)
    pw = sp.csr_matrix(
        (
            (area[:, None, None] * w[None, :, None] * bary[None]).ravel(),
            (np.repeat(np.arange(nf * nq), 3), np.repeat(faces[:, None, :], nq, axis=1).ravel()),
        ),
        shape=(nf * nq, n),
    )
    pwt = pw.T.tocsr()
    c = np.empty((n, 3, n, 3))
    nt = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    nt = np.repeat(nt / np.linalg.norm(nt, axis=1)[:, None], nq, axis=0)  # (Q, 3) source normals
    for s in range(0, n, chunk):
        e = min(n, s + chunk)
        r = [x[s:e, k, None] - y[None, :, k] for k in range(3)]  # (c, Q) each: x - y
        d2 = r[0] * r[0] + r[1] * r[1] + r[2] * r[2]
        if double:  # r r^T ((y - x) . n) / |r|^5
            scale = -(r[0] * nt[None, :, 0] + r[1] * nt[None, :, 1] + r[2] * nt[None, :, 2]) / d2**2.5
            diag = 0.0
        else:
            inv = 1.0 / np.sqrt(d2)
            scale = inv**3
            diag = (pwt @ inv.T).T
        for a in range(3):
            ra = r[a] * scale
            for b in range(a, 3):
                blk = (pwt @ (ra * r[b]).T).T  # (c, N)
                c[s:e, a, :, b] = blk + diag if a == b else blk
                if a != b:
                    c[s:e, b, :, a] = blk

    # the pairs whose 7-point value is replaced: the node's own triangles and the near ones
    pi, pf, corr, _ = near_pairs(x, faces, double, near=near, duffy_points=duffy_points, near_levels=near_levels)
    # scatter into C[i, a, j, b]
    j = faces[pf]  # (P, 3)
    flat = c.reshape(-1)
    a_idx = np.arange(3)
    lin = (
        (pi[:, None, None, None] * 3 + a_idx[None, None, :, None]) * (3 * n)
        + j[:, :, None, None] * 3
        + a_idx[None, None, None, :]
    )  # (P, k, a, b)
    np.add.at(flat, lin.ravel(), corr.ravel())
    return c.reshape(3 * n, 3 * n)
