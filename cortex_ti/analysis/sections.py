"""Lines and planes through a triangulated surface (the definitions are in
:mod:`cortex_ti.analysis.diagnostics`): the crossings of a line with the surface (exact
ray-triangle intersections) and the pole radius, the polygon a plane cuts from it and the furrow
radius, its range and the neck radius, and the fold radii across and beside a fold stripe.
"""

from __future__ import annotations

import numpy as np

from ..surface.measures import FlatSurface, cross, dot, sub, unit_vector

__all__ = [
    "BARYCENTRIC_TOLERANCE",
    "DUPLICATE_TOLERANCE",
    "axis_crossings",
    "pole_radius",
    "furrow_radius",
    "furrow_radius_range",
    "neck_radius",
    "fold_radii",
    "pole_radius_on",
    "furrow_on",
]

#: Tolerance of the barycentric inside-test of a ray-triangle intersection (so that
#: a line through a vertex or along an edge is not lost to round-off).
BARYCENTRIC_TOLERANCE = 1e-9

#: Crossings along the line closer than this fraction of the bounding-box diagonal
#: are one crossing (hits of the triangles sharing a vertex or an edge).
DUPLICATE_TOLERANCE = 1e-9


# ---------------------------------------------------------------------------
# pole radius: line-surface crossings
# ---------------------------------------------------------------------------


