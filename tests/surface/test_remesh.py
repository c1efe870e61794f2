"""Remeshing (cortex_ti.surface.remesh) against the truths of docs/derivations/remeshing.md: a valid
closed manifold mesh (surface.validation) with its smallest angle above the run's trigger, the
surface kept within the error bound of the derivation (ellipsoid), the enclosed volume and the
amount of a density kept to round-off, a uniform intensive field kept exactly, the closest point
against a brute-force search, and the transfer of a smooth field converging at second order. The
node budget: its scale against the closed form on a sphere and against its definition, the grading
against the shortest-path form of MMG's rule, and the node count MMG returns within the budget's
tolerance (a sphere refined 4-fold, a pinched surface whose nodes move into its neck). The accept
rule: a hard neck from a furrow run meets the trigger after a second pass; a trigger out of reach
gets the bounded retries and one warning."""

import logging
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cortex_ti.surface.mesh import icosphere
from cortex_ti.surface.remesh import (
    BUDGET_RTOL,
    RETRIES,
    RemeshOptions,
    budget_scale,
    closest_points,
    edge_curvature,
    enclosed_volume,
    flip_bad_edges,
    grade,
    mean_edge_length,
    min_angles,
    node_coarseness,
    predicted_nodes,
    remesh,
    remesh_available,
    sizes,
)
from cortex_ti.surface.transport import DENSITY, dual_areas
from cortex_ti.surface.validation import validate_mesh

EPS = np.finfo(float).eps
AXES = np.array([1.3, 1.0, 0.8])  # the ellipsoid's semi-axes

needs_mmg = pytest.mark.skipif(not remesh_available(), reason="mmgpy not installed (the remesh extra)")


def _ellipsoid(n):
    m = icosphere(n)
    return m.points * AXES, m.faces


def _pinched(n, depth=0.5):
    """An ellipsoid pinched at its equator by a Gaussian furrow of relative depth ``depth``."""
    p, f = _ellipsoid(n)
    p = p * np.array([1.2, 1.0, 1.0])
    p[:, :2] *= (1.0 - depth * np.exp(-((p[:, 2] / 0.25) ** 2)))[:, None]
    return p, f


def _smooth(x):
    return np.sin(2.0 * x[:, 0]) + x[:, 1] * x[:, 2]


def test_closest_points_match_brute_force():
    """Every query near the surface gets the foot point of a search over all triangles."""
    rng = np.random.default_rng(0)
    p, f = _pinched(642)
    q = p[rng.integers(0, len(p), 400)] + 0.03 * rng.standard_normal((400, 3))
    tri, bary = closest_points(p, f, q)
    foot = np.einsum("qk,qkc->qc", bary, p[f[tri]])
    assert np.all(bary >= -1e-12) and np.allclose(bary.sum(axis=1), 1.0, atol=1e-14)
    # brute force: the region test (checked against sampling below) on every triangle
    from cortex_ti.surface.closest import _closest_on_triangles

    x = p[f]
    best = np.empty(len(q))
    for i, point in enumerate(q):
        b = _closest_on_triangles(np.broadcast_to(point, x[:, 0].shape), x[:, 0], x[:, 1], x[:, 2])
        best[i] = np.min(np.linalg.norm(np.einsum("tk,tkc->tc", b, x) - point, axis=1))
    got = np.linalg.norm(foot - q, axis=1)
    assert np.max(np.abs(got - best)) < 1e-12


def test_point_triangle_region_test_against_sampling():
    """The region test's foot point is no farther than any of 20000 sample points of the triangle
    (and the best sample is within the sampling resolution of it)."""
    from cortex_ti.surface.closest import _closest_on_triangles

    rng = np.random.default_rng(1)
    a, b, c = np.array([0.0, 0, 0]), np.array([1.0, 0.1, 0]), np.array([0.3, 0.8, 0.1])
    s = rng.random((20000, 2))
    s = np.where(s.sum(axis=1, keepdims=True) > 1, 1 - s, s)
    samples = a + s[:, :1] * (b - a) + s[:, 1:] * (c - a)
    for point in rng.normal(0.4, 1.0, (30, 3)):
        bary = _closest_on_triangles(point, a, b, c)
        foot = bary @ np.stack([a, b, c])
        d = np.linalg.norm(samples - point, axis=1).min()
        assert np.linalg.norm(foot - point) <= d + 1e-14
        assert d - np.linalg.norm(foot - point) < 0.02


