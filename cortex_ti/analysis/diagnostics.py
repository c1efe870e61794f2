"""Shape diagnostics of a closed triangulated surface, evaluated once per saved frame.

Every quantity is computed on the surface as the piecewise-flat triangle mesh it is
(exact integrals over flat triangles, exact ray/plane intersections with the
triangles), never by picking nodes. Lengths are in R0 (the initial radius), times in
t_a = eta_s / zeta_0, angles in degrees. Faces must be oriented so that the
right-hand rule gives the **outward** normal (as :mod:`cortex_ti.surface.validation` guarantees).

Definitions
-----------
area centroid ``c``
    ``c = (1/A) sum_f A_f g_f``: the centroid of the surface (not of the enclosed
    volume), ``A_f`` and ``g_f`` the area and centroid of triangle ``f``. Every
    "through the centre" quantity below uses ``c`` unless a ``center`` is given.
volume
    Enclosed volume by the divergence theorem, ``V = (1/6) sum_f x_0 . (x_1 x x_2)``
    (exact for the polyhedron; negative if the faces point inward).
area
    ``A = sum_f |(x_1 - x_0) x (x_2 - x_0)| / 2``.
second-moment tensor, long axis
    ``J = int_S (x - c)(x - c)^T dA``, integrated exactly over each flat triangle
    (``int_T x x^T dA = A_T/12 (sum_i x_i x_i^T + (sum_i x_i)(sum_i x_i)^T)``).
    The long axis is the unit eigenvector of the largest eigenvalue of ``J``.
    It is undefined when the two largest eigenvalues coincide (a sphere, an
    oblate spheroid); :func:`orientation_angle` then returns NaN (see
    :data:`ISOTROPY_TOLERANCE`).
pole radius
    Half the distance between the two points where the line ``c + s a`` (``a`` the
    unit axis) crosses the surface, ``(s_max - s_min) / 2`` with ``s_max > 0`` the farthest crossing
    in the ``+a`` direction and ``s_min < 0`` the farthest in the ``-a`` direction.
    Crossings are exact ray-triangle intersections (vectorised Moller-Trumbore with
    a tolerant barycentric test, so a line through a vertex or along an edge is
    caught; duplicate hits of neighbouring triangles are merged).
furrow radius
    The plane through ``c`` perpendicular to ``a`` cuts the mesh in a closed
    polygon (one straight segment per crossed triangle). The furrow radius is the
    mean distance of this polygon from the axis line ``c + s a``, weighted by arc
    length: ``(1/L) int_polygon dist ds``, integrated exactly along each straight
    segment. For an axisymmetric shape this is the cylindrical radius at the
    equator (the axisymmetric reference's furrow radius). Its minimum and maximum
    over the polygon (:func:`furrow_radius_range`) measure the loss of
    axisymmetry. Nodes lying exactly in the plane are treated as lying on its
    ``+a`` side (symbolic perturbation), which makes the polygon well defined
    when the plane passes through nodes and edges.

The speeds in :func:`frame_diagnostics` are nodal maxima; mesh quality is per
triangle (:func:`mesh_quality`). All functions are vectorised numpy without loops over
nodes or faces; :func:`frame_diagnostics` of a 2562-node mesh takes 1-2 ms in a warm
process (up to ~4 ms in a fresh one, where numpy's temporaries still cost page faults).
"""

from __future__ import annotations

import logging

import numpy as np

__all__ = [
    "DIAGNOSTIC_ATTRS",
    "NECK_ATTRS",
    "ISOTROPY_TOLERANCE",
    "area_centroid",
    "axis_crossings",
    "enclosed_volume",
    "surface_area",
    "mesh_quality",
    "principal_axes",
    "long_axis",
    "pole_radius",
    "furrow_radius",
    "furrow_radius_range",
    "neck_radius",
    "surface_stress",
    "orientation_angle",
    "frame_diagnostics",
    "fold_radii",
]

log = logging.getLogger(__name__)

