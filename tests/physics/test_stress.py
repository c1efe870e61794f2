"""Tests of cortex_ti.physics.spherical and .patterns: real spherical harmonics, their surface gradient,
patterns, sphere means."""

import math

import numpy as np
import pytest
from scipy import integrate, special

from cortex_ti.errors import SceneError
from cortex_ti.physics.patterns import (
    PATTERNS,
    evaluate_active_stress,
    integrate_patterns,
    mean_over_sphere,
    register_pattern,
)
from cortex_ti.physics.spherical import (
    direction_angles,
    integrate_over_sphere,
    pattern_frame,
    real_sph_harm,
    real_sph_harm_surface_gradient,
    sphere_quadrature,
)

RNG_SEED = 12345


def random_unit(n, seed=RNG_SEED):
    rng = np.random.default_rng(seed)
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1)[:, None]


def y_at(l, m, pts):
    th, ph = direction_angles(pts)
    return real_sph_harm(l, m, th, ph)


def independent_quadrature(n_mu=40, n_phi=80):
    """Gauss-Legendre in mu = cos(theta) x trapezoid in phi: exact for the products tested here."""
    mu, w = np.polynomial.legendre.leggauss(n_mu)
    phi = np.arange(n_phi) * 2 * np.pi / n_phi
    MU, PH = np.meshgrid(mu, phi, indexing="ij")
    W = (w[:, None] * (2 * np.pi / n_phi)) * np.ones_like(PH)
    return np.arccos(MU).ravel(), PH.ravel(), W.ravel()


# ---------------------------------------------------------------------------------------------
# real_sph_harm
# ---------------------------------------------------------------------------------------------
def test_orthonormality_gram_matrix_l_le_4():
    th, ph, w = independent_quadrature()
    lm = [(l, m) for l in range(5) for m in range(-l, l + 1)]
    Y = np.array([real_sph_harm(l, m, th, ph) for l, m in lm])
    gram = (Y * w) @ Y.T
    assert len(lm) == 25
    assert np.max(np.abs(gram - np.eye(len(lm)))) < 1e-12


def test_closed_forms_against_cartesian_polynomials():
    p = random_unit(50)
    x, y, z = p.T
    c = 1 / math.sqrt(4 * math.pi)
    expected = {
        (0, 0): np.full_like(x, c),
        (1, 0): math.sqrt(3 / (4 * math.pi)) * z,
        (1, 1): math.sqrt(3 / (4 * math.pi)) * x,
        (1, -1): math.sqrt(3 / (4 * math.pi)) * y,
        (2, 0): math.sqrt(5 / (16 * math.pi)) * (3 * z**2 - 1),
        (2, 1): math.sqrt(15 / (4 * math.pi)) * x * z,
        (2, -1): math.sqrt(15 / (4 * math.pi)) * y * z,
        (2, 2): math.sqrt(15 / (16 * math.pi)) * (x**2 - y**2),
        (2, -2): math.sqrt(15 / (4 * math.pi)) * x * y,
    }
    for (l, m), val in expected.items():
        np.testing.assert_allclose(y_at(l, m, p), val, rtol=0, atol=1e-14, err_msg=f"Y_{l}{m}")


def test_relation_to_complex_condon_shortley_harmonics_up_to_l20():
    rng = np.random.default_rng(1)
    th = rng.uniform(0, np.pi, 30)
    ph = rng.uniform(0, 2 * np.pi, 30)
    for l in (2, 7, 20):
        for m in range(0, l + 1):
            yc = special.sph_harm_y(l, m, th, ph)  # complex, with the (-1)^m Condon-Shortley phase
            if m == 0:
                np.testing.assert_allclose(real_sph_harm(l, 0, th, ph), yc.real, atol=1e-13)
            else:
                np.testing.assert_allclose(real_sph_harm(l, m, th, ph), math.sqrt(2) * (-1) ** m * yc.real, atol=1e-13)
                np.testing.assert_allclose(real_sph_harm(l, -m, th, ph), math.sqrt(2) * (-1) ** m * yc.imag, atol=1e-13)
    # the example of the docstring: Re Y_2^1 = -Y_21 / sqrt(2)
    assert special.sph_harm_y(2, 1, 0.7, 0.3).real == pytest.approx(
        -real_sph_harm(2, 1, 0.7, 0.3) / math.sqrt(2), abs=1e-15
    )


def test_high_degree_is_finite_and_normalised():
    th, ph, w = independent_quadrature(n_mu=60, n_phi=120)
    for m in (0, 7, -13, 20):
        y = real_sph_harm(20, m, th, ph)
        assert np.all(np.isfinite(y))
        assert np.sum(w * y * y) == pytest.approx(1.0, abs=1e-12)