def _line_hits(surf: FlatSurface, origin: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Parameters ``s`` of all (tolerant) intersections of ``origin + s direction`` with the triangles.

    Moller-Trumbore for a line (``s`` unrestricted), at once on the faces that can be hit. A hit
    needs barycentric coordinates ``u, v >= -tol`` and ``u + v <= 1 + tol``, so a
    line through a shared vertex or edge hits every triangle around it. Every point of a hit
    triangle lies within its longest edge (times ``1 + 2 tol``) of the hit point, on the line: the
    faces with no corner that close to the line are left out, none of them can be hit.
    """
    pts = surf.pts
    rel = (pts[0] - origin[0], pts[1] - origin[1], pts[2] - origin[2])
    along = dot(rel, direction)
    near_sq = (surf.longest_edge * (1.0 + 4.0 * BARYCENTRIC_TOLERANCE)) ** 2
    near = (dot(rel, rel) - along * along) <= near_sq  # node within that distance of the line
    cand = np.flatnonzero(near[surf.cols[0]] | near[surf.cols[1]] | near[surf.cols[2]])
    x0, x1, x2 = ((row[cand] for row in xk) for xk in surf.x)
    x0, x1, x2 = tuple(x0), tuple(x1), tuple(x2)
    e1 = sub(x1, x0)
    e2 = sub(x2, x0)
    pvec = cross(direction, e2)
    det = dot(e1, pvec)
    size = np.sqrt(dot(e1, e1) * dot(e2, e2))
    ok = np.abs(det) > 1e-12 * size  # skip triangles parallel to the line
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    tvec = (origin[0] - x0[0], origin[1] - x0[1], origin[2] - x0[2])
    u = dot(tvec, pvec) * inv
    qvec = cross(tvec, e1)
    v = dot(direction, qvec) * inv
    tol = BARYCENTRIC_TOLERANCE
    hit = np.flatnonzero(ok & (u >= -tol) & (v >= -tol) & (u + v <= 1.0 + tol))
    return (e2[0][hit] * qvec[0][hit] + e2[1][hit] * qvec[1][hit] + e2[2][hit] * qvec[2][hit]) * inv[hit]


def _merge(s: np.ndarray, tol: float) -> np.ndarray:
    """Sorted distinct values of ``s``; values within ``tol`` of their neighbour form one (their mean)."""
    if s.size == 0:
        return s
    s = np.sort(s)
    idx = np.cumsum(np.r_[True, np.diff(s) > tol]) - 1
    return np.bincount(idx, weights=s) / np.bincount(idx)


def _crossings(surf: FlatSurface, axis: np.ndarray, c: np.ndarray) -> np.ndarray:
    return _merge(_line_hits(surf, c, axis), DUPLICATE_TOLERANCE * surf.scale())


def axis_crossings(points, faces, axis=(0.0, 0.0, 1.0), center=None) -> np.ndarray:
    """Distinct crossings of the line ``center + s axis`` with the surface.

    Returns the sorted parameters ``s`` (``axis`` normalised, so ``s`` is a
    signed distance from ``center``; default centre the area centroid). Hits of
    several triangles at a shared vertex or edge (closer than
    :data:`DUPLICATE_TOLERANCE` times the bounding-box diagonal) count once.
    """
    axis = unit_vector(axis, "axis")
    surf = FlatSurface(points, faces)
    return _crossings(surf, axis, surf.center(center))


def pole_radius_on(surf: FlatSurface, axis: np.ndarray, c: np.ndarray) -> float:
    """:func:`pole_radius` of a :class:`~cortex_ti.surface.measures.FlatSurface` along a unit ``axis`` through ``c``."""
    s = _crossings(surf, axis, c)
    n_pos, n_neg = int((s > 0).sum()), int((s < 0).sum())
    if n_pos == 0 or n_neg == 0:
        raise ValueError(
            f"the line through {np.round(c, 6).tolist()} along {np.round(axis, 6).tolist()} does not cross "
            f"the surface on both sides ({n_pos} crossing(s) ahead, {n_neg} behind): the centre lies "
            "outside the surface or on it, or the shape has pinched off; the pole radius is undefined"
        )
    return 0.5 * float(s[-1] - s[0])


def pole_radius(points, faces, axis=(0.0, 0.0, 1.0), center=None) -> float:
    """Half the pole-to-pole distance along ``axis`` through ``center``.

    The line ``center + s a`` (``a = axis / |axis|``, default ``center`` the area
    centroid) is intersected exactly with every triangle (vectorised
    Moller-Trumbore with a barycentric tolerance of
    :data:`BARYCENTRIC_TOLERANCE`, so a line through a vertex or an edge is
    caught; hits of neighbouring triangles are merged). The poles are the
    outermost crossings on either side, and the pole radius is
    ``(s_max - s_min) / 2``. For a convex shape there is exactly one crossing
    on each side.

    Raises
    ------
    ValueError
        If the line does not cross the surface on both sides of ``center``
        (centre outside the surface, or a pinched-off shape).
    """
    axis = unit_vector(axis, "axis")
    surf = FlatSurface(points, faces)
    return pole_radius_on(surf, axis, surf.center(center))


# ---------------------------------------------------------------------------
# furrow radius: plane-surface intersection
# ---------------------------------------------------------------------------


def _basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(axis)))] = 1.0
    e1 = np.array(cross(axis, helper))
    e1 /= np.sqrt(e1 @ e1)
    return e1, np.array(cross(axis, e1))


def _section(surf: FlatSurface, axis: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Segments of the plane section, in plane coordinates centred on the axis: P, Q of shape (K, 2)."""
    rel = surf.pts - c[:, None]  # (3, N)
    height = axis[0] * rel[0] + axis[1] * rel[1] + axis[2] * rel[2]  # signed height of each node
    # a node exactly in the plane counts as above it (symbolic perturbation)
    up0, up1, up2 = (height.take(col) >= 0.0 for col in surf.cols)
    mixed = np.flatnonzero((up0 | up1 | up2) & ~(up0 & up1 & up2))
    if mixed.size == 0:
        raise ValueError(
            f"the plane through {np.round(c, 6).tolist()} perpendicular to {np.round(axis, 6).tolist()} "
            "does not cut the surface: the shape has pinched off there or lies on one side of it; the "
            "furrow radius is undefined"
        )
    fc = surf.faces[mixed]
    d = height[fc]  # identical for a node in all its faces
    up = d >= 0.0
    nxt = [1, 2, 0]
    crossed = up != up[:, nxt]  # edge k: corner k -> corner k+1
    y = rel.T[fc]  # (M, 3 corners, 3)
    dn = d[:, nxt]
    t = np.where(crossed, d / np.where(crossed, d - dn, 1.0), 0.0)
    pts = y + t[:, :, None] * (y[:, nxt] - y)  # crossing point on each edge
    seg = pts[crossed].reshape(-1, 2, 3)  # exactly two crossed edges per mixed face
    e1, e2 = _basis(axis)
    plane = np.stack([seg @ e1, seg @ e2], axis=-1)  # (M, 2 ends, 2)
    return plane[:, 0], plane[:, 1]


def _segment_stats(p: np.ndarray, q: np.ndarray) -> tuple[float, float, float]:
    """Length-weighted mean, min and max of |x| along the 2-D segments p -> q."""
    dv = q - p
    length = np.hypot(dv[:, 0], dv[:, 1])
    keep = length > 0
    p, dv, length = p[keep], dv[keep], length[keep]
    if length.size == 0:
        raise ValueError(
            "the plane only touches the surface (its section has zero length); the furrow radius is undefined"
        )
    u = dv / length[:, None]
    x0 = p[:, 0] * u[:, 0] + p[:, 1] * u[:, 1]  # along-line coordinate of p (foot of the axis at 0)
    h = np.abs(p[:, 0] * u[:, 1] - p[:, 1] * u[:, 0])  # distance of the segment's line from the axis
    x1 = x0 + length
    pos = h > 0
    hs = np.where(pos, h, 1.0)

    def primitive(x):
        # int sqrt(x^2 + h^2) dx = (x sqrt(x^2 + h^2) + h^2 asinh(x / h)) / 2   (h = 0: x |x| / 2)
        return 0.5 * (x * np.sqrt(x * x + h * h) + np.where(pos, h * h * np.arcsinh(x / hs), 0.0))

    integral = primitive(x1) - primitive(x0)
    mean = float(integral.sum() / length.sum())
    tfoot = np.clip(-x0, 0.0, length)
    foot = p + tfoot[:, None] * u
    dmin = float(np.hypot(foot[:, 0], foot[:, 1]).min())
    dmax = float(max(np.hypot(p[:, 0], p[:, 1]).max(), np.hypot(p[:, 0] + dv[:, 0], p[:, 1] + dv[:, 1]).max()))
    return mean, dmin, dmax


def furrow_on(surf: FlatSurface, axis: np.ndarray, c: np.ndarray) -> tuple[float, float, float]:
    """``(mean, min, max)`` distance from the axis of the section through ``c`` perpendicular to
    ``axis`` (:func:`furrow_radius`)."""
    return _segment_stats(*_section(surf, axis, c))


def furrow_radius(points, faces, axis=(0.0, 0.0, 1.0), center=None) -> float:
    """Radius of the cortex in the plane through ``center`` perpendicular to ``axis``.

    The plane is intersected exactly with the triangles: each triangle it crosses
    contributes one straight segment between the crossing points on two of its
    edges (a node exactly in the plane counts as lying on its ``+axis`` side, so
    the section stays a closed polygon when the plane runs through nodes or along
    edges, and an edge lying in the plane is counted once). The result is the
    mean distance of the polygon from the axis line ``center + s axis``, weighted
    by arc length, ``(1/L) int dist ds``, with the integral of
    ``sqrt(x^2 + h^2)`` along each segment in closed form. Default ``center``:
    the area centroid. For an axisymmetric shape this is the cylindrical radius
    at the equator; for a polygon inscribed in a circle of radius R it is
    slightly below R (chords). If the plane cuts the surface in several closed
    curves, all count.

    Raises
    ------
    ValueError
        If the plane does not cut the surface (a pinched-off furrow).
    """
    axis = unit_vector(axis, "axis")
    surf = FlatSurface(points, faces)
    return furrow_on(surf, axis, surf.center(center))[0]


def neck_radius(points, faces, axis=(0.0, 0.0, 1.0), center=None, planes: int = 64) -> tuple[float, float]:
    """The neck: the smallest interior local minimum, over the planes perpendicular to ``axis``, of
    the section radius of :func:`furrow_radius` (mean distance from the axis line through ``center``,
    default the area centroid). Returns ``(radius, height)``, the height along ``axis`` from
    ``center``; ``(nan, nan)`` when the profile has no interior minimum (a convex body).

    :func:`furrow_radius` measures in the plane through the area centroid, which is the neck only
    while the two sides of a furrow keep equal sizes: once one lobe grows at the other's expense the
    centroid moves off the neck and that radius grows while the neck keeps closing (amplitude 12 of
    ``constriction_p4``, docs/validation/remesh_constriction.md). The profile is sampled on
    ``planes`` planes between the extreme nodes, and the smallest interior local minimum refined by a
    bounded scalar minimisation between its two neighbouring planes (the profile is continuous).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(642)
    >>> bool(np.isnan(neck_radius(m.points, m.faces)[0]))  # a sphere has no neck
    True
    """
    ax = unit_vector(axis, "axis")
    surf = FlatSurface(points, faces)
    c = surf.center(center)
    height = ax @ (surf.pts - c[:, None])

    def radius(z: float) -> float:
        return furrow_on(surf, ax, c + z * ax)[0]

    return profile_minimum(radius, height, planes)


def profile_minimum(radius, height: np.ndarray, planes: int) -> tuple[float, float]:
    """The smallest interior local minimum of a section profile ``radius(z)``: sampled on ``planes``
    planes between the extreme ``height`` of the nodes, refined by a bounded scalar minimisation
    between the neighbouring planes. A plane that only touches the surface (``radius`` raises
    ValueError) counts as infinite. ``(radius, z)``, or ``(nan, nan)`` without an interior minimum."""
    from scipy.optimize import minimize_scalar  # only a neck search needs it

    lo, hi = float(np.min(height)), float(np.max(height))
    pad = 1e-9 * max(hi - lo, 1e-300)
    zs = np.linspace(lo + pad, hi - pad, int(planes) + 2)[1:-1]

    def safe(z: float) -> float:
        try:
            return radius(z)
        except ValueError:  # the plane only touches the surface
            return float("inf")

    r = np.array([safe(z) for z in zs])
    interior = np.flatnonzero((r[1:-1] <= r[:-2]) & (r[1:-1] <= r[2:]) & np.isfinite(r[1:-1])) + 1
    if interior.size == 0:
        return float("nan"), float("nan")
    k = int(interior[np.argmin(r[interior])])
    best = minimize_scalar(safe, bounds=(zs[k - 1], zs[k + 1]), method="bounded", options={"xatol": 1e-6})
    if best.fun <= r[k]:
        return float(best.fun), float(best.x)
    return float(r[k]), float(zs[k])


def furrow_radius_range(points, faces, axis=(0.0, 0.0, 1.0), center=None) -> tuple[float, float]:
    """Smallest and largest distance from the axis line along the section polygon of :func:`furrow_radius`.

    Exact for the polygon (the minimum may lie inside a segment). Equal for a
    perfectly axisymmetric section; their spread measures the loss of
    axisymmetry (and, for a mesh, the discretisation: chords of a circle of
    radius R reach in to ``R cos(pi / n)``).

    Raises
    ------
    ValueError
        If the plane does not cut the surface.
    """
    axis = unit_vector(axis, "axis")
    surf = FlatSurface(points, faces)
    _, dmin, dmax = furrow_on(surf, axis, surf.center(center))
    return dmin, dmax


def fold_radii(points, faces, axis=(0.0, 0.0, 1.0), center=None) -> tuple[float, float]:
    """Equatorial radii across and beside the fold stripe of the ``fold`` pattern.

    The stripe runs along the great circle through the pattern's poles at azimuth
    ``phi = pi/2, 3 pi/2`` (frame of :func:`cortex_ti.physics.spherical.pattern_frame`: direction
    ``e2``). Returns ``(r_stripe, r_off)``: half the width of the surface along ``e2`` and
    along ``e1`` through ``center`` (exact line-surface crossings, as :func:`pole_radius`).
    The fold depth is ``r_off - r_stripe``.
    """
    from ..physics.spherical import pattern_frame

    e1, e2, _ = pattern_frame(axis)
    surf = FlatSurface(points, faces)
    c = surf.center(center)
    return pole_radius_on(surf, e2, c), pole_radius_on(surf, e1, c)

