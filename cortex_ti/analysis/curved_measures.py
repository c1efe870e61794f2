r"""The shape measures of a surface made of curved six-node cells (formulation ``rayleigh_p2``).

A run on curved cells has its surface between the nodes on the quadratic cells, not on the flat
triangles that are their vertex view (:mod:`cortex_ti.surface.curved`): a flat section of a sphere
of N nodes lies inside it by O(h^2) (6.4e-4 at 2562 nodes), which is more than the formulation's
error. Here every measure is taken on the curved cells:

* ``volume`` ``1/3 int x . n dA`` and ``area``, by the cells' quadrature (a sphere's volume to 1e-6 at
  2562 nodes, the cells' own geometric error);
* ``furrow_radius``: the plane through the area centroid normal to the axis cut with the cells. Each
  edge of a flat sub-triangle that the plane crosses is a straight segment of its cell's reference
  triangle, along which the cell's map is quadratic, so the crossing on the curved cell is the root of
  a quadratic; the radius is the mean distance of these points from the axis, weighted by the lengths
  of the section's segments (exact on any circle);
* ``pole_radius``: half the distance between the outermost crossings of the axis line, each found on
  the flat sub-triangle it hits and then on its curved cell by Newton's method on the cell's map.

The long-axis radii use the curved second moment's long axis. :func:`curved_neck_radius` is the
neck of :func:`cortex_ti.analysis.sections.neck_radius` (the smallest interior local minimum of the
section radius over the planes along the axis) with the sections cut on the curved cells.
"""

from __future__ import annotations

import numpy as np

from ..surface.curved import p2_cells, p2_shape, triangle_rule
from .sections import profile_minimum

__all__ = ["curved_measures", "curved_neck_radius"]

#: reference coordinates of a cell's six nodes, and each of its four flat sub-triangles' local nodes
_REF = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]])
_SUB = np.array([[0, 3, 5], [1, 4, 3], [2, 5, 4], [3, 4, 5]])


#: the 4 x 4 rule (degree 7) on which the volume, area and centroid are integrated: its shape functions
#: (Q, 6) and their two reference derivatives stacked (2Q, 6), rule weights (Q,)
_RULE_POINTS, _RULE_WEIGHTS = triangle_rule(4)
_RULE_SHAPE, _RULE_DSHAPE = p2_shape(_RULE_POINTS)
_RULE_D = np.concatenate([_RULE_DSHAPE[:, :, 0], _RULE_DSHAPE[:, :, 1]])
#: the three stacked (3Q, 6): positions, first and second tangents at the rule's points
_RULE_ALL = np.concatenate([_RULE_SHAPE, _RULE_D]).T.copy()


