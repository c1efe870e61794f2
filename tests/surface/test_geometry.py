"""Discrete geometry (cortex_ti.surface.geometry) against exact polynomials, closed-form curvatures
and convergence orders.

Truths used here, none taken from the code under test:

* a least-squares fit whose basis contains every monomial of degree <= d reproduces every
  polynomial of degree <= d exactly, whatever the stencil (a property of least squares);
* a linear field f = c.x has the fitted derivatives c.e_a and c.X_ab = (c.n) h_ab exactly;
* a sphere of radius R: C_ab = g_ab / R in any coordinates, C = 2/R, K = 1/R^2, normal = radial,
  and the Monge height over the plane (x_i, e_xi, e_eta) has closed-form derivatives;
* an ellipsoid F = x^2/a^2 + y^2/b^2 + z^2/c^2 - 1 = 0: C and K from grad F and the Hessian;
* Meyer's mixed areas tile the surface; the triangulated volume is linear in each node and
  homogeneous of degree 3 (sum_i x_i . dV/dx_i = 3 V).

Measured numbers quoted in comments are from this code at the time of writing (bounds ~1.5x).
"""

from __future__ import annotations

import numpy as np
import pytest

from cortex_ti.errors import MeshError
from cortex_ti.surface.fits import FIT_SCHEMES, StencilChooser
from cortex_ti.surface.geometry import compute_geometry
from cortex_ti.surface.mesh import affine
from cortex_ti.surface.topology import build_topology
from cortex_ti.surface.validation import validate_mesh

pytestmark = pytest.mark.usefixtures("taichi_runtime")

SCHEMES = ("quadratic", "quartic")
#: (a, b) exponents of the five fitted derivatives A..E and their Taylor factors a! b!
DERIVS = [(1, 0), (0, 1), (2, 0), (0, 2), (1, 1)]
TAYLOR = np.array([1.0, 1.0, 2.0, 2.0, 1.0])


# ---------------------------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------------------------
def local_coords(g):
    """Stencil coordinates (xi, eta) in each node's frame, and the stencil mask."""
    mask = g.stencil >= 0
    d = g.points[np.where(mask, g.stencil, 0)] - g.points[:, None, :]
    xi = np.einsum("nsc,nc->ns", d, g.frame[:, 0])
    eta = np.einsum("nsc,nc->ns", d, g.frame[:, 1])
    return xi, eta, mask


def polynomial_fit_errors(g, degree: int, seed: int = 0) -> np.ndarray:
    """Per node: a random polynomial P of ``degree`` in the node's local coordinates, sampled at
    the stencil (f_i = P(0, 0)), pushed through the fit operator F[i, k, j]; relative error of
    A..E against P's exact derivatives."""
    xi, eta, mask = local_coords(g)
    mono = [(a, d - a) for d in range(degree + 1) for a in range(d, -1, -1)]
    coef = np.random.default_rng(seed).normal(size=(g.n_nodes, len(mono)))
    f = sum(coef[:, t, None] * xi**a * eta**b for t, (a, b) in enumerate(mono))
    f0 = coef[:, mono.index((0, 0))]
    df = np.where(mask, f - f0[:, None], 0.0)
    fitted = np.einsum("nks,ns->nk", g.fit, df)
    exact = np.stack([coef[:, mono.index(ab)] for ab in DERIVS], axis=1) * TAYLOR
    return np.abs(fitted - exact).max(axis=1) / np.abs(exact).max(axis=1)


def signed_volume(points, faces) -> float:
    p = points[faces]
    return float(np.einsum("fc,fc->f", p[:, 0], np.cross(p[:, 1], p[:, 2])).sum() / 6.0)


def face_areas(points, faces) -> np.ndarray:
    p = points[faces]
    return 0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1)


def face_angles(points, faces) -> np.ndarray:
    p = points[faces]
    out = []
    for k in range(3):
        u = p[:, (k + 1) % 3] - p[:, k]
        v = p[:, (k + 2) % 3] - p[:, k]
        cos = np.einsum("fc,fc->f", u, v) / np.linalg.norm(u, axis=1) / np.linalg.norm(v, axis=1)
        out.append(np.degrees(np.arccos(cos)))
    return np.stack(out, axis=1)