#: The long axis counts as undefined (orientation angle NaN) when the two largest
#: eigenvalues of the second-moment tensor differ by less than this fraction of the
#: largest. An icosphere is isotropic to round-off (~1e-16); one Euler step of a
#: furrow scene (dt = 5e-4) already makes the spread ~1e-4.
ISOTROPY_TOLERANCE = 1e-9

#: Tolerance of the barycentric inside-test of a ray-triangle intersection (so that
#: a line through a vertex or along an edge is not lost to round-off).
BARYCENTRIC_TOLERANCE = 1e-9

#: Crossings along the line closer than this fraction of the bounding-box diagonal
#: are one crossing (hits of the triangles sharing a vertex or an edge).
DUPLICATE_TOLERANCE = 1e-9

_R0, _R02, _R03 = "R0", "R0^2", "R0^3"

#: Metadata of every key of :func:`frame_diagnostics` (``units``, ``long_name``, ``description``).
DIAGNOSTIC_ATTRS: dict[str, dict] = {
    "volume": {
        "units": _R03,
        "long_name": "enclosed volume",
        "description": "volume enclosed by the triangulated surface, V = (1/6) sum over triangles of "
        "x0 . (x1 x x2) (divergence theorem, outward faces; exact for the polyhedron)",
    },
    "area": {
        "units": _R02,
        "long_name": "surface area",
        "description": "sum of the areas of the flat triangles",
    },
    "pole_radius": {
        "units": _R0,
        "long_name": "pole radius along the pattern axis",
        "description": "half the distance between the two outermost points where the line through the "
        "area centroid of the surface along the pattern axis crosses the triangulated surface "
        "(exact ray-triangle intersections); NaN if the line does not cross the surface on both sides "
        "of the centroid",
    },
    "furrow_radius": {
        "units": _R0,
        "long_name": "furrow radius in the plane of the ring",
        "description": "mean distance from the pattern axis (the line through the area centroid along the "
        "pattern axis) of the polygon in which the plane through the area centroid perpendicular to that "
        "axis cuts the triangulated surface, weighted by arc length and integrated exactly along each "
        "straight segment (cylindrical radius at the equator for an axisymmetric shape); NaN if the plane "
        "misses the surface",
    },
    "max_normal_speed": {
        "units": "R0/t_a",
        "long_name": "largest normal speed",
        "description": "maximum over nodes of |v . n|, v the node velocity and n the unit outward node normal",
    },
    "max_tangential_speed": {
        "units": "R0/t_a",
        "long_name": "largest tangential speed",
        "description": "maximum over nodes of |v - (v . n) n|, v the node velocity and n the unit outward node normal",
    },
    "min_angle_deg": {
        "units": "degrees",
        "long_name": "smallest triangle angle",
        "description": "smallest interior angle of any triangle of the mesh (60 for equilateral triangles)",
    },
    "max_edge_ratio": {
        "units": "1",
        "long_name": "largest triangle edge ratio",
        "description": "maximum over triangles of (longest edge / shortest edge) (1 for equilateral triangles)",
    },
    "orientation_angle": {
        "units": "degrees",
        "long_name": "angle between long axis and pattern axis",
        "description": "angle in [0, 90] between the undirected long axis (eigenvector of the largest "
        "eigenvalue of J = integral over the surface of (x - c)(x - c)^T dA, c the area centroid, "
        "integrated exactly over the flat triangles) and the undirected pattern axis; NaN when the "
        "long axis is undefined (two largest eigenvalues of J equal to a relative 1e-9, e.g. a sphere)",
    },
    "pole_radius_long_axis": {
        "units": _R0,
        "long_name": "pole radius along the long axis",
        "description": "pole radius (see pole_radius) measured along the current long axis instead of the "
        "pattern axis; along the pattern axis when the long axis is undefined (orientation_angle NaN)",
    },
    "furrow_radius_long_axis": {
        "units": _R0,
        "long_name": "furrow radius perpendicular to the long axis",
        "description": "furrow radius (see furrow_radius) in the plane through the area centroid "
        "perpendicular to the current long axis, distances measured from the long axis; with the pattern "
        "axis when the long axis is undefined (orientation_angle NaN)",
    },
}