def _quadrature(points, cells):
    """Positions and weighted normals ``n dA`` at the rule's points, (3, Q T) each, component first:
    one matrix product for all cells and components (a batch of (Q, 6) x (6, 3) products per cell cost
    3x more at 2562 nodes), laid out so that every component at every rule point is a contiguous row
    over the cells, the cross product by components."""
    nq = len(_RULE_WEIGHTS)
    xc = points[cells].transpose(1, 2, 0).reshape(6, -1)  # (6, 3 T)
    all_ = (_RULE_ALL.T @ xc).reshape(3, nq, 3, len(cells))  # (position / tangent 1 / tangent 2, Q, 3, T)
    x, a, b = all_
    nda = np.empty((3, nq, len(cells)))
    nda[0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    nda[1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    nda[2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    nda *= _RULE_WEIGHTS[None, :, None]
    return x.transpose(1, 0, 2).reshape(3, -1), nda.reshape(3, -1)  # positions and n dA


def _cells_and_centre(points, faces):
    """``(points, cells, x, n dA, dA, centre)``: the curved cells of ``faces``, their quadrature
    points (3, P), weighted normals (3, P) and areas (P,), and the surface's area centroid."""
    points = np.asarray(points, dtype=float)
    cells = p2_cells(np.asarray(faces))
    x, nda = _quadrature(points, cells)
    da = np.sqrt(nda[0] * nda[0] + nda[1] * nda[1] + nda[2] * nda[2])
    return points, cells, x, nda, da, x @ da / da.sum()


def _section_points(points, faces, cells, axis, c):
    """Crossings of the plane through ``c`` normal to ``axis`` with the curved cells: the two crossing
    points of every flat sub-triangle the plane cuts (M, 2, 3)."""
    node_up = ((points - c) @ axis >= 0.0).view(np.uint8)
    count = node_up[faces[:, 0]] + node_up[faces[:, 1]] + node_up[faces[:, 2]]  # nodes above, per triangle
    mixed = np.flatnonzero((count > 0) & (count < 3))
    up = node_up[faces[mixed]].astype(bool)  # (M, 3)
    if mixed.size == 0:
        raise ValueError("the plane does not cut the surface: the furrow radius is undefined")
    out = np.empty((mixed.size, 2, 3))
    sub = _SUB[mixed % 4]  # local nodes of each sub-triangle
    cell = cells[mixed // 4]
    xc = points[cell]  # (M, 6, 3)
    found = np.zeros(mixed.size, dtype=int)
    for k in range(3):
        a, b = sub[:, k], sub[:, (k + 1) % 3]
        ua = up[:, k]
        ub = up[:, (k + 1) % 3]
        crossed = ua != ub
        if not crossed.any():
            continue
        idx = np.flatnonzero(crossed)
        ra, rb = _REF[a[idx]], _REF[b[idx]]
        p0 = xc[idx, a[idx]]
        p1 = xc[idx, b[idx]]
        ph = np.einsum("ki,kic->kc", p2_shape(0.5 * (ra + rb))[0], xc[idx])
        # X(s) = p0 + s b1 + s^2 b2 on the curved cell, h(s) = (X(s) - c) . axis
        b1 = -3.0 * p0 + 4.0 * ph - p1
        b2 = 2.0 * p0 - 4.0 * ph + 2.0 * p1
        h0, h1, h2 = (p0 - c) @ axis, b1 @ axis, b2 @ axis
        s = _root(h0, h1, h2)
        pts = p0 + s[:, None] * b1 + (s * s)[:, None] * b2
        out[idx, found[idx]] = pts
        found[idx] += 1
    return out[found == 2]


def _root(h0, h1, h2):
    """The root in [0, 1] of ``h0 + h1 s + h2 s^2`` (a sign change between s = 0 and 1)."""
    lin = -h0 / np.where(h1 != 0.0, h1, 1e-300)
    disc = np.sqrt(np.maximum(h1 * h1 - 4.0 * h0 * h2, 0.0))
    # the numerically stable pair of roots
    qq = -0.5 * (h1 + np.copysign(disc, h1))
    r1 = qq / np.where(h2 != 0.0, h2, 1e-300)
    r2 = h0 / np.where(qq != 0.0, qq, 1e-300)
    small = np.abs(h2) <= 1e-14 * (np.abs(h1) + np.abs(h0))
    pick = np.where((r1 >= -1e-9) & (r1 <= 1.0 + 1e-9), r1, r2)
    return np.clip(np.where(small, lin, pick), 0.0, 1.0)


def _furrow(points, faces, cells, axis, c) -> float:
    seg = _section_points(points, faces, cells, axis, c)
    rel = seg - c
    dist = np.linalg.norm(rel - (rel @ axis)[..., None] * axis, axis=-1)  # (M, 2)
    length = np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1)
    if not length.sum() > 0:
        raise ValueError("the plane only touches the surface: the furrow radius is undefined")
    return float((length * dist.mean(1)).sum() / length.sum())


def _pole(points, faces, cells, axis, c) -> float:
    # only the flat sub-triangles whose box in the plane normal to the axis holds the axis line (with a
    # margin far above the hit test's 1e-9 in barycentric coordinates): the same hits, 10-100x fewer
    # triangles to test
    b1 = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
    b1 /= np.linalg.norm(b1)
    plane = (points - c) @ np.column_stack([b1, np.cross(axis, b1)])  # (N, 2)
    margin = 1e-6 * (np.abs(plane).max() + 1.0)
    # per node four bits: below / above the line in each of the plane's two directions; a box holds
    # the line where its three nodes have all four between them
    code = (plane <= margin).astype(np.uint8) @ np.array([1, 2], np.uint8)
    code |= (plane >= -margin).astype(np.uint8) @ np.array([4, 8], np.uint8)
    near = np.flatnonzero((code[faces[:, 0]] | code[faces[:, 1]] | code[faces[:, 2]]) == 15)
    x = points[faces[near]]
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    pv = np.cross(axis, e2)
    det = np.einsum("fc,fc->f", e1, pv)
    ok = np.abs(det) > 1e-300
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = c - x[:, 0]
    u = np.einsum("fc,fc->f", tv, pv) * inv
    qv = np.cross(tv, e1)
    v = (qv @ axis) * inv
    s = np.einsum("fc,fc->f", e2, qv) * inv
    tol = 1e-9
    hit = ok & (u >= -tol) & (v >= -tol) & (u + v <= 1.0 + tol)
    if not (hit & (s > 0)).any() or not (hit & (s < 0)).any():
        raise ValueError("the axis line does not cross the surface on both sides: the pole radius is undefined")
    ends = []
    for side in (np.argmax(np.where(hit & (s > 0), s, -np.inf)), np.argmin(np.where(hit & (s < 0), s, np.inf))):
        k = int(side)
        f = int(near[k])
        sub = _SUB[f % 4]
        cell_pts = points[cells[f // 4]]
        # the flat hit's barycentric coordinates give the start in the cell's reference triangle
        ref = (1 - u[k] - v[k]) * _REF[sub[0]] + u[k] * _REF[sub[1]] + v[k] * _REF[sub[2]]
        t = s[k]
        for _ in range(8):
            n, dn = p2_shape(ref[None])
            xx = n[0] @ cell_pts
            jac = np.column_stack([dn[0, :, 0] @ cell_pts, dn[0, :, 1] @ cell_pts, -axis])
            res = xx - (c + t * axis)
            step = np.linalg.solve(jac, -res)
            ref = ref + step[:2]
            t = t + step[2]
            if np.abs(step).max() < 1e-15:
                break
        ends.append(t)
    return 0.5 * float(ends[0] - ends[1])


def curved_measures(points, faces, axis=(0.0, 0.0, 1.0)) -> dict[str, float]:
    """Volume, area and the pole and furrow radii along ``axis`` and along the long axis, measured on
    the curved cells of the split mesh ``faces`` (module docstring); the keys of
    :func:`cortex_ti.analysis.diagnostics.frame_diagnostics` they replace. A radius that is undefined
    is NaN.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = curved_measures(icosphere(2562).points, icosphere(2562).faces)
    >>> round(m["volume"], 5), round(m["furrow_radius"], 7), round(m["pole_radius"], 12)
    (4.18875, 0.9999982, 1.0)
    """
    faces = np.asarray(faces)
    points, cells, x, nda, da, centre = _cells_and_centre(points, faces)
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    area = float(da.sum())
    rel = x - centre[:, None]
    moment = (rel * da) @ rel.T
    w, vec = np.linalg.eigh(moment)
    long_ax = vec[:, 2] if (w[2] - w[1]) > 1e-9 * abs(w[2]) else axis
    long_ax = long_ax if long_ax @ axis >= 0 else -long_ax
    out = {"volume": float(np.einsum("cp,cp->", x, nda) / 3.0), "area": area}
    for suffix, ax in (("", axis), ("_long_axis", long_ax)):
        for name, func in (("pole_radius", _pole), ("furrow_radius", _furrow)):
            if suffix and np.abs(ax - axis).max() <= 1e-9:
                # the same axis: the radii would differ by at most 1e-9 (an axisymmetric shape's long axis is
                # the pattern axis to 1e-10, which changes its radii by O(1e-20))
                out[name + suffix] = out[name]
                continue
            try:
                out[name + suffix] = func(points, faces, cells, ax, centre)
            except (ValueError, np.linalg.LinAlgError):
                out[name + suffix] = float("nan")
    return out


def curved_neck_radius(points, faces, axis=(0.0, 0.0, 1.0), planes: int = 64) -> tuple[float, float]:
    """The neck on the curved cells: the smallest interior local minimum, over the planes
    perpendicular to ``axis``, of the curved section radius (the furrow radius of
    :func:`curved_measures` in each plane), refined by a bounded scalar minimisation between the
    neighbouring planes. Returns ``(radius, height)``, the height from the curved area centroid;
    ``(nan, nan)`` without an interior minimum (a convex body).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(642)
    >>> bool(np.isnan(curved_neck_radius(m.points, m.faces)[0]))
    True
    """
    faces = np.asarray(faces)
    points, cells, _, _, _, centre = _cells_and_centre(points, faces)
    ax = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    height = (points - centre) @ ax

    def radius(z: float) -> float:
        return _furrow(points, faces, cells, ax, centre + z * ax)

    return profile_minimum(radius, height, planes)