def angle_to(vectors, directions) -> np.ndarray:
    """Angle (rad) between unit vectors and the directions of ``directions``."""
    d = directions / np.linalg.norm(directions, axis=1, keepdims=True)
    return np.arccos(np.clip(np.einsum("nc,nc->n", vectors, d), -1.0, 1.0))


def subdivided_sphere(points, faces, levels: int):
    """Midpoint subdivision projected on the unit sphere (keeps the valence of the base nodes)."""
    pts = [np.asarray(p, float) / np.linalg.norm(p) for p in points]
    faces = [tuple(f) for f in faces]
    for _ in range(levels):
        mid, new = {}, []

        def m(a, b, mid=mid):
            key = (min(a, b), max(a, b))
            if key not in mid:
                q = pts[a] + pts[b]
                pts.append(q / np.linalg.norm(q))
                mid[key] = len(pts) - 1
            return mid[key]

        for a, b, c in faces:
            ab, bc, ca = m(a, b), m(b, c), m(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return validate_mesh(np.array(pts), np.array(faces))


OCTAHEDRON = (
    [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]],
    [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)],
)
TETRAHEDRON = ([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], [(0, 1, 2), (0, 3, 1), (0, 2, 3), (1, 3, 2)])


# ---------------------------------------------------------------------------------------------
# the fit operator
# ---------------------------------------------------------------------------------------------
def test_perturbed_mesh_is_irregular(lab):
    """The test mesh really is irregular: obtuse triangles, spread angles, no flipped faces."""
    mesh = lab.perturbed(642)
    ang = face_angles(mesh.points, mesh.faces)
    assert (ang > 90.0).any(axis=1).sum() >= 30  # measured 61 obtuse faces
    assert ang.max() > 105.0 and ang.min() < 30.0  # measured 108.1 and 27.1 degrees
    p = mesh.points[mesh.faces]
    outward = np.einsum("fc,fc->f", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p.sum(1))
    assert (outward > 0).all()


@pytest.mark.parametrize("scheme", SCHEMES)
def test_fit_reproduces_its_polynomials_exactly(lab, scheme):
    """Every polynomial of the scheme's degree (2: quadratic, 4: quartic) is reproduced to
    rounding on the irregular mesh, at every node (measured max 3e-14 and 1.2e-13)."""
    g = lab.geometry(lab.perturbed(642), scheme)
    order = FIT_SCHEMES[scheme].order
    err = polynomial_fit_errors(g, order, seed=1)
    assert err.max() < 1e-10
    # ... and it is a least-squares fit, not an interpolation: one degree more is not exact
    # (measured max relative error 0.64 for quadratic on cubics, 0.048 for quartic on quintics)
    assert polynomial_fit_errors(g, order + 1, seed=2).max() > 1e-3


