"""Shape diagnostics of a closed triangulated surface, evaluated once per saved frame.

Every quantity is computed on the surface as the piecewise-flat triangle mesh it is
(exact integrals over flat triangles, exact ray/plane intersections with the
triangles), never by picking nodes. Lengths are in R0 (the initial radius), times in
t_a = eta_s / zeta_0, angles in degrees. Faces must be oriented so that the
right-hand rule gives the **outward** normal (as :mod:`cortex_ti.surface.validation` guarantees).

The flat-triangle measures (volume, area, centroid, quality, second moment) live in
:mod:`cortex_ti.surface.measures`, the line and plane sections (pole, furrow, neck and fold radii)
in :mod:`cortex_ti.analysis.sections`; this module defines the diagnostics of a frame from them and
keeps their public names importable from here.

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

from ..surface.measures import (
    FlatSurface,
    area_centroid,
    dot,
    enclosed_volume,
    mesh_quality,
    second_moment,
    surface_area,
    triangle_quality,
    unit_vector,
    volume_about,
)
from .sections import (
    axis_crossings,
    fold_radii,
    furrow_on,
    furrow_radius,
    furrow_radius_range,
    neck_radius,
    pole_radius,
    pole_radius_on,
)

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

# ---------------------------------------------------------------------------
# volume, area, centroid, quality
# ---------------------------------------------------------------------------


# ---------------------------------------------------------------------------
# second moment and long axis
# ---------------------------------------------------------------------------


def _eig(surf: FlatSurface) -> tuple[np.ndarray, np.ndarray]:
    return np.linalg.eigh(second_moment(surf, surf.centroid))


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
    return _eig(FlatSurface(points, faces))


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
    ref = unit_vector(ref, "ref")
    _, v = _eig(FlatSurface(points, faces))
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
    pattern = unit_vector(pattern_axis, "pattern_axis")
    w, v = _eig(FlatSurface(points, faces))
    if _isotropic(w):
        return float("nan")
    return _angle(v[:, 2], pattern)


# ---------------------------------------------------------------------------
# one frame
# ---------------------------------------------------------------------------

_warned: set[str] = set()


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


def frame_diagnostics(
    points, faces, velocity, normals, axis=(0.0, 0.0, 1.0), measures: bool = True
) -> dict[str, float]:
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
    measures : bool
        False: the volume, area and the four radii are NaN, not measured on the flat triangles (a run
        on curved cells measures them on its cells, :mod:`cortex_ti.analysis.curved_measures`).

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
    pattern = unit_vector(axis, "axis")
    surf = FlatSurface(points, faces)
    c = surf.centroid
    quality = triangle_quality(surf)
    w, vecs = np.linalg.eigh(second_moment(surf, c))
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
        nn = np.sqrt(dot(n, n))
        n = n / np.where(nn > 0, nn, 1.0)
        vn = dot(v, n)
        vt = v - vn * n
        vn_max = float(np.abs(vn).max())
        vt_max = float(np.sqrt(dot(vt, vt)).max())

    def furrow_mean(ax):
        return furrow_on(surf, ax, c)[0]

    def measured(func, *args):
        return func(*args) if measures else float("nan")

    return {
        "volume": measured(volume_about, surf, c),
        "area": measured(lambda: float(surf.areas.sum())),
        "pole_radius": measured(_guarded, "pole_radius", pole_radius_on, surf, pattern, c),
        "furrow_radius": measured(_guarded, "furrow_radius", furrow_mean, pattern),
        "max_normal_speed": vn_max,
        "max_tangential_speed": vt_max,
        "min_angle_deg": quality["min_angle_deg"],
        "max_edge_ratio": quality["max_edge_ratio"],
        "orientation_angle": angle,
        "pole_radius_long_axis": measured(_guarded, "pole_radius_long_axis", pole_radius_on, surf, long_ax, c),
        "furrow_radius_long_axis": measured(_guarded, "furrow_radius_long_axis", furrow_mean, long_ax),
    }