def test_edge_curvature_of_an_ellipsoid_bounded_by_the_principal_curvatures():
    """The estimate lies between the extreme normal curvatures of the ellipsoid
    (min a/c^2-type bounds: kappa in [c/a^2, a/c^2] for a > b > c), up to O(h) discretisation."""
    p, f = _ellipsoid(2562)
    a, c = AXES.max(), AXES.min()
    k = edge_curvature(p, f)
    h = mean_edge_length(p, f)
    assert k.min() > c / a**2 * (1 - 2 * h) and k.max() < a / c**2 * (1 + 2 * h)


@needs_mmg
@pytest.mark.parametrize("shape", ["ellipsoid", "pinched"])
def test_remesh_is_valid_keeps_volume_amount_and_surface(shape):
    p, f = _ellipsoid(642) if shape == "ellipsoid" else _pinched(642)
    c = 1.0 + 0.5 * p[:, 0]  # a positive density
    res = remesh(p, f, {"c": c, "q": np.full(len(p), 2.5)}, {"c": DENSITY}, RemeshOptions())
    mesh = validate_mesh(res.points, res.faces)  # closed, manifold, connected, outward
    assert mesh.n_nodes == res.points.shape[0]
    assert min_angles(res.points, res.faces).min() > 25.0  # above the run's default trigger
    v0 = enclosed_volume(p, f)
    assert abs(enclosed_volume(res.points, res.faces) / v0 - 1.0) < 1e-13
    total0 = np.dot(c, dual_areas(p, f))
    assert abs(np.dot(res.fields["c"], dual_areas(res.points, res.faces)) / total0 - 1.0) < 50 * EPS
    assert np.abs(res.fields["q"] - 2.5).max() <= 8 * EPS * 2.5  # barycentric weights sum to 1 up to round-off
    if shape == "ellipsoid":
        # the new nodes lie within hausd of the old polyhedron, which lies within the sagitta
        # h^2 kappa_max / 8 of the ellipsoid; the volume offset adds |delta|
        h = np.linalg.norm(p[f] - p[f][:, [1, 2, 0]], axis=2).max()
        kmax = AXES.max() / AXES.min() ** 2
        bound = 0.05 * mean_edge_length(p, f) + h * h * kmax / 8 + abs(res.offset)
        g = np.sum((res.points / AXES) ** 2, axis=1) - 1.0
        dist = np.abs(g) / np.linalg.norm(2 * res.points / AXES**2, axis=1)  # first order in the distance
        assert dist.max() < bound


@needs_mmg
def test_density_without_content_is_shifted_and_kept():
    """A density of zero total (c = x on a shape symmetric in x) cannot be rescaled: it is shifted."""
    p, f = _pinched(642)
    c = p[:, 0] - np.dot(p[:, 0], dual_areas(p, f)) / dual_areas(p, f).sum()
    res = remesh(p, f, {"c": c}, {"c": DENSITY})
    scale = np.dot(np.abs(c), dual_areas(p, f))
    assert abs(np.dot(res.fields["c"], dual_areas(res.points, res.faces))) < 50 * EPS * scale


@needs_mmg
def test_curvature_sizing_resolves_the_neck():
    """Edges at the pinch are shorter than elsewhere, as edge_angle / kappa asks (within hgrad)."""
    p, f = _pinched(642, depth=0.6)
    opts = RemeshOptions()
    res = remesh(p, f, options=opts)
    mid = 0.5 * (res.points[res.faces] + res.points[res.faces][:, [1, 2, 0]])
    length = np.linalg.norm(res.points[res.faces] - res.points[res.faces][:, [1, 2, 0]], axis=2)
    neck = np.abs(mid[..., 2]) < 0.05
    far = np.abs(mid[..., 2]) > 0.6
    assert length[neck].mean() < 0.5 * length[far].mean()


@needs_mmg
def test_transfer_of_a_smooth_field_converges_at_second_order():
    """The closest-point P1 transfer of f = sin 2x + yz onto the remeshed ellipsoid: the error at the
    new nodes falls like h^2 (observed order between 1.7 and 2.3 over two halvings of h)."""
    errors, sizes = [], []
    for n in (642, 2562, 10242):
        p, f = _ellipsoid(n)
        res = remesh(p, f, {"f": _smooth(p)})
        errors.append(np.abs(res.fields["f"] - _smooth(res.points)).max())
        sizes.append(mean_edge_length(p, f))
    order = np.diff(np.log(errors)) / np.diff(np.log(sizes))
    assert np.all((order > 1.7) & (order < 2.3)), order