@pytest.mark.parametrize("scheme", SCHEMES)
def test_patch_without_operators_is_the_operators_patch(lab, scheme):
    """Consistency check of two routes: the patch solved for directly from the heights
    (``operators=False``, what the curved cells read) is the fit operator applied to them, to
    rounding (measured 5e-14 relative, quartic), on the irregular mesh; without operators the
    geometry refuses :meth:`fit_scalar` in one line."""
    from cortex_ti.surface.fits import StencilChooser
    from cortex_ti.surface.geometry import compute_geometry

    mesh = lab.perturbed(642)
    g = lab.geometry(mesh, scheme)
    topo = lab.topology(mesh)
    d = compute_geometry(mesh.points, topo, StencilChooser(topo, scheme), operators=False)
    for key in ("normal_fit", "tangents", "metric_inv", "curvature", "christoffel", "height_fit", "height_poly"):
        a, b = getattr(g, key), getattr(d, key)
        assert np.abs(a - b).max() <= 1e-11 * max(1.0, np.abs(a).max()), key
    assert d.fit is None
    with pytest.raises(ValueError, match="without its fit operators"):
        d.fit_scalar(mesh.points[:, 0])
    # positions of another mesh on this connectivity: refused in one line, not read past the arrays
    with pytest.raises(MeshError, match="node positions for a mesh of 642 nodes"):
        compute_geometry(mesh.points[:600], topo, StencilChooser(topo, scheme), operators=False)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_linear_field_gives_tangents_and_heights(lab, scheme):
    """f = c.x: A = c.e_1, B = c.e_2 (fitted tangents) and (C, D, E) = (c.n) h_ab, exactly."""
    g = lab.geometry(lab.perturbed(642), scheme)
    c = np.array([0.3, -1.1, 0.7])
    fitted = g.fit_scalar(g.points @ c)
    assert np.allclose(fitted[:, 0], g.tangents[:, 0] @ c, rtol=0, atol=1e-12)
    assert np.allclose(fitted[:, 1], g.tangents[:, 1] @ c, rtol=0, atol=1e-12)
    second = (g.frame[:, 2] @ c)[:, None] * g.height_fit[:, 2:]
    assert np.abs(second).max() > 0.5  # not zero: the surface is curved
    assert np.allclose(fitted[:, 2:], second, rtol=0, atol=1e-10)
    # the vector version is the same operator on each component
    vec = g.fit_vector(g.points)
    assert np.allclose(vec[:, :2], g.tangents, rtol=0, atol=1e-12)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_fitted_patch_is_self_consistent(lab, scheme):
    """metric = e_a . e_b, its inverse, n_f a unit normal to both tangents (outward),
    C_ab = -n_f . X_ab with X_ab = h_ab n, Gamma^c_ab = g^cd e_d . X_ab."""
    g = lab.geometry(lab.perturbed(642), scheme)
    e = g.tangents
    assert np.allclose(g.metric, np.einsum("nac,nbc->nab", e, e), atol=1e-13)
    assert np.allclose(np.einsum("nab,nbc->nac", g.metric, g.metric_inv), np.eye(2), atol=1e-13)
    nf = g.normal_fit
    assert np.allclose(np.linalg.norm(nf, axis=1), 1.0, atol=1e-13)
    assert np.abs(np.einsum("nac,nc->na", e, nf)).max() < 1e-13
    assert (np.einsum("nc,nc->n", np.cross(e[:, 0], e[:, 1]), nf) > 0).all()
    n = g.frame[:, 2]
    h = g.height_fit
    hab = np.stack([np.stack([h[:, 2], h[:, 4]], 1), np.stack([h[:, 4], h[:, 3]], 1)], 1)
    xab = hab[..., None] * n[:, None, None, :]  # (N, 2, 2, 3)
    assert np.allclose(g.curvature, -np.einsum("nc,nabc->nab", nf, xab), atol=1e-12)
    gamma = np.einsum("ncd,ndk,nabk->ncab", g.metric_inv, e, xab)
    assert np.allclose(g.christoffel, gamma, atol=1e-12)
    # the frame rows are orthonormal and right-handed
    assert np.allclose(np.einsum("nac,nbc->nab", g.frame, g.frame), np.eye(3), atol=1e-13)
    assert np.allclose(np.linalg.det(g.frame), 1.0, atol=1e-13)


# ---------------------------------------------------------------------------------------------
# spheres
# ---------------------------------------------------------------------------------------------
def sphere_errors(g, radius):
    """Max relative errors of C and K, and max |C_ab - g_ab / R| R."""
    ec = np.abs(g.mean_curvature - 2.0 / radius).max() * radius / 2.0
    ek = np.abs(g.gaussian_curvature - 1.0 / radius**2).max() * radius**2
    et = np.abs(g.curvature - g.metric / radius).max() * radius
    return ec, ek, et


# measured max relative errors of C, K and of the tensor C_ab - g_ab / R on the 642 icosphere
# (identical for every R)
SPHERE_642 = {"quadratic": (6.60e-3, 1.325e-2, 6.73e-3), "quartic": (5.54e-4, 1.108e-3, 6.07e-4)}


@pytest.mark.parametrize("scheme", SCHEMES)
def test_sphere_curvature_all_radii(lab, scheme):
    """C = 2/R, K = 1/R^2 and the full tensor C_ab = g_ab / R at every node, for R = 0.5, 1, 2;
    the relative errors do not depend on R (the scheme is scale invariant)."""
    errs = []
    for radius in (0.5, 1.0, 2.0):
        g = lab.geometry(lab.icosphere(642, radius), scheme)
        errs.append(sphere_errors(g, radius))
        assert (g.mean_curvature > 0).all()
    errs = np.array(errs)
    assert np.allclose(errs, errs[1], rtol=1e-6, atol=0)
    assert (errs[1] < 1.5 * np.array(SPHERE_642[scheme])).all(), errs[1]