def test_eigenfunction_of_laplace_beltrami_by_finite_differences():
    rng = np.random.default_rng(2)
    th = rng.uniform(0.3, np.pi - 0.3, 20)
    ph = rng.uniform(0, 2 * np.pi, 20)
    h = 1e-4
    for l in range(0, 6):
        for m in range(-l, l + 1):
            Y = lambda t, p, l=l, m=m: real_sph_harm(l, m, t, p)  # noqa: E731
            y0 = Y(th, ph)
            d_t = (Y(th + h, ph) - Y(th - h, ph)) / (2 * h)
            d_tt = (Y(th + h, ph) - 2 * y0 + Y(th - h, ph)) / h**2
            d_pp = (Y(th, ph + h) - 2 * y0 + Y(th, ph - h)) / h**2
            lap = d_tt + d_t / np.tan(th) + d_pp / np.sin(th) ** 2
            assert np.max(np.abs(lap + l * (l + 1) * y0)) < 1e-6, (l, m)


def test_invalid_degree_and_order_rejected():
    with pytest.raises(ValueError):
        real_sph_harm(2, 3, 0.1, 0.1)
    with pytest.raises(ValueError):
        real_sph_harm(-1, 0, 0.1, 0.1)
    with pytest.raises(ValueError):
        real_sph_harm(2.5, 0, 0.1, 0.1)


# ---------------------------------------------------------------------------------------------
# direction angles
# ---------------------------------------------------------------------------------------------
def test_direction_angles_z_axis_and_accuracy_near_pole():
    p = np.array([[1.0, 0, 0], [0, 1.0, 0], [-1.0, 0, 0], [0, -2.0, 0], [0, 0, 3.0], [0, 0, -1.0], [1e-9, 0, 1.0]])
    th, ph = direction_angles(p)
    np.testing.assert_allclose(th, [np.pi / 2] * 4 + [0, np.pi, 1e-9], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ph[:4], [0, np.pi / 2, np.pi, 3 * np.pi / 2], atol=1e-15)
    assert np.all((ph >= 0) & (ph < 2 * np.pi))
    # center shifts the origin
    th2, ph2 = direction_angles(p + [1.0, 2.0, 3.0], center=(1.0, 2.0, 3.0))
    np.testing.assert_allclose(th2, th, atol=1e-14)


def test_pattern_frame_is_minimal_rotation():
    b = 0.6
    # axis tilted by b about +y: the frame is the z frame rotated by b about +y
    e1, e2, a = pattern_frame((math.sin(b), 0, math.cos(b)))
    np.testing.assert_allclose(e1, [math.cos(b), 0, -math.sin(b)], atol=1e-15)
    np.testing.assert_allclose(e2, [0, 1, 0], atol=1e-15)
    e1, e2, a = pattern_frame((2.0, 0, 0))
    np.testing.assert_allclose(np.c_[e1, e2, a], np.c_[[0, 0, -1], [0, 1, 0], [1, 0, 0]], atol=1e-15)
    e1, e2, a = pattern_frame((0, 0, -1))
    np.testing.assert_allclose(np.c_[e1, e2, a], np.c_[[1, 0, 0], [0, -1, 0], [0, 0, -1]], atol=1e-15)
    # angles about a tilted axis = angles about z of the back-rotated points
    p = random_unit(40, seed=3)
    rot = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])  # R_y(b)
    th_a, ph_a = direction_angles(p @ rot.T, axis=(math.sin(b), 0, math.cos(b)))
    th_z, ph_z = direction_angles(p)
    np.testing.assert_allclose(th_a, th_z, atol=1e-13)
    np.testing.assert_allclose(np.cos(ph_a - ph_z), 1.0, atol=1e-12)
    with pytest.raises(ValueError):
        pattern_frame((0, 0, 0))


# ---------------------------------------------------------------------------------------------
# surface gradient
# ---------------------------------------------------------------------------------------------
def _tangent_dirs(p, seed):
    rng = np.random.default_rng(seed)
    t = rng.normal(size=p.shape)
    t -= np.sum(t * p, axis=1)[:, None] * p
    return t / np.linalg.norm(t, axis=1)[:, None]


