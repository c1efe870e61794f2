"""Tests for cortex_ti.analysis.diagnostics: volume, area, quality, principal axes, pole/furrow radii, orientation.

Reference values are closed forms (boxes, octahedra, ellipsoids, single triangles) or
measured discretisation deficits of the 2562-node icosphere, pinned tightly enough that
a wrong formula fails.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from cortex_ti.analysis import diagnostics as D
from cortex_ti.analysis.diagnostics import (
    DIAGNOSTIC_ATTRS,
    area_centroid,
    axis_crossings,
    enclosed_volume,
    frame_diagnostics,
    furrow_radius,
    furrow_radius_range,
    long_axis,
    mesh_quality,
    orientation_angle,
    pole_radius,
    principal_axes,
    surface_area,
)
from cortex_ti.surface.mesh import affine, icosphere

EZ = np.array([0.0, 0.0, 1.0])


# ---------------------------------------------------------------------------
# helpers (independent of the module under test)
# ---------------------------------------------------------------------------


def hull_mesh(points):
    """Convex hull triangles oriented outward (normal . (centroid - interior point) > 0)."""
    points = np.asarray(points, dtype=float)
    faces = ConvexHull(points).simplices.copy()
    inside = points.mean(axis=0)
    p = points[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flip = np.einsum("ij,ij->i", normal, p.mean(axis=1) - inside) < 0
    faces[flip] = faces[flip][:, ::-1]
    return points, faces


def box(a, b, c, offset=(0.0, 0.0, 0.0)):
    corners = np.array([[sx * a, sy * b, sz * c] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return hull_mesh(corners + np.asarray(offset))


def octahedron():
    return hull_mesh(np.vstack([np.eye(3), -np.eye(3)]))


def rot_y(deg):
    t = math.radians(deg)
    return np.array([[math.cos(t), 0.0, math.sin(t)], [0.0, 1.0, 0.0], [-math.sin(t), 0.0, math.cos(t)]])


@pytest.fixture(scope="module")
def sphere():
    return icosphere(2562)


@pytest.fixture(scope="module")
def ellipsoid(sphere):
    return affine(sphere, np.diag([0.8, 0.8, 1.4]))


# ---------------------------------------------------------------------------
# volume, area, centroid
# ---------------------------------------------------------------------------


def test_box_volume_area_exact():
    p, f = box(0.5, 1.0, 2.0, offset=(3.0, -1.0, 7.0))
    assert enclosed_volume(p, f) == pytest.approx(8 * 0.5 * 1.0 * 2.0, rel=1e-13)
    assert surface_area(p, f) == pytest.approx(8 * (0.5 + 2.0 + 1.0), rel=1e-13)
    np.testing.assert_allclose(area_centroid(p, f), [3.0, -1.0, 7.0], atol=1e-13)
    # inward faces give the negative volume
    assert enclosed_volume(p, f[:, ::-1]) == pytest.approx(-8.0, rel=1e-13)


def test_icosphere_volume_area_deficit(sphere):
    p, f = sphere.points, sphere.faces
    vol_deficit = 1 - enclosed_volume(p, f) / (4 / 3 * np.pi)
    area_deficit = 1 - surface_area(p, f) / (4 * np.pi)
    # measured: 2.1608e-3 and 1.1950e-3 (the inscribed polyhedron lies inside the sphere)
    assert vol_deficit == pytest.approx(2.1608e-3, abs=2e-7)
    assert area_deficit == pytest.approx(1.1950e-3, abs=2e-7)
    # translation invariance of the divergence-theorem volume
    assert enclosed_volume(p + [5.0, -3.0, 2.0], f) == pytest.approx(enclosed_volume(p, f), rel=1e-12)


# ---------------------------------------------------------------------------
# mesh quality
# ---------------------------------------------------------------------------


def test_quality_equilateral():
    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, math.sqrt(3) / 2, 0.0]])
    q = mesh_quality(p, [[0, 1, 2]])
    assert q["min_angle_deg"] == pytest.approx(60.0, abs=1e-12)
    assert q["max_edge_ratio"] == pytest.approx(1.0, abs=1e-12)
    assert q["max_aspect_ratio"] == pytest.approx(1.0, abs=1e-12)


def test_quality_skinny_right_triangle():
    t = 0.1
    p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, t, 0.0]])
    hyp = math.sqrt(1 + t * t)
    circumradius = hyp / 2  # right triangle: half the hypotenuse
    inradius = (1 + t - hyp) / 2  # right triangle: (a + b - c) / 2
    q = mesh_quality(p, [[0, 1, 2]])
    assert q["min_angle_deg"] == pytest.approx(math.degrees(math.atan(t)), abs=1e-12)  # 5.7106 deg
    assert q["max_edge_ratio"] == pytest.approx(hyp / t, rel=1e-12)  # 10.0499
    assert q["max_aspect_ratio"] == pytest.approx(circumradius / (2 * inradius), rel=1e-12)  # 5.5250


def test_quality_obtuse_and_degenerate():
    # isosceles with a 150 degree apex: base angles 15 degrees
    h = math.tan(math.radians(15.0))
    p = np.array([[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, h, 0.0], [3.0, 0.0, 0.0]])
    q = mesh_quality(p, [[0, 1, 2]])
    assert q["min_angle_deg"] == pytest.approx(15.0, abs=1e-12)
    # collinear corners: zero area -> infinite aspect ratio, zero min angle
    q = mesh_quality(p, [[0, 1, 2], [0, 1, 3]])
    assert q["max_aspect_ratio"] == np.inf
    assert q["min_angle_deg"] == pytest.approx(0.0, abs=1e-12)


def test_quality_icosphere(sphere):
    q = mesh_quality(sphere.points, sphere.faces)
    # measured on the 2562-node icosphere
    assert q["min_angle_deg"] > 50.0
    assert q["min_angle_deg"] == pytest.approx(54.0249, abs=1e-4)
    assert q["max_edge_ratio"] == pytest.approx(1.17487, abs=1e-5)
    assert q["max_aspect_ratio"] == pytest.approx(1.03154, abs=1e-5)


# ---------------------------------------------------------------------------
# principal axes, long axis, orientation
# ---------------------------------------------------------------------------


def test_second_moment_of_box_exact():
    a, b, c = 0.5, 1.0, 2.0
    p, f = box(a, b, c, offset=(1.0, 2.0, -3.0))
    w, v = principal_axes(p, f)

    def moment(a, b, c):  # int over the box surface of x^2 dA
        return 8 * a * a * b * c + 8 * a**3 * (b + c) / 3

    expected = sorted([moment(a, b, c), moment(b, a, c), moment(c, a, b)])
    np.testing.assert_allclose(w, expected, rtol=1e-13)
    np.testing.assert_allclose(np.abs(v), np.eye(3), atol=1e-12)  # x, y, z in ascending order
    np.testing.assert_allclose(long_axis(p, f), [0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(long_axis(p, f, ref=(0, 0, -1)), [0, 0, -1], atol=1e-12)


def test_sphere_is_isotropic_orientation_nan(sphere):
    w, _ = principal_axes(sphere.points, sphere.faces)
    # J = 4 pi R^4 / 3 I for the sphere; the icosphere is isotropic to round-off (icosahedral symmetry)
    assert (w[2] - w[0]) / w[2] < 1e-13
    assert w[1] / (4 * np.pi / 3) == pytest.approx(1 - 2.635e-3, abs=1e-5)
    assert math.isnan(orientation_angle(sphere.points, sphere.faces, EZ))
    # a 1e-6 stretch is well above the isotropy tolerance
    nearly = affine(sphere, np.diag([1.0, 1.0, 1.0 + 1e-6]))
    assert orientation_angle(nearly.points, nearly.faces, EZ) == pytest.approx(0.0, abs=1e-4)


def test_ellipsoid_axes(ellipsoid):
    p, f = ellipsoid.points, ellipsoid.faces
    np.testing.assert_allclose(long_axis(p, f), [0, 0, 1], atol=1e-12)
    assert orientation_angle(p, f, EZ) == pytest.approx(0.0, abs=1e-9)
    assert orientation_angle(p, f, (1, 0, 0)) == pytest.approx(90.0, abs=1e-9)
    assert orientation_angle(p, f, (0, 0, -2)) == pytest.approx(0.0, abs=1e-9)  # undirected, any length


@pytest.mark.parametrize("deg, expected", [(30.0, 30.0), (-45.0, 45.0), (120.0, 60.0), (90.0, 90.0)])
def test_rotated_ellipsoid_orientation(sphere, deg, expected):
    m = affine(sphere, rot_y(deg) @ np.diag([0.8, 0.8, 1.4]), offset=(0.3, -0.2, 0.1))
    assert orientation_angle(m.points, m.faces, EZ) == pytest.approx(expected, abs=1e-8)
    ax = long_axis(m.points, m.faces)
    assert ax @ EZ >= 0
    assert abs(ax @ (rot_y(deg) @ EZ)) == pytest.approx(1.0, abs=1e-12)


def test_sheared_sphere_long_axis(sphere):
    shear = np.array([[1.0, 0.0, 0.75], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    m = affine(sphere, shear)
    w, v = np.linalg.eigh(shear @ shear.T)  # image of the unit sphere: x^T (A A^T)^-1 x = 1
    exact = v[:, 2] * np.sign(v[2, 2])
    ax = long_axis(m.points, m.faces)
    err_deg = math.degrees(math.acos(min(1.0, abs(ax @ exact))))
    assert err_deg < 1e-3  # measured 7.4e-5 degrees (discretisation)
    exact_angle = math.degrees(math.acos(exact[2]))  # 55.2780 degrees
    assert exact_angle == pytest.approx(55.278, abs=1e-3)
    assert orientation_angle(m.points, m.faces, EZ) == pytest.approx(exact_angle, abs=1e-3)


# ---------------------------------------------------------------------------
# pole radius
# ---------------------------------------------------------------------------


def test_pole_radius_sphere_through_pole_nodes(sphere):
    p, f = sphere.points, sphere.faces
    # the edge case: the z axis runs exactly through two nodes of valence 6
    on_axis = np.flatnonzero(np.hypot(p[:, 0], p[:, 1]) == 0.0)
    assert sorted(p[on_axis, 2]) == [-1.0, 1.0]
    assert pole_radius(p, f) == pytest.approx(1.0, abs=1e-14)
    # six triangles meet at each pole node; their hits count once
    np.testing.assert_allclose(axis_crossings(p, f), [-1.0, 1.0], atol=1e-14)
    # and a generic direction through face interiors: slightly inside the unit sphere
    r = pole_radius(p, f, axis=(0.3, 0.5, 0.81))
    assert 1 - 1.5e-3 < r < 1.0


def test_pole_radius_icosahedron_through_edge_midpoint():
    m = icosphere(12)  # the z axis crosses edges (0, -1, phi) - (0, 1, phi) at their midpoints
    phi = (1 + math.sqrt(5)) / 2
    expected = phi / math.sqrt(1 + phi * phi)
    assert pole_radius(m.points, m.faces) == pytest.approx(expected, abs=1e-14)  # 0.850651
    assert len(axis_crossings(m.points, m.faces)) == 2


def test_rays_through_every_vertex_and_edge():
    # A generic convex mesh (rotated, stretched, shifted icosphere): a ray from the centroid
    # aimed exactly at a node or at an edge midpoint must find that point once. With a
    # strict barycentric test (tolerance 0) about 8% of these rays slip through the crack.
    rng = np.random.default_rng(1)
    a = np.linalg.qr(rng.normal(size=(3, 3)))[0] @ np.diag([1.0, 0.9, 1.2])
    m = affine(icosphere(642), a, offset=(0.1, 0.2, 0.3))
    c = area_centroid(m.points, m.faces)
    mids = 0.5 * (m.points[m.faces[:, 0]] + m.points[m.faces[:, 1]])
    targets = np.vstack([m.points, mids[::2]])
    for q in targets:
        s = axis_crossings(m.points, m.faces, axis=q - c)
        assert len(s) == 2 and s[0] < 0
        assert s[1] == pytest.approx(np.linalg.norm(q - c), abs=1e-12)


def test_pole_radius_octahedron_vertex_edge_face():
    p, f = octahedron()
    assert pole_radius(p, f, axis=(0, 0, 1)) == pytest.approx(1.0, abs=1e-14)  # vertex
    assert pole_radius(p, f, axis=(1, 1, 0)) == pytest.approx(1 / math.sqrt(2), abs=1e-14)  # edge midpoint
    assert pole_radius(p, f, axis=(1, 1, 1)) == pytest.approx(1 / math.sqrt(3), abs=1e-14)  # face centre
    assert len(axis_crossings(p, f, axis=(1, 1, 0))) == 2
    # moving the centre along the axis leaves the poles where they are
    assert pole_radius(p, f, center=(0, 0, 0.5)) == pytest.approx(1.0, abs=1e-14)


def test_pole_radius_ellipsoid(ellipsoid):
    p, f = ellipsoid.points, ellipsoid.faces
    assert pole_radius(p, f) == pytest.approx(1.4, abs=1e-12)
    moved = p + [2.0, -1.0, 0.5]  # centre = area centroid follows
    assert pole_radius(moved, f) == pytest.approx(1.4, abs=1e-12)


def test_pole_radius_rotated_ellipsoid(sphere):
    rot = rot_y(30.0)
    m = affine(sphere, rot @ np.diag([0.8, 0.8, 1.4]))
    ax = long_axis(m.points, m.faces)
    assert pole_radius(m.points, m.faces, axis=ax) == pytest.approx(1.4, abs=1e-12)
    # along z the ray meets the ellipsoid at 1 / sqrt(u^T D^-2 u), u = z in the body frame
    u = rot.T @ EZ
    exact = 1 / math.sqrt(u[0] ** 2 / 0.64 + u[1] ** 2 / 0.64 + u[2] ** 2 / 1.96)  # 1.137188
    r = pole_radius(m.points, m.faces)
    assert exact - 2e-4 < r < exact  # measured 1.137150 (inscribed)


def test_pole_radius_misses_raise():
    s = icosphere(162)
    two = np.vstack([s.points + [2.5, 0, 0], s.points - [2.5, 0, 0]])
    faces = np.vstack([s.faces, s.faces + s.n_nodes])
    with pytest.raises(ValueError, match="does not cross the surface on both sides"):
        pole_radius(two, faces)  # the z axis passes between the spheres
    with pytest.raises(ValueError, match="outside"):
        pole_radius(s.points, s.faces, center=(0, 0, 5))  # centre outside: hits on one side only
    with pytest.raises(ValueError, match="non-zero"):
        pole_radius(s.points, s.faces, axis=(0, 0, 0))


# ---------------------------------------------------------------------------
# furrow radius
# ---------------------------------------------------------------------------


def test_furrow_radius_octahedron_exact():
    p, f = octahedron()
    # plane z = 0 runs through four nodes and along four edges: the square |x| + |y| = 1
    exact = 0.5 + math.asinh(1.0) / (2 * math.sqrt(2))  # mean distance along the square, 0.811613
    assert furrow_radius(p, f) == pytest.approx(exact, abs=1e-14)
    lo, hi = furrow_radius_range(p, f)
    assert lo == pytest.approx(1 / math.sqrt(2), abs=1e-14)
    assert hi == pytest.approx(1.0, abs=1e-14)
    # plane z = 0.5: the same square at half size
    assert furrow_radius(p, f, center=(0, 0, 0.5)) == pytest.approx(exact / 2, abs=1e-14)
    # along x: the square in the plane x = 0
    assert furrow_radius(p, f, axis=(1, 0, 0)) == pytest.approx(exact, abs=1e-14)


def test_furrow_radius_sphere(sphere):
    p, f = sphere.points, sphere.faces
    r = furrow_radius(p, f)
    assert abs(r - 1.0) < 1e-3 and r < 1.0  # measured 0.999364 (inscribed polygon)
    lo, hi = furrow_radius_range(p, f)
    assert hi == pytest.approx(1.0, abs=1e-14)  # equatorial nodes lie in the plane
    assert 0.998 < lo < r  # measured 0.998862 (chord midpoints)


def test_furrow_radius_ellipsoid(sphere, ellipsoid):
    p, f = ellipsoid.points, ellipsoid.faces
    r = furrow_radius(p, f)
    assert 0.8 - 1e-3 < r < 0.8  # measured 0.799491
    assert r == pytest.approx(0.8 * furrow_radius(sphere.points, f), abs=1e-14)
    lo, hi = furrow_radius_range(p, f)
    assert hi == pytest.approx(0.8, abs=1e-14)


def test_furrow_radius_dumbbell(sphere):
    p = sphere.points.copy()
    p[:, :2] *= (1 - 0.5 * np.exp(-((p[:, 2] / 0.3) ** 2)))[:, None]
    f = sphere.faces
    assert pole_radius(p, f) == pytest.approx(1.0, abs=1e-14)
    r = furrow_radius(p, f)
    assert 0.4995 < r < 0.505  # measured 0.502719: the neck is 0.5
    lo, hi = furrow_radius_range(p, f)
    assert 0.495 < lo < 0.5 < hi < 0.52  # measured 0.499701, 0.508953


def test_furrow_radius_misses_raise():
    s = icosphere(162)
    two = np.vstack([s.points + [0, 0, 2.5], s.points - [0, 0, 2.5]])
    faces = np.vstack([s.faces, s.faces + s.n_nodes])
    with pytest.raises(ValueError, match="does not cut the surface"):
        furrow_radius(two, faces)
    p, f = octahedron()
    with pytest.raises(ValueError, match="only touches the surface"):
        furrow_radius(p, f, center=(0, 0, 1))  # plane touches the apex only


# ---------------------------------------------------------------------------
# one frame
# ---------------------------------------------------------------------------


def test_frame_diagnostics_sphere_speeds(sphere):
    p, f = sphere.points, sphere.faces
    n = p / np.linalg.norm(p, axis=1, keepdims=True)
    vel = 0.3 * n + 0.2 * np.cross(EZ, p)  # tangential part 0.2 * cylindrical radius
    d = frame_diagnostics(p, f, vel, 2.0 * n)  # normals are normalised internally
    assert set(d) == set(DIAGNOSTIC_ATTRS)
    assert d["max_normal_speed"] == pytest.approx(0.3, abs=1e-14)
    assert d["max_tangential_speed"] == pytest.approx(0.2, abs=1e-14)
    assert d["volume"] == pytest.approx(enclosed_volume(p, f), rel=1e-14)
    assert d["area"] == pytest.approx(surface_area(p, f), rel=1e-14)
    assert d["pole_radius"] == pytest.approx(1.0, abs=1e-14)
    assert d["furrow_radius"] == pytest.approx(furrow_radius(p, f), abs=1e-15)
    assert d["min_angle_deg"] == pytest.approx(mesh_quality(p, f)["min_angle_deg"], abs=1e-12)
    # isotropic: no orientation, radii along the pattern axis
    assert math.isnan(d["orientation_angle"])
    assert d["pole_radius_long_axis"] == d["pole_radius"]
    assert d["furrow_radius_long_axis"] == d["furrow_radius"]
    none = frame_diagnostics(p, f, None, None)
    assert math.isnan(none["max_normal_speed"]) and math.isnan(none["max_tangential_speed"])
    # without the flat measures (a run on curved cells measures them on its cells): NaN, the rest alike
    bare = frame_diagnostics(p, f, vel, 2.0 * n, measures=False)
    flat = ("volume", "area", "pole_radius", "furrow_radius", "pole_radius_long_axis", "furrow_radius_long_axis")
    assert list(bare) == list(d) and all(math.isnan(bare[k]) for k in flat)
    assert all(bare[k] == d[k] or (math.isnan(bare[k]) and math.isnan(d[k])) for k in d if k not in flat)


def test_frame_diagnostics_rotated_ellipsoid(sphere):
    m = affine(sphere, rot_y(30.0) @ np.diag([0.8, 0.8, 1.4]))
    zero = np.zeros_like(m.points)
    d = frame_diagnostics(m.points, m.faces, zero, m.points, axis=(0, 0, 1))
    assert d["orientation_angle"] == pytest.approx(30.0, abs=1e-8)
    assert d["pole_radius_long_axis"] == pytest.approx(1.4, abs=1e-12)
    assert 0.8 - 1e-3 < d["furrow_radius_long_axis"] < 0.8
    assert d["pole_radius"] == pytest.approx(pole_radius(m.points, m.faces), abs=1e-15)
    assert d["max_normal_speed"] == 0.0


def test_frame_diagnostics_undefined_radius_is_nan():
    s = icosphere(162)
    two = np.vstack([s.points + [2.5, 0, 0], s.points - [2.5, 0, 0]])
    faces = np.vstack([s.faces, s.faces + s.n_nodes])
    d = frame_diagnostics(two, faces, None, None, axis=(0, 0, 1))
    assert math.isnan(d["pole_radius"])  # the z axis misses both spheres
    assert np.isfinite(d["furrow_radius"])  # z = 0 cuts both
    assert d["orientation_angle"] == pytest.approx(90.0, abs=1e-9)  # long axis = x
    assert d["pole_radius_long_axis"] == pytest.approx(3.5, abs=1e-12)  # x axis through both, out to 2.5 + 1


def test_diagnostic_attrs():
    allowed = {"R0", "R0^2", "R0^3", "R0/t_a", "degrees", "1"}
    for key, attrs in DIAGNOSTIC_ATTRS.items():
        assert attrs["units"] in allowed, key
        assert isinstance(attrs["long_name"], str) and attrs["long_name"], key
        assert isinstance(attrs["description"], str) and len(attrs["description"]) > 20, key
    assert DIAGNOSTIC_ATTRS["volume"]["units"] == "R0^3"
    assert DIAGNOSTIC_ATTRS["area"]["units"] == "R0^2"
    assert DIAGNOSTIC_ATTRS["max_normal_speed"]["units"] == "R0/t_a"
    assert DIAGNOSTIC_ATTRS["orientation_angle"]["units"] == "degrees"
    assert D.__all__ and all(hasattr(D, name) for name in D.__all__)


def _unequal_dumbbell(nodes: int = 2562, z0: float = 0.25):
    """An icosphere mapped onto the surface of revolution of radius R(z) = sqrt(1 - (z/1.3)^2) rho(z),
    rho(z) = 1 - 0.6 exp(-((z - z0) / 0.35)^2): a neck off the centre, lobes of unequal sizes."""
    from cortex_ti.surface.mesh import icosphere

    m = icosphere(nodes)
    p = m.points
    z = 1.3 * p[:, 2]
    rho = 1.0 - 0.6 * np.exp(-(((z - z0) / 0.35) ** 2))
    out = np.column_stack([p[:, 0] * rho, p[:, 1] * rho, z])
    zz = np.linspace(-1.0, 1.0, 200001)
    profile = np.sqrt(1.0 - (zz / 1.3) ** 2) * (1.0 - 0.6 * np.exp(-(((zz - z0) / 0.35) ** 2)))
    k = int(np.argmin(np.where(np.abs(zz) < 0.8, profile, np.inf)))
    return out, m.faces, float(profile[k]), float(zz[k])


def test_neck_radius_finds_an_off_centre_neck_the_centroid_plane_misses():
    from cortex_ti.analysis.diagnostics import area_centroid, neck_radius

    pts, faces, r_true, z_true = _unequal_dumbbell()
    r, h = neck_radius(pts, faces)
    c = area_centroid(pts, faces)
    # below: the section polygon's chords sit inside the circle, 1 - cos(pi/n) ~ 1e-3 at ~70 chords;
    # above: along the axis the polyhedron interpolates the profile linearly between its nodes, off by
    # up to |R''| edge^2 / 8 at the minimum (|R''| < 10 here; the longest edge near the neck)
    near = np.abs(pts[faces][:, :, 2] - z_true).max(axis=1) < 0.2
    e = pts[faces[near]] - pts[faces[near]][:, [1, 2, 0]]
    edge = float(np.linalg.norm(e, axis=2).max())
    assert r_true * (1.0 - 3e-3) < r < r_true + 10.0 * edge**2 / 8.0
    assert abs(c[2] + h - z_true) < 0.02  # within a fraction of the ~0.05 edges there
    assert furrow_radius(pts, faces) > r_true + 0.02  # the centroid plane is off the neck


def test_neck_radius_of_a_symmetric_neck_is_in_the_centroid_plane():
    from cortex_ti.analysis.diagnostics import neck_radius

    pts, faces, r_true, _ = _unequal_dumbbell(z0=0.0)
    r, h = neck_radius(pts, faces)
    assert abs(h) < 0.02
    assert abs(r - furrow_radius(pts, faces)) < 1e-3 * r_true


def test_surface_stress_of_a_rigid_rotation_is_the_tension():
    """A rigid rotation strains nothing: the stress is the tension, whatever the viscosities."""
    from cortex_ti.analysis.diagnostics import surface_stress

    m = icosphere(642)
    zeta = 1.0 + m.points[:, 2] ** 2
    s = surface_stress(m.points, m.faces, np.cross([0.3, -1.2, 0.7], m.points), zeta, 1.0, 5.0)
    assert np.allclose(s, zeta[m.faces].mean(axis=1)[:, None], atol=1e-12)


def test_surface_stress_of_a_plane_shear_flow():
    """v = eps (x, -y, 0) on a plane: traceless strain diag(eps, -eps), sigma = zeta -/+ 2 eta_s eps;
    a compressive one (negative) once 2 eta_s eps > zeta."""
    from cortex_ti.analysis.diagnostics import surface_stress

    g = np.linspace(0.0, 1.0, 6)
    x, y = np.meshgrid(g, g)
    pts = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    k = np.arange(36).reshape(6, 6)[:-1, :-1].ravel()
    faces = np.concatenate([np.column_stack([k, k + 1, k + 7]), np.column_stack([k, k + 7, k + 6])])
    eps, zeta = 0.8, np.full(36, 1.0)
    s = surface_stress(pts, faces, eps * pts * [1.0, -1.0, 0.0], zeta, 1.0, 3.0)
    assert np.allclose(s, [1.0 - 2.0 * eps, 1.0 + 2.0 * eps], atol=1e-12)