@pytest.mark.parametrize("scheme, min_ratio", [("quadratic", 3.5), ("quartic", 8.0)])
@pytest.mark.parametrize("perturbed", [False, True], ids=["regular", "irregular"])
def test_sphere_curvature_converges(lab, scheme, min_ratio, perturbed):
    """Error ratio between 642 and 2562 nodes (h halves). Measured:
    regular   quadratic C 3.90, K 3.91, C_ab 3.96;  quartic C 13.6, K 13.6, C_ab 14.8
    irregular quadratic C 3.95, K 3.96, C_ab 3.99;  quartic C 14.1, K 14.1, C_ab 13.6
    (irregular: the nodes moved along the sphere, the surface is still the sphere)."""

    def mesh(n):
        return lab.perturbed(n, on_sphere=True) if perturbed else lab.icosphere(n)

    coarse = sphere_errors(lab.geometry(mesh(642), scheme), 1.0)
    fine = sphere_errors(lab.geometry(mesh(2562), scheme), 1.0)
    for c, f in zip(coarse, fine, strict=False):
        assert c / f > min_ratio, (coarse, fine)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_monge_height_derivatives_on_sphere(lab, scheme):
    """On a sphere the height over the plane (x_i, e_xi, e_eta) has exact derivatives: with
    p = x_i in the frame, h_xi = -p_xi/p_n, h_eta = -p_eta/p_n, h_xixi = -(1 + h_xi^2)/p_n,
    h_etaeta = -(1 + h_eta^2)/p_n, h_xieta = -h_xi h_eta / p_n. Irregular mesh on the unit sphere,
    where the angle-weighted normal is up to 1.7 degrees off radial, so h_xi, h_eta != 0
    (max |h_xi| 0.025)."""
    errors = []
    for n in (642, 2562):
        g = lab.geometry(lab.perturbed(n, on_sphere=True), scheme)
        p = np.einsum("nkc,nc->nk", g.frame, g.points)
        hx, hy = -p[:, 0] / p[:, 2], -p[:, 1] / p[:, 2]
        exact = np.stack([hx, hy, -(1 + hx**2) / p[:, 2], -(1 + hy**2) / p[:, 2], -hx * hy / p[:, 2]], 1)
        assert np.abs(hx).max() > 0.01  # the slopes are really tested
        errors.append(np.abs(g.height_fit - exact).max(axis=0))
    coarse, fine = errors
    # measured max error at 642: quadratic 2.1e-4 (slopes) / 9.8e-3 (second derivatives),
    # quartic 3.6e-5 / 1.0e-3; ratios 642 -> 2562 of the second derivatives: quadratic
    # 3.7-4.2, quartic 13.6-15.6
    bound = {"quadratic": (3.2e-4, 1.5e-2), "quartic": (5.4e-5, 1.5e-3)}[scheme]
    assert coarse[:2].max() < bound[0] and coarse[2:].max() < bound[1], coarse
    assert (coarse[2:] / fine[2:]).min() > (3.5 if scheme == "quadratic" else 8.0)


def test_fitted_normal_beats_angle_weighted_normal(lab):
    """The fitted normal is far more accurate than the angle-weighted one (paper's frame normal).
    Measured max angle to the radial direction (rad):
    regular 642:   angle-weighted 5.2e-3, fitted 4.3e-5 (quadratic), 6.8e-6 (quartic)
    irregular 642: angle-weighted 3.0e-2, fitted 2.2e-4 (quadratic), 3.6e-5 (quartic)."""
    for mesh, aw_bound, fit_bound in (
        (lab.icosphere(642), 7.8e-3, (6.4e-5, 1.0e-5)),
        (lab.perturbed(642, on_sphere=True), 4.5e-2, (3.3e-4, 5.4e-5)),
    ):
        for scheme, fb in zip(SCHEMES, fit_bound, strict=False):
            g = lab.geometry(mesh, scheme)
            aw = angle_to(g.frame[:, 2], mesh.points).max()  # angle-weighted (paper Eq. 30)
            fit = angle_to(g.normal_fit, mesh.points).max()
            assert aw < aw_bound and fit < fb, (aw, fit)
            assert fit * 10 < aw, "an order of magnitude"