def test_flips_repair_an_obtuse_pair():
    """Two triangles sharing a long edge opposite two 150-degree angles: the flip makes them
    acute-angled (the Delaunay pair) and keeps their orientation."""
    pts = np.array([[0.0, 0, 0], [1.0, 0, 0], [0.5, 0.13, 0], [0.5, -0.13, 0]])
    faces = np.array([[0, 1, 2], [1, 0, 3]])
    out = flip_bad_edges(pts, faces, 30.0)
    assert sorted(map(sorted, out.tolist())) == [[0, 2, 3], [1, 2, 3]]
    n = np.cross(pts[out[:, 1]] - pts[out[:, 0]], pts[out[:, 2]] - pts[out[:, 0]])
    assert np.all(n[:, 2] > 0)


def test_budget_scale_on_a_sphere_is_the_closed_form():
    """With kappa = 1/R everywhere, h = s R and N = 2 (4 pi R^2) / (sqrt(3) s^2 R^2): s = sqrt(8 pi /
    (sqrt(3) N)), whatever R. The edge estimate of kappa is within 10 % of 1/R (edge_curvature), so s is."""
    m = icosphere(642)
    for radius in (0.5, 2.0):
        for nodes in (642, 2562, 10242):
            s = budget_scale(m.points * radius, m.faces, nodes, 1e-3, 10.0)
            exact = np.sqrt(8.0 * np.pi / (np.sqrt(3.0) * nodes))
            assert abs(s / exact - 1.0) < 0.1, (radius, nodes, s, exact)


@pytest.mark.parametrize("hgrad", [None, 1.3])
def test_budget_scale_meets_its_definition(hgrad):
    """The scale's predicted count, sum_i A_i 2 / (sqrt(3) h_i^2) with h = clip(s / kappa, h_min,
    h_max) graded as MMG grades it, is the budget to the bisection's 1e-3 in log s (2e-3 in N ~ s^-2);
    a budget beyond the clips returns the clip."""
    p, f = _pinched(2562, depth=0.6)
    area, kappa = dual_areas(p, f), edge_curvature(p, f)
    h_min, h_max = 0.01, 3 * mean_edge_length(p, f)

    def count(s):
        h = sizes(kappa, s, h_min, h_max)
        return predicted_nodes(area, h if hgrad is None else grade(p, f, h, hgrad))

    for nodes in (1000, 2562, 10000):
        s = budget_scale(p, f, nodes, h_min, h_max, hgrad)
        assert abs(count(s) / nodes - 1.0) < 2e-3
    assert budget_scale(p, f, 10, h_min, h_max, hgrad) == pytest.approx(h_max * kappa.max())  # h_max everywhere