def test_surface_gradient_tangent_and_matches_finite_differences():
    p = random_unit(40, seed=4)
    p = np.vstack([p, [[1e-7, 0, 1.0]], [[0, 3e-8, -1.0]]])
    p /= np.linalg.norm(p, axis=1)[:, None]
    t = _tangent_dirs(p, seed=5)
    h = 1e-5
    for l in range(0, 7):
        for m in range(-l, l + 1):
            g = real_sph_harm_surface_gradient(l, m, p)
            assert np.max(np.abs(np.sum(g * p, axis=1))) < 1e-13
            # derivative along the great circle p cos s + t sin s (unit speed) at s = 0
            fd = (y_at(l, m, p * math.cos(h) + t * math.sin(h)) - y_at(l, m, p * math.cos(h) - t * math.sin(h))) / (
                2 * h
            )
            assert np.max(np.abs(np.sum(g * t, axis=1) - fd)) < 1e-7, (l, m)


def test_surface_gradient_high_degree_matches_finite_differences():
    p = random_unit(30, seed=9)
    t = _tangent_dirs(p, seed=10)
    h = 1e-5
    for l, m in [(20, 0), (20, 7), (20, -20), (40, 13)]:
        g = real_sph_harm_surface_gradient(l, m, p)
        assert np.all(np.isfinite(g)) and np.max(np.abs(g)) > 1.0
        fd = (y_at(l, m, p * math.cos(h) + t * math.sin(h)) - y_at(l, m, p * math.cos(h) - t * math.sin(h))) / (2 * h)
        assert np.max(np.abs(np.sum(g * t, axis=1) - fd)) < 1e-6, (l, m)


def test_surface_gradient_at_exact_poles():
    poles = np.array([[0, 0, 1.0], [0, 0, -1.0]])
    c1 = math.sqrt(3 / (4 * math.pi))
    c21 = math.sqrt(15 / (4 * math.pi))
    np.testing.assert_allclose(real_sph_harm_surface_gradient(1, 1, poles), [[c1, 0, 0], [c1, 0, 0]], atol=1e-15)
    np.testing.assert_allclose(real_sph_harm_surface_gradient(1, -1, poles), [[0, c1, 0], [0, c1, 0]], atol=1e-15)
    np.testing.assert_allclose(real_sph_harm_surface_gradient(1, 0, poles), 0.0, atol=1e-15)
    # Y_21 = c x z: gradient +c e_x at the north pole, -c e_x at the south pole
    np.testing.assert_allclose(real_sph_harm_surface_gradient(2, 1, poles), [[c21, 0, 0], [-c21, 0, 0]], atol=1e-14)
    np.testing.assert_allclose(real_sph_harm_surface_gradient(2, -1, poles), [[0, c21, 0], [0, -c21, 0]], atol=1e-14)
    for l in range(0, 9):
        for m in range(-l, l + 1):
            g = real_sph_harm_surface_gradient(l, m, poles)
            assert np.all(np.isfinite(g))
            if abs(m) != 1:
                assert np.max(np.abs(g)) < 1e-13, (l, m)
            # finite differences along x and y at the poles
            for t in (np.array([1.0, 0, 0]), np.array([0, 1.0, 0])):
                h = 1e-5
                T = np.tile(t, (2, 1))
                fd = (
                    y_at(l, m, poles * math.cos(h) + T * math.sin(h))
                    - y_at(l, m, poles * math.cos(h) - T * math.sin(h))
                ) / (2 * h)
                assert np.max(np.abs(g @ t - fd)) < 1e-7, (l, m)


def test_surface_gradient_scales_as_one_over_radius():
    p = random_unit(20, seed=6)
    center = np.array([0.3, -1.0, 2.0])
    for l, m in [(2, 0), (3, -2), (5, 4)]:
        g1 = real_sph_harm_surface_gradient(l, m, p)
        g2 = real_sph_harm_surface_gradient(l, m, 2.0 * p)
        g3 = real_sph_harm_surface_gradient(l, m, center + 2.0 * p, center=center)
        np.testing.assert_allclose(g2, g1 / 2, atol=1e-14)
        np.testing.assert_allclose(g3, g1 / 2, atol=1e-14)


def test_dirichlet_energy_equals_eigenvalue():
    # int |grad_s Y|^2 dA = l(l+1) int Y^2 dA / R^2  =>  mean over the sphere = l(l+1) / (4 pi R^2)
    R = 2.0
    pts, w = sphere_quadrature(24)
    for l, m in [(1, 0), (2, 1), (3, -3), (4, 2), (6, -5), (12, 7)]:
        g = real_sph_harm_surface_gradient(l, m, R * pts)
        mean = np.sum(w * np.sum(g * g, axis=1)) / (4 * np.pi)
        assert mean == pytest.approx(l * (l + 1) / (4 * np.pi * R**2), rel=1e-12)