# ---------------------------------------------------------------------------------------------
# ellipsoid
# ---------------------------------------------------------------------------------------------
ABC = np.array([1.3, 1.0, 0.7])


def ellipsoid_exact(x):
    """Mean-curvature trace C, Gaussian curvature K and unit outward normal of the implicit
    surface F = sum x_k^2 / a_k^2 - 1 (H = Hessian of F, diagonal)."""
    grad = 2.0 * x / ABC**2
    hess = 2.0 / ABC**2
    gn = np.linalg.norm(grad, axis=1)
    c = (gn**2 * hess.sum() - np.einsum("nk,k,nk->n", grad, hess, grad)) / gn**3
    adj = np.array([hess[1] * hess[2], hess[0] * hess[2], hess[0] * hess[1]])
    k = np.einsum("nk,k,nk->n", grad, adj, grad) / gn**4
    return c, k, grad / gn[:, None]


def ellipsoid_geometry(lab, n, scheme):
    mesh = lab.memo(("ellipsoid", n), lambda: affine(lab.icosphere(n), np.diag(ABC)))
    return lab.geometry(mesh, scheme)


def test_ellipsoid_closed_form_sanity():
    """The closed forms themselves, at the vertex (a, 0, 0) where the principal curvatures are
    a/b^2 and a/c^2: C = a/b^2 + a/c^2, K = a^2/(b^2 c^2), normal +x."""
    c, k, n = ellipsoid_exact(np.array([[ABC[0], 0.0, 0.0]]))
    a, b, cc = ABC
    assert c[0] == pytest.approx(a / b**2 + a / cc**2)
    assert k[0] == pytest.approx(a**2 / (b**2 * cc**2))
    assert np.allclose(n[0], [1, 0, 0])


# measured max |error| at 642 / 2562 nodes:   C                 K                 normal
ELLIPSOID = {
    "quadratic": {642: (3.82e-2, 5.23e-2, 7.8e-3), 2562: (1.32e-2, 1.66e-2, 2.0e-3)},
    "quartic": {642: (4.41e-3, 5.81e-3, 1.19e-3), 2562: (5.80e-4, 5.65e-4, 7.1e-5)},
}


@pytest.mark.parametrize("scheme", SCHEMES)
def test_ellipsoid_curvature(lab, scheme):
    """Per-node C, K and fitted normal on the (1.3, 1.0, 0.7) ellipsoid vs the closed forms,
    and their convergence 642 -> 2562. Measured ratios: quadratic C 2.91, K 3.15 (the one-ring
    least squares is not symmetric on this stretched mesh; 2562 -> 10242 gives 2.5 for C);
    quartic C 7.6, K 10.3."""
    errs = {}
    for n in (642, 2562):
        g = ellipsoid_geometry(lab, n, scheme)
        c, k, normal = ellipsoid_exact(g.points)
        assert (g.mean_curvature > 0).all() and (g.gaussian_curvature > 0).all()
        errs[n] = (
            np.abs(g.mean_curvature - c).max(),
            np.abs(g.gaussian_curvature - k).max(),
            np.abs(g.normal_fit - normal).max(),
        )
        for got, measured in zip(errs[n], ELLIPSOID[scheme][n], strict=False):
            assert got < 1.5 * measured, (n, errs[n])
    ratios = np.array(errs[642]) / np.array(errs[2562])
    assert ratios[:2].min() > (2.5 if scheme == "quadratic" else 6.0), ratios


# ---------------------------------------------------------------------------------------------
# areas and volume
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("which", ["regular", "irregular", "ellipsoid"])
def test_mixed_areas_tile_the_surface(lab, which):
    """sum_i A_i (Meyer mixed areas) = total triangle area to rounding, obtuse triangles included."""
    mesh = {
        "regular": lambda: lab.icosphere(642),
        "irregular": lambda: lab.perturbed(642),
        "ellipsoid": lambda: affine(lab.icosphere(642), np.diag(ABC)),
    }[which]()
    g = lab.geometry(mesh, "quadratic")
    total = face_areas(mesh.points, mesh.faces).sum()
    assert g.area.sum() == pytest.approx(total, rel=1e-12)
    assert (g.area > 0).all()
    if which == "irregular":
        # Meyer's obtuse-triangle branch is exercised
        assert (face_angles(mesh.points, mesh.faces) > 90).any()


