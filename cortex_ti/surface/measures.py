"""Measures of a surface as the piecewise-flat triangle mesh it is: face areas, the enclosed
volume, the surface area, the area centroid, the worst-triangle quality and the second-moment
tensor, each an exact integral over the flat triangles. The one home of these measures: the
shape diagnostics (:mod:`cortex_ti.analysis.diagnostics`), the validation of a user's mesh
(:mod:`cortex_ti.surface.validation`) and the remeshing use them.

Definitions
-----------
``x_0, x_1, x_2`` are the corners of a triangle, ordered so that the right-hand rule gives the
outward normal.

area
    ``A = sum_f |(x_1 - x_0) x (x_2 - x_0)| / 2``.
volume
    ``V = (1/6) sum_f (x_0 - o) . ((x_1 - o) x (x_2 - o))`` (divergence theorem): exact for the
    polyhedron, independent of the origin ``o`` for a closed surface (an origin near the surface's
    centre keeps the round-off small), negative if the faces point inward.
area centroid
    ``c = (1/A) sum_f A_f (x_0 + x_1 + x_2) / 3``.
second moment
    ``J = int_S (x - c)(x - c)^T dA``, exact on each flat triangle:
    ``int_T x x^T dA = A_T/12 (sum_i x_i x_i^T + (sum_i x_i)(sum_i x_i)^T)``.

Imports numpy only.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "FlatSurface",
    "enclosed_volume",
    "face_areas",
    "surface_area",
    "area_centroid",
    "volume_centroid",
    "mesh_quality",
    "min_angles",
    "second_moment",
    "volume_about",
    "triangle_quality",
    "unit_vector",
]

# Vector fields over the faces are kept as tuples of three 1-D component arrays
# (x, y, z), each of length F: arithmetic on contiguous rows avoids numpy's slow
# reductions over a trailing axis of 3, and arrays of F doubles stay small enough
# to be recycled by the allocator (larger temporaries cost a page fault per page).
# A constant vector is a numpy array of shape (3,), so ``v[i]`` works for both.


def dot(a, b):
    """``a . b`` of component tuples (or (3,) arrays)."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    """``a x b`` of component tuples (or (3,) arrays), as a tuple."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def sub(a, b):
    """``a - b`` of component tuples (or (3,) arrays), as a tuple."""
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


class FlatSurface:
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
            self._longest = float(np.sqrt(max(dot(e, e).max() for e in (sub(x2, x1), sub(x0, x2), sub(x1, x0)))))
        return self._longest

    @property
    def areas(self) -> np.ndarray:
        if self._areas is None:
            x0, x1, x2 = self.x
            n = cross(sub(x1, x0), sub(x2, x0))
            self._areas = 0.5 * np.sqrt(dot(n, n))
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