# ---------------------------------------------------------------------------------------------
# patterns
# ---------------------------------------------------------------------------------------------
RING8 = {"type": "ring", "zeta0": 1.0, "amplitude": 1.0, "sigma": 10.0, "p": 8}
RING4 = {"type": "ring", "zeta0": 1.0, "amplitude": 1.0, "sigma": 10.0, "p": 4}


def test_ring_values_at_equator_and_poles():
    pat = {"type": "ring", "zeta0": 1.5, "amplitude": 2.0, "sigma": 1.5, "p": 4}
    eq = np.array([[1.0, 0, 0], [0, -3.0, 0], [math.sqrt(0.5), math.sqrt(0.5), 0]])
    poles = np.array([[0, 0, 1.0], [0, 0, -2.0]])
    np.testing.assert_allclose(evaluate_active_stress(eq, [pat]), 3.5, rtol=1e-15)
    np.testing.assert_allclose(
        evaluate_active_stress(poles, [pat]), 1.5 + 2.0 * math.exp(-1.5 * (math.pi / 2) ** 4), rtol=1e-14
    )
    # a point at theta = pi/2 - 0.4
    q = np.array([[math.cos(0.4), 0, math.sin(0.4)]])
    assert evaluate_active_stress(q, [pat])[0] == pytest.approx(1.5 + 2.0 * math.exp(-1.5 * 0.4**4), rel=1e-14)


def test_ring_axis_rotation_is_coordinate_permutation():
    p = random_unit(60, seed=7) * 1.3
    ring_x = dict(RING4, axis=[1, 0, 0])
    # theta from +x of p equals theta from +z of (p_y, p_z, p_x)
    np.testing.assert_allclose(
        evaluate_active_stress(p, [ring_x]), evaluate_active_stress(p[:, [1, 2, 0]], [RING4]), atol=1e-14
    )
    ring_y = dict(RING4, axis=[0, 2.0, 0])
    np.testing.assert_allclose(
        evaluate_active_stress(p, [ring_y]), evaluate_active_stress(p[:, [2, 0, 1]], [RING4]), atol=1e-14
    )


def test_harmonics_pattern_and_sum_of_patterns():
    p = random_unit(30, seed=8)
    x, y, z = p.T
    harm = {
        "type": "harmonics",
        "terms": [{"l": 0, "m": 0, "coeff": math.sqrt(4 * math.pi)}, {"l": 2, "m": 1, "coeff": 2.0}],
    }
    expected = 1.0 + 2.0 * math.sqrt(15 / (4 * math.pi)) * x * z
    np.testing.assert_allclose(evaluate_active_stress(p, [harm]), expected, atol=1e-14)
    ring = evaluate_active_stress(p, [RING8])
    np.testing.assert_allclose(evaluate_active_stress(p, [harm, RING8]), expected + ring, atol=1e-14)
    np.testing.assert_array_equal(evaluate_active_stress(p, []), np.zeros(30))


def test_scene_errors():
    p = random_unit(5)
    with pytest.raises(SceneError, match="harmonics.*ring|ring.*harmonics"):
        evaluate_active_stress(p, [{"type": "blob"}])
    with pytest.raises(SceneError, match="sigma"):
        evaluate_active_stress(p, [{"type": "ring", "zeta0": 1, "amplitude": 1, "p": 4}])
    with pytest.raises(SceneError, match="width"):
        evaluate_active_stress(p, [dict(RING4, width=3)])
    with pytest.raises(SceneError):
        evaluate_active_stress(p, [{"zeta0": 1}])
    with pytest.raises(SceneError, match="m"):
        evaluate_active_stress(p, [{"type": "harmonics", "terms": [{"l": 1, "m": 2, "coeff": 1}]}])
    with pytest.raises(SceneError, match="axis"):
        evaluate_active_stress(p, [dict(RING4, axis=[0, 0, 0])])
    with pytest.raises(SceneError, match="p"):
        evaluate_active_stress(p, [dict(RING4, p=0)])


def test_register_pattern_adds_a_type():
    name = "_test_constant"
    try:

        @register_pattern(name)
        def constant(points, value):
            return np.full(len(points), float(value))

        assert PATTERNS[name] is constant
        p = random_unit(4)
        np.testing.assert_allclose(
            evaluate_active_stress(p, [{"type": name, "value": 2.5}, RING8]), 2.5 + evaluate_active_stress(p, [RING8])
        )
        assert mean_over_sphere([{"type": name, "value": 2.5}]) == pytest.approx(2.5, abs=1e-14)
        with pytest.raises(ValueError):
            register_pattern(name)(lambda points: points[:, 0])
    finally:
        PATTERNS.pop(name, None)