@pytest.mark.parametrize("which", ["regular", "irregular"])
def test_volume_gradient_matches_finite_differences(lab, which):
    """dV/dx_i against central differences of the signed volume (V is linear in each node, so the
    central difference is exact up to rounding), for every node and direction; and Euler's
    relation sum_i x_i . dV/dx_i = 3 V."""
    mesh = lab.icosphere(642) if which == "regular" else lab.perturbed(642)
    g = lab.geometry(mesh, "quadratic")
    step = 1e-4
    fd = np.zeros_like(mesh.points)
    for i in range(mesh.n_nodes):
        for c in range(3):
            p = mesh.points.copy()
            p[i, c] += step
            vp = signed_volume(p, mesh.faces)
            p[i, c] -= 2 * step
            fd[i, c] = (vp - signed_volume(p, mesh.faces)) / (2 * step)
    scale = np.abs(g.volume_gradient).max()
    assert np.abs(g.volume_gradient - fd).max() < 1e-7 * scale
    volume = signed_volume(mesh.points, mesh.faces)
    assert np.einsum("nc,nc->", mesh.points, g.volume_gradient) == pytest.approx(3 * volume, rel=1e-12)


# ---------------------------------------------------------------------------------------------
# rank deficiency and wider stencils
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("base, valence", [(OCTAHEDRON, 4), (TETRAHEDRON, 3)], ids=["octa", "tetra"])
def test_low_valence_node_gets_wider_stencil(lab, base, valence):
    """Nodes of valence 3 or 4 cannot determine a quadratic from their one-ring (5 unknowns): they
    get the two-ring automatically (and a three-ring for the quartic's 14 unknowns), and the fit
    still reproduces the scheme's polynomials exactly."""
    mesh = subdivided_sphere(*base, levels=3)  # 258 (octa) / 130 (tetra) nodes
    topo = build_topology(mesh)
    low = np.flatnonzero(topo.valence == valence)
    assert low.size == len(base[0])
    for scheme in SCHEMES:
        g = compute_geometry(mesh.points, topo, StencilChooser(topo, scheme))
        scheme_obj = FIT_SCHEMES[scheme]
        assert (g.stencil_size >= scheme_obj.n_terms).all()
        assert polynomial_fit_errors(g, scheme_obj.order, seed=3).max() < 1e-10
        if scheme == "quadratic":
            for i in low:
                got = set(g.stencil[i, : g.stencil_size[i]].tolist())
                assert got == set(topo.ring2[i, : topo.ring2_size[i]].tolist())
            high = np.setdiff1d(np.arange(mesh.n_nodes), low)
            assert (g.stencil_size[high] == topo.valence[high]).all()
        else:
            assert (g.stencil_size[low] > topo.ring2_size[low]).all()
        # and the geometry is sane there: the sphere's mean curvature within 15 %
        assert np.abs(g.mean_curvature[low] - 2.0).max() < 0.3


def conic_ring():
    """Five directions/radii around a node whose points lie, with the node, on one conic: the
    one-ring cannot determine a quadratic (5x5 design matrix singular). The last radius is solved
    for: det(design) / r is linear in r."""
    ang = np.radians([29.9, 134.1, 165.9, 197.8, 261.8])
    rad = np.array([1.2069, 1.2775, 0.8013, 1.2016, 1.0])

    def det(r):
        rr = rad.copy()
        rr[4] = r
        u, w = rr * np.cos(ang), rr * np.sin(ang)
        return np.linalg.det(np.stack([u, w, u * u / 2, w * w / 2, u * w], 1))

    d1, d2 = det(1.0), det(2.0) / 2.0
    rad[4] = 1.0 - d1 / (d2 - d1)
    return ang, rad