def test_grading_is_the_shortest_path_form_of_mmgs_rule():
    """MMG's rule h_j <= h_i + ln(hgrad) l_ij, applied until nothing changes, gives the largest field
    below h that satisfies it: g_j = min_i (h_i + ln(hgrad) d(i, j)), d the shortest path along edges."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    p, f = _pinched(642, depth=0.6)
    rng = np.random.default_rng(1)
    h = np.exp(rng.uniform(np.log(0.01), np.log(0.5), len(p)))
    g = grade(p, f, h, 1.3)
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    w = np.log(1.3) * np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1)
    graph = coo_matrix((w, (e[:, 0], e[:, 1])), shape=(len(p), len(p))).tocsr()
    d = dijkstra(graph, directed=False)
    exact = np.min(h[:, None] + d, axis=0)
    assert np.allclose(g, exact, rtol=1e-12, atol=0.0)


@needs_mmg
@pytest.mark.parametrize(
    ("shape", "n", "nodes"), [("sphere", 642, 2562), ("pinched", 2562, 2562), ("pinched", 642, 2562)]
)
def test_budgeted_remeshing_returns_the_budget(shape, n, nodes):
    """MMG keeps an edge within a factor sqrt(2) of its target (its unit-length band), so one pass
    lands within a factor 2 of the predicted count; remeshed afresh it lands within 5 % (measured
    0.96 - 1.05 on spheres: MMG_DENSITY), and the scale is corrected by MMG's own count past
    BUDGET_RTOL. On the pinched surface the nodes move into the neck: its edges are shorter than
    the far ones by about the ratio of the curvatures (the field s / kappa, graded)."""
    m = icosphere(n)
    p, f = (m.points, m.faces) if shape == "sphere" else _pinched(n, depth=0.6)
    h_max = 3 * mean_edge_length(p, f)
    res = remesh(p, f, options=RemeshOptions(nodes=nodes, h_max=h_max))
    validate_mesh(res.points, res.faces)
    assert abs(res.n_after / nodes - 1.0) <= BUDGET_RTOL
    assert min_angles(res.points, res.faces).min() > 25.0
    if shape == "pinched":
        mid = 0.5 * (res.points[res.faces] + res.points[res.faces][:, [1, 2, 0]])
        length = np.linalg.norm(res.points[res.faces] - res.points[res.faces][:, [1, 2, 0]], axis=2)
        neck, far = np.abs(mid[..., 2]) < 0.05, np.abs(mid[..., 2]) > 0.6
        assert length[neck].mean() < 0.5 * length[far].mean()


def test_node_coarseness_against_its_definition():
    """The largest ratio of a node's mean edge length to its target: 1 when the target is that mean
    (to round-off), 2 when it is half of it."""
    p, f = _pinched(642, depth=0.6)
    e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    length = np.linalg.norm(p[e[:, 0]] - p[e[:, 1]], axis=1)
    mean = np.bincount(e.ravel(), np.repeat(length, 2), len(p)) / np.bincount(e.ravel(), minlength=len(p))
    assert abs(node_coarseness(p, f, mean) - 1.0) < 8 * EPS
    assert abs(node_coarseness(p, f, 0.5 * mean) - 2.0) < 16 * EPS


#: a surface the amplitude-12 furrow (constriction_p4, 2562 nodes, mesh.remesh.h_min 0.005) handed to
#: the remesher at t = 2.39 (neck 0.12 R0), with the options the run remeshed it with
HARD_NECK = Path(__file__).parents[1] / "data" / "remesh_neck_2562.npz"


@needs_mmg
def test_remesh_of_a_hard_neck_meets_the_trigger():
    """The accept rule on a surface where one MMG pass and the repair leave a needle in the neck
    (23.4 deg with mmgpy 0.17.1: a short edge beside two long ones): with the run's trigger 25 deg
    as ``min_angle`` MMG remeshes its own output again and the new mesh meets it, stays a valid
    closed surface with the volume restored and the node count within the budget's tolerance."""
    d = np.load(HARD_NECK)  # shipped: a missing file fails the test
    p, f = d["points"], d["faces"]
    options = RemeshOptions(
        h_min=float(d["h_min"]),
        h_max=float(d["h_max"]),
        nodes=int(d["nodes"]),
        hgrad=float(d["hgrad"]),
        quality=float(d["quality"]),
    )
    res = remesh(p, f, options=replace(options, min_angle=25.0))
    # more than one pass: the first was below 25 deg, the case is hard (if a new MMG is not fooled
    # by it, this test needs a new input)
    assert res.passes > 1
    assert min_angles(res.points, res.faces).min() >= 25.0
    validate_mesh(res.points, res.faces)
    assert abs(enclosed_volume(res.points, res.faces) / enclosed_volume(p, f) - 1.0) < 1e-13
    assert abs(res.n_after / options.nodes - 1.0) <= BUDGET_RTOL


@needs_mmg
def test_an_unmet_trigger_is_said_after_the_bounded_retries(caplog):
    """A trigger no mesh of the sphere's size field meets (55 deg) costs 1 + RETRIES passes, keeps
    the best of them (not worse than one pass) and says so in one warning."""
    m = icosphere(642)
    one = remesh(m.points * AXES, m.faces, options=RemeshOptions(h_max=0.15))
    with caplog.at_level(logging.WARNING, logger="cortex_ti.surface.remesh"):
        res = remesh(m.points * AXES, m.faces, options=RemeshOptions(h_max=0.15, min_angle=55.0))
    assert res.passes == 1 + RETRIES
    assert min_angles(res.points, res.faces).min() >= min_angles(one.points, one.faces).min()
    said = [r for r in caplog.records if r.levelno == logging.WARNING]
    assert len(said) == 1 and "below 55" in said[0].getMessage()