# ---------------------------------------------------------------------------------------------
# sphere means
# ---------------------------------------------------------------------------------------------
def _ring_mean_quad(p, sigma=10.0):
    f = lambda t: (1.0 + math.exp(-sigma * abs(t - math.pi / 2) ** p)) * math.sin(t)  # noqa: E731
    a, _ = integrate.quad(f, 0, math.pi / 2, epsabs=1e-14, epsrel=1e-13, limit=200)
    b, _ = integrate.quad(f, math.pi / 2, math.pi, epsabs=1e-14, epsrel=1e-13, limit=200)
    return 0.5 * (a + b)


def test_mean_of_rings():
    m8 = mean_over_sphere([RING8])
    m4 = mean_over_sphere([RING4])
    assert round(m8, 5) == 1.64548
    assert round(m4, 5) == 1.48299
    assert m8 == pytest.approx(_ring_mean_quad(8), abs=1e-12)
    assert m4 == pytest.approx(_ring_mean_quad(4), abs=1e-12)
    # converged: a fixed, much higher order agrees to 1e-12
    assert mean_over_sphere([RING8], order=256) == pytest.approx(m8, abs=1e-12)
    # the mean does not depend on the axis
    assert mean_over_sphere([dict(RING8, axis=[1.0, -2.0, 0.5])]) == pytest.approx(m8, abs=1e-12)
    # odd exponent (kink at the equator) converges too
    assert mean_over_sphere([dict(RING8, p=3)]) == pytest.approx(_ring_mean_quad(3), abs=1e-12)


def test_mean_of_harmonics_and_sum():
    harm = {
        "type": "harmonics",
        "terms": [
            {"l": 0, "m": 0, "coeff": 0.7},
            {"l": 2, "m": 0, "coeff": 3.0},
            {"l": 3, "m": -2, "coeff": -1.0},
            {"l": 1, "m": 1, "coeff": 5.0},
        ],
    }
    assert mean_over_sphere([harm]) == pytest.approx(0.7 / math.sqrt(4 * math.pi), abs=1e-14)
    assert mean_over_sphere([harm, RING4]) == pytest.approx(
        0.7 / math.sqrt(4 * math.pi) + mean_over_sphere([RING4]), abs=1e-13
    )


def test_sphere_quadrature_weights_and_exactness():
    pts, w = sphere_quadrature(8, axis=(1.0, 1.0, 0.0))
    assert w.sum() == pytest.approx(4 * np.pi, rel=1e-14)
    np.testing.assert_allclose(np.linalg.norm(pts, axis=1), 1.0, atol=1e-15)
    # int x^2 y^2 z^2 dOmega = 4 pi / 105
    assert integrate_over_sphere(lambda q: (q[:, 0] * q[:, 1] * q[:, 2]) ** 2) == pytest.approx(
        4 * np.pi / 105, rel=1e-13
    )


# ---------------------------------------------------------------------------------------------
# user-supplied patterns: 'field' (per node, from a file) and 'python' (a user's function)
# ---------------------------------------------------------------------------------------------
RING_PARAMS = {"zeta0": 1.0, "amplitude": 1.0, "sigma": 10.0, "p": 8}


def ring_closed_form(points, zeta0=1.0, amplitude=1.0, sigma=10.0, p=8):
    """Paper Eq. 59 about +z written out here (not through cortex_ti.physics.patterns)."""
    x, y, z = np.asarray(points, dtype=float).T
    theta = np.arctan2(np.hypot(x, y), z)
    return zeta0 + amplitude * np.exp(-sigma * np.abs(theta - np.pi / 2) ** p)


@pytest.fixture(scope="module")
def ico162():
    from cortex_ti.surface.mesh import icosphere

    return icosphere(162)


def write_field(path, values, name="zeta", extra=None):
    """Write ``values`` (one per node of the 162-node icosphere) in the format of the suffix."""
    import meshio

    from cortex_ti.surface.mesh import icosphere

    values = np.asarray(values, dtype=float)
    if path.suffix == ".npy":
        np.save(path, values)
    elif path.suffix in (".txt", ".csv"):
        np.savetxt(path, values, fmt="%.17g")
    else:
        m = icosphere(len(values)) if len(values) in (42, 162, 642) else icosphere(162)
        data = {name: values, **(extra or {})}
        meshio.write(str(path), meshio.Mesh(m.points, [("triangle", m.faces)], point_data=data))
    return path