def test_degenerate_one_ring_is_widened(lab):
    """A valence-5 node (one of the icosahedron's vertices of the 642 icosphere) whose one-ring is
    moved into its tangent plane onto a conic through the node: the fit is rank deficient there
    and the node is moved to the two-ring automatically, where quadratics are reproduced."""
    ang, rad = conic_ring()
    assert 0.7 < rad[4] < 1.5
    base = lab.icosphere(642)
    topo = lab.topology(base)
    i = 0
    assert topo.valence[i] == 5
    ring = topo.ring[i, :5]
    p = base.points.copy()
    n = p[i] / np.linalg.norm(p[i])
    e = np.linalg.norm(p[ring] - p[i], axis=1).mean()
    t1 = p[ring[0]] - p[i]
    t1 -= (t1 @ n) * n
    t1 /= np.linalg.norm(t1)
    t2 = np.cross(n, t1)
    orig = np.arctan2((p[ring] - p[i]) @ t2, (p[ring] - p[i]) @ t1)
    offset = np.angle(np.exp(1j * (orig - ang)).mean())
    for k, a in enumerate(ring):
        p[a] = p[i] + e * rad[k] * (np.cos(ang[k] + offset) * t1 + np.sin(ang[k] + offset) * t2)
    mesh = validate_mesh(p, base.faces)
    g = compute_geometry(mesh.points, topo, StencilChooser(topo, "quadratic"))
    # the one-ring really is degenerate in the node's own frame
    d = mesh.points[ring] - mesh.points[i]
    u, w = d @ g.frame[i, 0] / e, d @ g.frame[i, 1] / e
    sv = np.linalg.svd(np.stack([u, w, u * u / 2, w * w / 2, u * w], 1), compute_uv=False)
    assert sv[-1] < 1e-12 * sv[0]
    # ... so the node got its two-ring, a well-posed fit, and exact quadratics
    assert g.stencil_size[i] == topo.ring2_size[i] > 5
    assert g.fit_quality[i] > 1e-3  # measured 0.19
    others = np.arange(mesh.n_nodes) != i
    assert (g.stencil_size[others] == topo.valence[others]).all()
    assert polynomial_fit_errors(g, 2, seed=4).max() < 1e-10


@pytest.mark.parametrize("operators", [True, False])
def test_a_quartic_fit_no_stencil_determines_takes_the_quadratic_terms_on_the_nearest_nodes(lab, operators):
    """The icosahedron (12 nodes): every node's widest stencil is the 11 others, fewer than the quartic's
    14 monomials, so no quartic fit exists. Instead of a MeshError each node takes the quadratic terms
    alone on its nearest stencil nodes (its five neighbours): the paper's one-ring quadratic fit, so the
    same normals (radial, by the icosahedron's symmetry) and curvature (1.382, the coarse ring's) as the
    quadratic scheme."""
    mesh = lab.icosphere(12)
    topo = build_topology(mesh)
    quartic = compute_geometry(mesh.points, topo, StencilChooser(topo, "quartic"), operators=operators)
    quadratic = compute_geometry(mesh.points, topo, StencilChooser(topo, "quadratic"))
    radial = mesh.points / np.linalg.norm(mesh.points, axis=1)[:, None]
    assert np.abs(np.einsum("nc,nc->n", quartic.normal_fit, radial) - 1.0).max() < 1e-13
    assert np.abs(quartic.curvature - quadratic.curvature).max() < 1e-12
    assert np.all(quartic.fit_quality > 1e-8)
    assert np.abs(quartic.height_poly[:, 5:]).max() == 0.0  # no cubic or quartic term


@pytest.mark.parametrize("scheme", SCHEMES)
def test_hopelessly_flat_mesh_raises_mesh_error(lab, scheme):
    """A closed icosphere squashed to 1e-4 of its height: along the rim no stencil can see a
    quadratic (the projected stencil collapses onto a line); MeshError names the problem."""
    mesh = affine(lab.icosphere(162), np.diag([1.0, 1.0, 1e-4]))
    topo = build_topology(mesh)
    with pytest.raises(MeshError, match="rank deficient"):
        compute_geometry(mesh.points, topo, StencilChooser(topo, scheme))


@pytest.mark.parametrize("case", ["tetra34", "flat1e-3"])
def test_exactly_singular_fit_widens_or_raises_mesh_error(lab, case):
    if case == "tetra34":
        mesh = subdivided_sphere(*TETRAHEDRON, levels=2)
    else:
        mesh = affine(lab.icosphere(162), np.diag([1.0, 1.0, 1e-3]))
    topo = build_topology(mesh)
    try:
        g = compute_geometry(mesh.points, topo, StencilChooser(topo, "quartic"))
    except MeshError:
        return
    assert polynomial_fit_errors(g, 4, seed=5).max() < 1e-10