#: The neck radius per frame (not one of :func:`frame_diagnostics`: its plane search costs about
#: 0.1 s a frame at 2562 nodes, so a 3D run writes it only with ``time.stop_neck``, where it is
#: measured anyway; the constriction study's store computes it for the other frames).
NECK_ATTRS: dict[str, dict] = {
    "neck_radius": {
        "units": _R0,
        "long_name": "neck radius",
        "description": "the smallest interior local minimum along the pattern axis of the section radius "
        "(mean distance from the axis of the polygon a plane perpendicular to it cuts), "
        "diagnostics.neck_radius; the axisymmetric model: of r along its meridian. NaN without a neck "
        "(a convex body)",
    },
}


# ---------------------------------------------------------------------------
# input handling and shared pieces
# ---------------------------------------------------------------------------
# Vector fields over the faces are kept as tuples of three 1-D component arrays
# (x, y, z), each of length F: arithmetic on contiguous rows avoids numpy's slow
# reductions over a trailing axis of 3, and arrays of F doubles stay small enough
# to be recycled by the allocator (larger temporaries cost a page fault per page).
# A constant vector is a numpy array of shape (3,), so ``v[i]`` works for both.


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


class _Surface:
    """Triangle corners of a surface: ``x[k][i]`` (length F) is component ``i`` of corner ``k`` of every face."""

    def __init__(self, points, faces):
        pts = np.asarray(points, dtype=np.float64)
        fc = np.asarray(faces)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"points must have shape (N, 3), got {pts.shape}")
        if fc.ndim != 2 or fc.shape[1] != 3 or fc.shape[0] == 0:
            raise ValueError(f"faces must have shape (F, 3) with F > 0, got {fc.shape}")
        if not np.issubdtype(fc.dtype, np.integer):
            raise ValueError(f"faces must hold integer node indices, got dtype {fc.dtype}")
        if fc.min() < 0 or fc.max() >= pts.shape[0]:
            raise ValueError(f"faces refer to nodes outside 0..{pts.shape[0] - 1}")
        self.faces = fc
        self.cols = [np.ascontiguousarray(fc[:, k]) for k in range(3)]
        self.pts = np.ascontiguousarray(pts.T)  # (3, N)
        self.x = [tuple(row.take(col) for row in self.pts) for col in self.cols]
        self._areas = None
        self._centroid = None
        self._longest = None

    @property
    def longest_edge(self) -> float:
        """The longest edge of any triangle."""
        if self._longest is None:
            x0, x1, x2 = self.x
            self._longest = float(np.sqrt(max(_dot(e, e).max() for e in (_sub(x2, x1), _sub(x0, x2), _sub(x1, x0)))))
        return self._longest

    @property
    def areas(self) -> np.ndarray:
        if self._areas is None:
            x0, x1, x2 = self.x
            n = _cross(_sub(x1, x0), _sub(x2, x0))
            self._areas = 0.5 * np.sqrt(_dot(n, n))
        return self._areas

    @property
    def centroid(self) -> np.ndarray:
        if self._centroid is None:
            total = self.areas.sum()
            if not total > 0:
                raise ValueError("the surface has zero area")
            x0, x1, x2 = self.x
            a = self.areas
            self._centroid = np.array([(x0[i] + x1[i] + x2[i]) @ a for i in range(3)]) / (3.0 * total)
        return self._centroid

    def center(self, center) -> np.ndarray:
        if center is None:
            return self.centroid
        c = np.asarray(center, dtype=np.float64).reshape(-1)
        if c.shape != (3,) or not np.isfinite(c).all():
            raise ValueError(f"center must be a finite 3-vector, got {center!r}")
        return c

    def scale(self) -> float:
        """Diagonal of the bounding box of the nodes."""
        return float(np.sqrt(sum((row.max() - row.min()) ** 2 for row in self.pts)))