@pytest.mark.parametrize("suffix", [".npy", ".txt", ".csv", ".vtu"])
def test_field_file_equals_the_ring_pattern(tmp_path, ico162, suffix):
    """The closed form of Eq. 59 written to a file, read back per node, is the built-in ring."""
    file = write_field(tmp_path / f"ring{suffix}", ring_closed_form(ico162.points))
    ring = evaluate_active_stress(ico162.points, [{"type": "ring", **RING_PARAMS}])
    zeta = evaluate_active_stress(ico162.points, [{"type": "field", "file": str(file)}])
    assert zeta.shape == (162,)
    np.testing.assert_allclose(zeta, ring, rtol=0, atol=1e-14)
    # scale multiplies; a field adds to other patterns like any pattern
    both = evaluate_active_stress(
        ico162.points, [{"type": "field", "file": str(file), "scale": -2.0}, {"type": "ring", **RING_PARAMS}]
    )
    np.testing.assert_allclose(both, -ring, rtol=0, atol=3e-14)


def test_field_values_are_per_node_not_per_position(tmp_path, ico162):
    """The values go to the nodes in order, whatever the positions (the pattern is evaluated on the
    initial shape; a deformed copy of the mesh gets the same values)."""
    values = np.arange(162, dtype=float) / 7.0
    file = write_field(tmp_path / "idx.npy", values)
    np.testing.assert_array_equal(evaluate_active_stress(ico162.points, [{"type": "field", "file": str(file)}]), values)
    np.testing.assert_array_equal(
        evaluate_active_stress(3.0 * ico162.points[::-1], [{"type": "field", "file": str(file)}]), values
    )


def test_field_mesh_file_point_data_by_name(tmp_path, ico162):
    ring = ring_closed_form(ico162.points)
    file = write_field(tmp_path / "two.vtu", ring, name="zeta", extra={"other": np.ones(162)})
    pat = {"type": "field", "file": str(file), "name": "zeta"}
    np.testing.assert_allclose(evaluate_active_stress(ico162.points, [pat]), ring, rtol=0, atol=1e-15)
    with pytest.raises(SceneError, match=r"2 point-data arrays \('zeta', 'other'\).*'name'"):
        evaluate_active_stress(ico162.points, [{"type": "field", "file": str(file)}])
    with pytest.raises(SceneError, match=r"no point-data array 'zetaa'; it has: 'zeta', 'other'"):
        evaluate_active_stress(ico162.points, [dict(pat, name="zetaa")])


def test_field_relative_path_is_relative_to_the_working_directory(tmp_path, ico162, monkeypatch):
    """From the Python API (no scene file) a relative path is taken from the working directory."""
    write_field(tmp_path / "ring.npy", ring_closed_form(ico162.points))
    monkeypatch.chdir(tmp_path)
    zeta = evaluate_active_stress(ico162.points, [{"type": "field", "file": "ring.npy"}])
    np.testing.assert_allclose(zeta, ring_closed_form(ico162.points), rtol=0, atol=0)


def test_field_errors_name_the_file_and_the_problem(tmp_path, ico162):
    pts = ico162.points

    def error(file, **kw):
        with pytest.raises(SceneError) as info:
            evaluate_active_stress(pts, [{"type": "field", "file": str(file), **kw}])
        return str(info.value)

    short = write_field(tmp_path / "short.npy", np.ones(161))
    assert (
        error(short)
        == f"field file '{short}' has 161 values but the mesh has 162 nodes (one value per node, in mesh order)"
    )
    long_txt = write_field(tmp_path / "long.txt", np.ones(163))
    assert f"field file '{long_txt}' has 163 values but the mesh has 162 nodes" in error(long_txt)
    coarse = write_field(tmp_path / "coarse.vtu", np.ones(42))
    assert f"field file '{coarse}' has 42 values but the mesh has 162 nodes" in error(coarse)
    for bad, word in ((np.nan, "NaN"), (np.inf, "inf")):
        v = np.ones(162)
        v[17] = bad
        f = write_field(tmp_path / f"bad_{word}.npy", v)
        assert error(f) == f"field file '{f}' has 1 non-finite value(s) (NaN or inf), the first at node 17"
    v = np.ones(162)
    v[[5, 9]] = np.nan
    f = write_field(tmp_path / "nan.txt", v)
    assert error(f) == f"field file '{f}' has 2 non-finite value(s) (NaN or inf), the first at node 5"
    missing = tmp_path / "missing.npy"
    assert error(missing) == f"field file '{missing}' does not exist"
    assert error(tmp_path) == f"field file '{tmp_path}' is a folder, not a file"
    two_d = tmp_path / "two_d.npy"
    np.save(two_d, np.ones((162, 2)))
    assert "shape (162, 2); need a 1-D array" in error(two_d)
    two_cols = tmp_path / "two_cols.csv"
    two_cols.write_text("1,2\n3,4\n")
    assert error(two_cols) == f"field file '{two_cols}' has 2 numbers per line; need one number per line"
    words = tmp_path / "words.txt"
    words.write_text("one\ntwo\n")
    assert f"cannot read field file '{words}' as one number per line" in error(words)
    empty = tmp_path / "empty.txt"
    empty.write_text("")
    assert error(empty) == f"field file '{empty}' holds no values"
    assert "'name' ('zeta') selects a point-data array of a mesh file" in error(short, name="zeta")
    garbage = tmp_path / "garbage.vtu"
    garbage.write_text("not a mesh")
    assert f"cannot read mesh file '{garbage}'" in error(garbage)
    ok = write_field(tmp_path / "ok.npy", np.ones(162))
    with pytest.raises(SceneError, match="field scale must be finite"):
        evaluate_active_stress(pts, [{"type": "field", "file": str(ok), "scale": np.nan}])
    with pytest.raises(SceneError, match="missing parameter.*file"):
        evaluate_active_stress(pts, [{"type": "field"}])