def unit_vector(vec, name: str) -> np.ndarray:
    """``vec`` as a unit (3,) array; ``ValueError`` naming ``name`` if it is not a finite non-zero 3-vector."""
    a = np.asarray(vec, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.isfinite(a).all():
        raise ValueError(f"{name} must be a finite 3-vector, got {vec!r}")
    norm = float(np.linalg.norm(a))
    if norm == 0.0:
        raise ValueError(f"{name} must be non-zero")
    return a / norm


def volume_about(surf: FlatSurface, origin: np.ndarray) -> float:
    """The enclosed volume with the corners taken relative to ``origin`` (:func:`enclosed_volume`)."""
    y0, y1, y2 = (sub(xk, origin) for xk in surf.x)
    return float(dot(y0, cross(y1, y2)).sum() / 6.0)


def enclosed_volume(points, faces, origin=None) -> float:
    """Volume enclosed by a closed surface with outward faces.

    ``V = (1/6) sum_f x_0 . (x_1 x x_2)`` over the triangles ``(x_0, x_1, x_2)``
    (divergence theorem); exact for the polyhedron, independent of the origin
    for a closed surface (evaluated relative to the area centroid for accuracy,
    or to ``origin`` when given), negative if the faces point inward.

    Parameters
    ----------
    points : array_like, shape (N, 3)
    faces : array_like, shape (F, 3)
    origin : array_like, shape (3,), optional
        The point the corners are taken relative to (default: the area centroid).

    Returns
    -------
    float
        Volume in R0^3.
    """
    surf = FlatSurface(points, faces)
    return volume_about(surf, surf.centroid if origin is None else np.asarray(origin, dtype=np.float64))


def face_areas(points, faces) -> np.ndarray:
    """The areas ``|(x_1 - x_0) x (x_2 - x_0)| / 2`` of the triangles, shape (F,) (R0^2)."""
    return FlatSurface(points, faces).areas.copy()


def surface_area(points, faces) -> float:
    """Sum of the areas ``|(x_1 - x_0) x (x_2 - x_0)| / 2`` of the triangles (R0^2)."""
    return float(FlatSurface(points, faces).areas.sum())


def area_centroid(points, faces) -> np.ndarray:
    """Area centroid ``c = (1/A) sum_f A_f (x_0 + x_1 + x_2) / 3`` of the surface, shape (3,)."""
    return FlatSurface(points, faces).centroid.copy()


def volume_centroid(points, faces) -> np.ndarray:
    """Centroid of the volume a closed surface with outward faces encloses, shape (3,): the tetrahedra
    (c, x_0, x_1, x_2) from the area centroid c, their signed volumes times their centroids
    (c + x_0 + x_1 + x_2) / 4, over their sum (exact for the polyhedron)."""
    s = FlatSurface(points, faces)
    c = s.centroid
    x0, x1, x2 = (sub(x, c) for x in s.x)
    v = dot(x0, cross(x1, x2)) / 6.0
    total = v.sum()
    if not total != 0.0:
        raise ValueError("the surface encloses no volume")
    return c + np.array([(v @ (x0[i] + x1[i] + x2[i])) / (4.0 * total) for i in range(3)])


def _smallest_angles(x0, x1, x2):
    """Per triangle: its smallest angle (degrees), the edges opposite corners 0, 1, 2, their lengths
    and twice the area. The smallest angle lies opposite the shortest edge; at corner k it is
    ``atan2(|a x b|, a . b)`` with a, b the edges leaving k (accurate for tiny and obtuse angles)."""
    ea, eb, ec = sub(x2, x1), sub(x0, x2), sub(x1, x0)  # edges opposite corners 0, 1, 2
    la, lb, lc = np.sqrt(dot(ea, ea)), np.sqrt(dot(eb, eb)), np.sqrt(dot(ec, ec))
    n = cross(eb, ec)
    area2 = np.sqrt(dot(n, n))  # twice the area
    cos_term = np.where((la <= lb) & (la <= lc), -dot(ec, eb), np.where(lb <= lc, -dot(ea, ec), -dot(eb, ea)))
    return np.degrees(np.arctan2(area2, cos_term)), (la, lb, lc), area2


def min_angles(points, faces) -> np.ndarray:
    """The smallest interior angle (degrees) of every triangle, ``(T,)``.

    >>> from cortex_ti.surface.mesh import icosphere
    >>> m = icosphere(162)
    >>> bool(50.0 < min_angles(m.points, m.faces).min() < 60.0)
    True
    """
    return _smallest_angles(*FlatSurface(points, faces).x)[0]


def triangle_quality(surf: FlatSurface) -> dict:
    """:func:`mesh_quality` of a :class:`FlatSurface` (also caches its longest edge)."""
    angles, (la, lb, lc), area2 = _smallest_angles(*surf.x)
    min_angle = float(angles.min())
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
    return triangle_quality(FlatSurface(points, faces))


def second_moment(surf: FlatSurface, c: np.ndarray) -> np.ndarray:
    """``J = int_S (x - c)(x - c)^T dA`` (3, 3), exact on each flat triangle (module docstring)."""
    a = surf.areas
    y0, y1, y2 = (sub(xk, c) for xk in surf.x)
    terms = (y0, y1, y2, tuple(y0[i] + y1[i] + y2[i] for i in range(3)))
    j = np.empty((3, 3))
    for i in range(3):
        weighted = [t[i] * a for t in terms]
        for k in range(i, 3):
            j[i, k] = j[k, i] = sum(w @ t[k] for w, t in zip(weighted, terms, strict=True))
    return j / 12.0