def _unit(vec, name: str) -> np.ndarray:
    a = np.asarray(vec, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be a finite 3-vector, got {vec!r}")
    norm = float(np.linalg.norm(a))
    if norm == 0.0:
        raise ValueError(f"{name} must be non-zero")
    return a / norm


# ---------------------------------------------------------------------------
# volume, area, centroid, quality
# ---------------------------------------------------------------------------


def _volume(surf: _Surface, origin: np.ndarray) -> float:
    y0, y1, y2 = (_sub(xk, origin) for xk in surf.x)
    return float(_dot(y0, _cross(y1, y2)).sum() / 6.0)


def enclosed_volume(points, faces) -> float:
    """Volume enclosed by a closed surface with outward faces.

    ``V = (1/6) sum_f x_0 . (x_1 x x_2)`` over the triangles ``(x_0, x_1, x_2)``
    (divergence theorem); exact for the polyhedron, independent of the origin
    for a closed surface (evaluated relative to the area centroid for accuracy),
    negative if the faces point inward.

    Parameters
    ----------
    points : array_like, shape (N, 3)
    faces : array_like, shape (F, 3)

    Returns
    -------
    float
        Volume in R0^3.
    """
    surf = _Surface(points, faces)
    return _volume(surf, surf.centroid)


def surface_area(points, faces) -> float:
    """Sum of the areas ``|(x_1 - x_0) x (x_2 - x_0)| / 2`` of the triangles (R0^2)."""
    return float(_Surface(points, faces).areas.sum())


def area_centroid(points, faces) -> np.ndarray:
    """Area centroid ``c = (1/A) sum_f A_f (x_0 + x_1 + x_2) / 3`` of the surface, shape (3,)."""
    return _Surface(points, faces).centroid.copy()


def _quality(surf: _Surface) -> dict:
    x0, x1, x2 = surf.x
    ea, eb, ec = _sub(x2, x1), _sub(x0, x2), _sub(x1, x0)  # edges opposite corners 0, 1, 2
    la, lb, lc = np.sqrt(_dot(ea, ea)), np.sqrt(_dot(eb, eb)), np.sqrt(_dot(ec, ec))
    n = _cross(eb, ec)
    area2 = np.sqrt(_dot(n, n))  # twice the area
    # the smallest angle of a triangle lies opposite its shortest edge; at corner k it is
    # atan2(|a x b|, a . b) with a, b the edges leaving k (accurate for tiny and obtuse angles)
    cos_term = np.where((la <= lb) & (la <= lc), -_dot(ec, eb), np.where(lb <= lc, -_dot(ea, ec), -_dot(eb, ea)))
    min_angle = float(np.degrees(np.arctan2(area2, cos_term).min()))
    lmax = np.maximum(np.maximum(la, lb), lc)
    lmin = np.minimum(np.minimum(la, lb), lc)
    surf._longest = float(lmax.max())
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(lmin > 0, lmax / lmin, np.inf)
        # circumradius R = abc / (4 A), inradius r = A / s  ->  R / (2 r) = abc s / (8 A^2) = abc s / (2 (2A)^2)
        s = 0.5 * (la + lb + lc)
        aspect = np.where(area2 > 0, la * lb * lc * s / (2.0 * area2 * area2), np.inf)
    return {
        "min_angle_deg": min_angle,
        "max_edge_ratio": float(ratio.max()),
        "max_aspect_ratio": float(aspect.max()),
    }


def mesh_quality(points, faces) -> dict:
    """Worst-triangle quality measures.

    Returns
    -------
    dict
        ``min_angle_deg``: smallest interior angle of any triangle (degrees; 60
        for equilateral triangles).
        ``max_edge_ratio``: largest ratio longest edge / shortest edge of a
        triangle (1 for equilateral; ``inf`` for a zero-length edge).
        ``max_aspect_ratio``: largest ratio circumradius / (2 inradius),
        ``R / (2 r) = a b c s / (8 A^2)`` with edge lengths ``a, b, c``,
        semi-perimeter ``s`` and area ``A`` (1 for equilateral, growing without
        bound as a triangle degenerates; ``inf`` for a zero-area triangle).
        (This is VTK's "radius ratio"; pyvista's range of good triangles is 1-1.3.)
    """
    return _quality(_Surface(points, faces))


# ---------------------------------------------------------------------------
# second moment and long axis
# ---------------------------------------------------------------------------


def _second_moment(surf: _Surface, c: np.ndarray) -> np.ndarray:
    a = surf.areas
    y0, y1, y2 = (_sub(xk, c) for xk in surf.x)
    terms = (y0, y1, y2, tuple(y0[i] + y1[i] + y2[i] for i in range(3)))
    j = np.empty((3, 3))
    for i in range(3):
        weighted = [t[i] * a for t in terms]
        for k in range(i, 3):
            j[i, k] = j[k, i] = sum(w @ t[k] for w, t in zip(weighted, terms, strict=True))
    return j / 12.0


def _eig(surf: _Surface) -> tuple[np.ndarray, np.ndarray]:
    return np.linalg.eigh(_second_moment(surf, surf.centroid))


def principal_axes(points, faces) -> tuple[np.ndarray, np.ndarray]:
    """Eigen-decomposition of the surface's second-moment tensor.

    ``J = int_S (x - c)(x - c)^T dA`` with ``c`` the area centroid, integrated
    exactly over each flat triangle ``T`` with corners ``x_i`` (relative to ``c``)
    by ``int_T x x^T dA = A_T/12 (sum_i x_i x_i^T + (sum_i x_i)(sum_i x_i)^T)``.
    A sphere of radius R has ``J = (4 pi R^4 / 3) I``.

    Returns
    -------
    eigenvalues : ndarray, shape (3,)
        Ascending, in R0^4.
    eigenvectors : ndarray, shape (3, 3)
        Unit eigenvectors as columns, ``eigenvectors[:, k]`` for ``eigenvalues[k]``
        (signs as returned by ``numpy.linalg.eigh``).
    """
    return _eig(_Surface(points, faces))


def _orient(vec: np.ndarray, ref: np.ndarray) -> np.ndarray:
    d = float(vec @ ref)
    if abs(d) <= 1e-12:
        # perpendicular to the reference: make the largest-magnitude component positive
        return vec if vec[np.argmax(np.abs(vec))] > 0 else -vec
    return vec if d > 0 else -vec


def _isotropic(w: np.ndarray) -> bool:
    return not (w[2] - w[1]) > ISOTROPY_TOLERANCE * abs(w[2])


def long_axis(points, faces, ref=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Unit eigenvector of the largest eigenvalue of ``J`` (see :func:`principal_axes`).

    The sign is fixed so that the axis has a non-negative component along
    ``ref``; if the component is zero (``|axis . ref| <= 1e-12``) the axis's
    largest-magnitude component is made positive.

    Note: when the two largest eigenvalues coincide (a sphere, an oblate
    spheroid) any vector of their eigenspace is a long axis and the one returned
    is arbitrary; :func:`orientation_angle` returns NaN in that case.
    """
    ref = _unit(ref, "ref")
    _, v = _eig(_Surface(points, faces))
    return _orient(v[:, 2].copy(), ref)


def _angle(axis: np.ndarray, pattern: np.ndarray) -> float:
    # atan2(|a x b|, |a . b|) in [0, 90]; accurate near 0 and near 90 degrees
    return float(np.degrees(np.arctan2(np.linalg.norm(np.cross(axis, pattern)), abs(float(axis @ pattern)))))


def orientation_angle(points, faces, pattern_axis) -> float:
    """Angle in degrees, in [0, 90], between the long axis and the pattern axis.

    Both axes are undirected. The long axis is the eigenvector of the largest
    eigenvalue of ``J`` (:func:`principal_axes`). Returns NaN when the long
    axis is undefined: the two largest eigenvalues agree to a relative
    :data:`ISOTROPY_TOLERANCE` (a sphere; an oblate shape whose long axes form
    a plane).
    """
    pattern = _unit(pattern_axis, "pattern_axis")
    w, v = _eig(_Surface(points, faces))
    if _isotropic(w):
        return float("nan")
    return _angle(v[:, 2], pattern)


# ---------------------------------------------------------------------------
# pole radius: line-surface crossings
# ---------------------------------------------------------------------------


def _line_hits(surf: _Surface, origin: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Parameters ``s`` of all (tolerant) intersections of ``origin + s direction`` with the triangles.

    Moller-Trumbore for a line (``s`` unrestricted), at once on the faces that can be hit. A hit
    needs barycentric coordinates ``u, v >= -tol`` and ``u + v <= 1 + tol``, so a
    line through a shared vertex or edge hits every triangle around it. Every point of a hit
    triangle lies within its longest edge (times ``1 + 2 tol``) of the hit point, on the line: the
    faces with no corner that close to the line are left out, none of them can be hit.
    """
    pts = surf.pts
    rel = (pts[0] - origin[0], pts[1] - origin[1], pts[2] - origin[2])
    along = _dot(rel, direction)
    near_sq = (surf.longest_edge * (1.0 + 4.0 * BARYCENTRIC_TOLERANCE)) ** 2
    near = (_dot(rel, rel) - along * along) <= near_sq  # node within that distance of the line
    cand = np.flatnonzero(near[surf.cols[0]] | near[surf.cols[1]] | near[surf.cols[2]])
    x0, x1, x2 = ((row[cand] for row in xk) for xk in surf.x)
    x0, x1, x2 = tuple(x0), tuple(x1), tuple(x2)
    e1 = _sub(x1, x0)
    e2 = _sub(x2, x0)
    pvec = _cross(direction, e2)
    det = _dot(e1, pvec)
    size = np.sqrt(_dot(e1, e1) * _dot(e2, e2))
    ok = np.abs(det) > 1e-12 * size  # skip triangles parallel to the line
    inv = np.divide(1.0, det, out=np.zeros_like(det), where=ok)
    tvec = (origin[0] - x0[0], origin[1] - x0[1], origin[2] - x0[2])
    u = _dot(tvec, pvec) * inv
    qvec = _cross(tvec, e1)
    v = _dot(direction, qvec) * inv
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


def _crossings(surf: _Surface, axis: np.ndarray, c: np.ndarray) -> np.ndarray:
    return _merge(_line_hits(surf, c, axis), DUPLICATE_TOLERANCE * surf.scale())


def axis_crossings(points, faces, axis=(0.0, 0.0, 1.0), center=None) -> np.ndarray:
    """Distinct crossings of the line ``center + s axis`` with the surface.

    Returns the sorted parameters ``s`` (``axis`` normalised, so ``s`` is a
    signed distance from ``center``; default centre the area centroid). Hits of
    several triangles at a shared vertex or edge (closer than
    :data:`DUPLICATE_TOLERANCE` times the bounding-box diagonal) count once.
    """
    axis = _unit(axis, "axis")
    surf = _Surface(points, faces)
    return _crossings(surf, axis, surf.center(center))


def _pole_radius(surf: _Surface, axis: np.ndarray, c: np.ndarray) -> float:
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
    axis = _unit(axis, "axis")
    surf = _Surface(points, faces)
    return _pole_radius(surf, axis, surf.center(center))


# ---------------------------------------------------------------------------
# furrow radius: plane-surface intersection
# ---------------------------------------------------------------------------


def _basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.zeros(3)
    helper[int(np.argmin(np.abs(axis)))] = 1.0
    e1 = np.array(_cross(axis, helper))
    e1 /= np.sqrt(e1 @ e1)
    return e1, np.array(_cross(axis, e1))


def _section(surf: _Surface, axis: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def _furrow(surf: _Surface, axis: np.ndarray, c: np.ndarray) -> tuple[float, float, float]:
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
    axis = _unit(axis, "axis")
    surf = _Surface(points, faces)
    return _furrow(surf, axis, surf.center(center))[0]


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
    from scipy.optimize import minimize_scalar  # only a neck search needs it

    ax = _unit(axis, "axis")
    surf = _Surface(points, faces)
    c = surf.center(center)
    height = ax @ (surf.pts - c[:, None])
    lo, hi = float(height.min()), float(height.max())
    pad = 1e-9 * max(hi - lo, 1e-300)
    zs = np.linspace(lo + pad, hi - pad, int(planes) + 2)[1:-1]

    def radius(z: float) -> float:
        try:
            return _furrow(surf, ax, c + z * ax)[0]
        except ValueError:  # the plane only touches the surface
            return float("inf")

    r = np.array([radius(z) for z in zs])
    interior = np.flatnonzero((r[1:-1] <= r[:-2]) & (r[1:-1] <= r[2:]) & np.isfinite(r[1:-1])) + 1
    if interior.size == 0:
        return float("nan"), float("nan")
    k = int(interior[np.argmin(r[interior])])
    best = minimize_scalar(radius, bounds=(zs[k - 1], zs[k + 1]), method="bounded", options={"xatol": 1e-6})
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
    axis = _unit(axis, "axis")
    surf = _Surface(points, faces)
    _, dmin, dmax = _furrow(surf, axis, surf.center(center))
    return dmin, dmax


# ---------------------------------------------------------------------------
# one frame
# ---------------------------------------------------------------------------

_warned: set[str] = set()


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
    surf = _Surface(points, faces)
    c = surf.center(center)
    return _pole_radius(surf, e2, c), _pole_radius(surf, e1, c)


def surface_stress(points, faces, velocity, zeta, eta_s: float, eta_b: float) -> np.ndarray:
    r"""The principal in-plane stresses ``(T, 2)`` (ascending) of the cortex on every flat triangle:
    the active tension plus the viscous stress of the P1 velocity,

    .. math:: \sigma = \zeta_T P + 2 \eta_s (U - \tfrac12 \operatorname{tr} U\, P) + \eta_b \operatorname{tr} U\, P,
              \qquad U = \tfrac12 (P G + G^T P), \quad G = \sum_k v_k \nabla\phi_k^T,

    ``zeta_T`` the mean of the corners' tension, ``P`` the projector on the triangle's plane (the
    strain rate the dissipation of formulation ``rayleigh_p1`` integrates). Without bending
    resistance a cortex whose stress is compressive (a negative principal value) wrinkles at any
    wavelength, the shorter the faster: on a mesh, at the mesh scale
    (docs/validation/remesh_constriction.md).

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> s = surface_stress(m.points, m.faces, 0.1 * m.points, np.ones(162), 1.0, 2.0)
    >>> bool(np.allclose(s, 1.0 + 2.0 * 0.2))  # uniform dilation: zeta + eta_b tr U, no shear
    True
    """
    x = np.asarray(points, dtype=float)[np.asarray(faces)]
    v = np.asarray(velocity, dtype=float)[np.asarray(faces)]
    e1, e2 = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    nt = np.cross(e1, e2)
    twice = np.linalg.norm(nt, axis=1)
    nt = nt / twice[:, None]
    # gradients of the barycentric functions: n x (opposite edge) / (2 A)
    grads = np.stack([np.cross(nt, x[:, (k + 2) % 3] - x[:, (k + 1) % 3]) / twice[:, None] for k in range(3)], 1)
    g = np.einsum("tkc,tkd->tcd", v, grads)  # G = sum_k v_k grad phi_k^T
    t1 = e1 / np.linalg.norm(e1, axis=1)[:, None]
    basis = np.stack([t1, np.cross(nt, t1)], 1)  # (T, 2, 3) in-plane orthonormal
    du = np.einsum("tbd,tcd->tcb", basis, g)  # d_b v = G t_b, (T, 3, 2)
    u = np.einsum("tac,tcb->tab", basis, du)  # t_a . d_b v
    u = 0.5 * (u + np.transpose(u, (0, 2, 1)))
    tr = u[:, 0, 0] + u[:, 1, 1]
    iso = np.asarray(zeta, dtype=float)[np.asarray(faces)].mean(axis=1) + (eta_b - eta_s) * tr
    mean = iso + eta_s * tr  # half the trace of sigma
    half = eta_s * np.hypot(u[:, 0, 0] - u[:, 1, 1], 2.0 * u[:, 0, 1])  # deviatoric radius
    return np.stack([mean - half, mean + half], axis=1)


def _guarded(name: str, func, *args) -> float:
    try:
        return float(func(*args))
    except ValueError as exc:
        level = logging.DEBUG if name in _warned else logging.WARNING
        _warned.add(name)
        log.log(level, "diagnostic %s set to NaN: %s", name, exc)
        return float("nan")


def frame_diagnostics(points, faces, velocity, normals, axis=(0.0, 0.0, 1.0)) -> dict[str, float]:
    """All shape diagnostics of one frame (keys and meanings in :data:`DIAGNOSTIC_ATTRS`).

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Node positions (R0).
    faces : array_like, shape (F, 3)
        Outward-oriented triangles.
    velocity : array_like, shape (N, 3) or None
        Node velocities (R0/t_a); ``None`` gives NaN speeds.
    normals : array_like, shape (N, 3) or None
        Outward node normals (normalised here); ``None`` gives NaN speeds.
    axis : array_like, shape (3,)
        The pattern axis (e.g. the axis of the furrow ring).

    Returns
    -------
    dict of str -> float
        ``volume``, ``area``, ``pole_radius``, ``furrow_radius`` (along/around
        ``axis`` through the area centroid), ``max_normal_speed``,
        ``max_tangential_speed``, ``min_angle_deg``, ``max_edge_ratio``,
        ``orientation_angle`` (long axis vs ``axis``, NaN for an isotropic
        shape), ``pole_radius_long_axis``, ``furrow_radius_long_axis`` (the
        radii along the current long axis, or along ``axis`` when the long axis
        is undefined). A radius that is undefined (the line or plane misses the
        surface) is NaN and logged, so that a frame is always written.
    """
    pattern = _unit(axis, "axis")
    surf = _Surface(points, faces)
    c = surf.centroid
    quality = _quality(surf)
    w, vecs = np.linalg.eigh(_second_moment(surf, c))
    if _isotropic(w):
        angle, long_ax = float("nan"), pattern
    else:
        long_ax = _orient(vecs[:, 2].copy(), pattern)
        angle = _angle(long_ax, pattern)

    if velocity is None or normals is None:
        vn_max = vt_max = float("nan")
    else:
        vel = np.asarray(velocity, dtype=np.float64)
        nrm = np.asarray(normals, dtype=np.float64)
        if vel.shape != nrm.shape or vel.ndim != 2 or vel.shape[1] != 3:
            raise ValueError(f"velocity {vel.shape} and normals {nrm.shape} must both have shape (N, 3)")
        v, n = np.ascontiguousarray(vel.T), np.ascontiguousarray(nrm.T)
        nn = np.sqrt(_dot(n, n))
        n = n / np.where(nn > 0, nn, 1.0)
        vn = _dot(v, n)
        vt = v - vn * n
        vn_max = float(np.abs(vn).max())
        vt_max = float(np.sqrt(_dot(vt, vt)).max())

    def furrow_mean(ax):
        return _furrow(surf, ax, c)[0]

    return {
        "volume": _volume(surf, c),
        "area": float(surf.areas.sum()),
        "pole_radius": _guarded("pole_radius", _pole_radius, surf, pattern, c),
        "furrow_radius": _guarded("furrow_radius", furrow_mean, pattern),
        "max_normal_speed": vn_max,
        "max_tangential_speed": vt_max,
        "min_angle_deg": quality["min_angle_deg"],
        "max_edge_ratio": quality["max_edge_ratio"],
        "orientation_angle": angle,
        "pole_radius_long_axis": _guarded("pole_radius_long_axis", _pole_radius, surf, long_ax, c),
        "furrow_radius_long_axis": _guarded("furrow_radius_long_axis", furrow_mean, long_ax),
    }