def test_sphere_quadrature_refuses_a_field_but_not_a_python_pattern(tmp_path, ico162, user_module):
    """A field exists only at the nodes: the analytic sphere solution (which integrates the pattern
    by quadrature) must say so; a python pattern is a function of position and integrates."""
    from cortex_ti.truth.analytic import sphere_full_solution

    file = write_field(tmp_path / "ring.npy", ring_closed_form(ico162.points))
    field = {"type": "field", "file": str(file)}
    expected = (
        "active_stress[0]: the analytic sphere solution needs a pattern defined off the mesh; 'field' is per node"
    )
    for call in (
        lambda: mean_over_sphere([field]),
        lambda: integrate_patterns([field], weight=lambda q: q),
        lambda: sphere_full_solution(ico162.points, [field]),
    ):
        with pytest.raises(SceneError) as info:
            call()
        assert str(info.value).startswith(expected)
    python = {"type": "python", "function": f"{user_module}:ring", "params": RING_PARAMS}
    assert mean_over_sphere([python]) == pytest.approx(mean_over_sphere([RING8]), abs=1e-12)
    v_py, p_py = sphere_full_solution(ico162.points, [python])
    v_ring, p_ring = sphere_full_solution(ico162.points, [RING8])
    np.testing.assert_allclose(v_py, v_ring, rtol=0, atol=1e-13)
    assert p_py == pytest.approx(p_ring, abs=1e-12)


USER_MODULE = """
import numpy as np

CALLS = []


def ring(points, zeta0, amplitude, sigma, p=8):
    x, y, z = points.T
    theta = np.arctan2(np.hypot(x, y), z)
    return zeta0 + amplitude * np.exp(-sigma * np.abs(theta - np.pi / 2) ** p)


def height(points):
    return points[:, 2].copy()


def wrong_shape(points):
    return np.ones((len(points), 2))


def scalar(points):
    return 1.0


def nonfinite(points):
    out = np.zeros(len(points))
    out[3] = np.inf
    return out


def text(points):
    return ["a"] * len(points)


def mutates(points):
    points[:] = 0.0
    return np.ones(len(points))


def boom(points):
    raise RuntimeError("boom from the user's code")


class Patterns:
    @staticmethod
    def double(points, factor=2.0):
        return factor * points[:, 0]


NOT_CALLABLE = 3
"""


@pytest.fixture
def user_module(tmp_path, monkeypatch):
    """A module of pattern functions in tmp_path, importable for this test only."""
    import sys

    name = "cortex_user_patterns_for_tests"
    folder = tmp_path / "user_code"
    folder.mkdir()
    (folder / f"{name}.py").write_text(USER_MODULE)
    (folder / "broken_user_module.py").write_text("import numpy as np\ndef broken(:\n")
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.delitem(sys.modules, name, raising=False)
    yield name
    sys.modules.pop(name, None)
    sys.modules.pop("broken_user_module", None)


def test_python_pattern_reproduces_the_ring(ico162, user_module):
    pat = {"type": "python", "function": f"{user_module}:ring", "params": RING_PARAMS}
    zeta = evaluate_active_stress(ico162.points, [pat])
    np.testing.assert_allclose(zeta, evaluate_active_stress(ico162.points, [RING8]), rtol=0, atol=1e-14)
    # default params of the function apply; params may be left out for a function without any
    pat2 = {
        "type": "python",
        "function": f"{user_module}:ring",
        "params": {"zeta0": 0.5, "amplitude": 2.0, "sigma": 1.5},
    }
    np.testing.assert_allclose(
        evaluate_active_stress(ico162.points, [pat2]),
        ring_closed_form(ico162.points, 0.5, 2.0, 1.5, 8),
        rtol=0,
        atol=1e-14,
    )
    np.testing.assert_array_equal(
        evaluate_active_stress(ico162.points, [{"type": "python", "function": f"{user_module}:height"}]),
        ico162.points[:, 2],
    )
    # a dotted attribute: module:Class.method
    np.testing.assert_array_equal(
        evaluate_active_stress(
            ico162.points, [{"type": "python", "function": f"{user_module}:Patterns.double", "params": {"factor": 3.0}}]
        ),
        3.0 * ico162.points[:, 0],
    )


def test_python_pattern_accepts_a_callable_from_python(ico162):
    zeta = evaluate_active_stress(
        ico162.points, [{"type": "python", "function": lambda q, k: k * q[:, 1], "params": {"k": -2.0}}]
    )
    np.testing.assert_array_equal(zeta, -2.0 * ico162.points[:, 1])
    zeta = evaluate_active_stress(ico162.points, [{"type": "python", "function": ring_closed_form}])
    np.testing.assert_allclose(zeta, evaluate_active_stress(ico162.points, [RING8]), rtol=0, atol=1e-14)


def test_python_pattern_cannot_change_the_points(ico162, user_module):
    pts = ico162.points.copy()
    zeta = evaluate_active_stress(pts, [{"type": "python", "function": f"{user_module}:mutates"}])
    np.testing.assert_array_equal(zeta, np.ones(162))
    np.testing.assert_array_equal(pts, ico162.points)


def test_python_pattern_errors_name_the_target(ico162, user_module):
    pts = ico162.points

    def error(function, **kw):
        with pytest.raises(SceneError) as info:
            evaluate_active_stress(pts, [{"type": "python", "function": function, **kw}])
        return str(info.value)

    msg = error("no_such_module_xyz:f")
    assert msg.startswith("python pattern function 'no_such_module_xyz:f': cannot import module 'no_such_module_xyz'")
    assert "ModuleNotFoundError" in msg
    msg = error("broken_user_module:f")
    assert (
        "python pattern function 'broken_user_module:f': cannot import module 'broken_user_module' (SyntaxError" in msg
    )
    assert error(f"{user_module}:nope") == (
        f"python pattern function '{user_module}:nope': module '{user_module}' has no attribute 'nope'"
    )
    assert error(f"{user_module}:NOT_CALLABLE") == (
        f"python pattern function '{user_module}:NOT_CALLABLE' is a int, not a callable"
    )
    assert "must look like 'package.module:function'" in error("no_colon_here")
    assert "must look like 'package.module:function'" in error(f"{user_module}:")
    assert "must be 'package.module:function' or a callable, got 3" in error(3)
    assert error(f"{user_module}:wrong_shape") == (
        f"python pattern '{user_module}:wrong_shape' returned an array of shape (162, 2); need (162,), "
        f"one value per point"
    )
    assert error(f"{user_module}:scalar") == (
        f"python pattern '{user_module}:scalar' returned an array of shape (); need (162,), one value per point"
    )
    assert error(f"{user_module}:nonfinite") == (
        f"python pattern '{user_module}:nonfinite' returned 1 non-finite value(s) (NaN or inf), the first at point 3"
    )
    assert error(f"{user_module}:text") == f"python pattern '{user_module}:text' returned list, not an array of numbers"
    msg = error(f"{user_module}:ring", params={"zeta0": 1.0, "amplitude": 1.0, "sigma": 1.0, "width": 2})
    assert msg.startswith(
        f"python pattern '{user_module}:ring' cannot be called as {user_module}:ring(points, "
        "zeta0=..., amplitude=..., sigma=..., width=...)"
    )
    assert "width" in msg.split(":")[-1]
    assert "missing a required argument: 'sigma'" in error(f"{user_module}:ring", params={"zeta0": 1, "amplitude": 1})
    assert "params must be a mapping" in error(f"{user_module}:height", params=[1, 2])
    # an exception inside the user's function: one error naming the pattern, file and line, the
    # user's exception chained to it (issue 34; the command line shows its traceback with --debug)
    with pytest.raises(SceneError, match="boom from the user's code") as info:
        evaluate_active_stress(pts, [{"type": "python", "function": f"{user_module}:boom"}])
    assert str(info.value).startswith(f"python pattern '{user_module}:boom' raised RuntimeError: ")
    assert ".py:" in str(info.value) and isinstance(info.value.__cause__, RuntimeError)
