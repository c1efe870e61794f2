"""Tests for cortex_ti.surface (mesh, reading, validation, topology): icospheres, loading, validation, affine maps."""

from __future__ import annotations

import logging
from collections import deque

import meshio
import numpy as np
import pytest
from scipy.spatial import ConvexHull

from cortex_ti.errors import MeshError
from cortex_ti.surface.mesh import Mesh, affine, icosphere, icosphere_sizes
from cortex_ti.surface.reading import load_mesh
from cortex_ti.surface.topology import Topology, build_topology
from cortex_ti.surface.validation import validate_mesh

# ---------------------------------------------------------------------------
# helpers (independent of the module under test)
# ---------------------------------------------------------------------------


def signed_volume(points, faces):
    p = np.asarray(points)[np.asarray(faces)]
    return float(np.einsum("ij,ij->", p[:, 0], np.cross(p[:, 1], p[:, 2])) / 6.0)


def surface_area(points, faces):
    p = np.asarray(points)[np.asarray(faces)]
    return float(0.5 * np.linalg.norm(np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), axis=1).sum())


def n_edges(faces):
    f = np.asarray(faces)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    return len(np.unique(e, axis=0))


def neighbour_sets(mesh):
    nb = [set() for _ in range(mesh.n_nodes)]
    for a, b, c in mesh.faces.tolist():
        nb[a] |= {b, c}
        nb[b] |= {a, c}
        nb[c] |= {a, b}
    return nb


def check_ring_contract(mesh, topo):
    """Every consecutive ring pair (a_i, a_i+1) of v is an oriented face (v, a_i, a_i+1)."""
    oriented = set()
    for a, b, c in mesh.faces.tolist():
        oriented |= {(a, b, c), (b, c, a), (c, a, b)}
    nb = neighbour_sets(mesh)
    n_checked = 0
    for v in range(mesh.n_nodes):
        k = int(topo.valence[v])
        row = topo.ring[v].tolist()
        ring = row[:k]
        assert all(x == -1 for x in row[k:]), f"node {v}: padding is not -1"
        assert len(set(ring)) == k, f"node {v}: repeated neighbour in ring {ring}"
        assert set(ring) == nb[v], f"node {v}: ring {ring} != neighbours {sorted(nb[v])}"
        for i in range(k):
            assert (v, ring[i], ring[(i + 1) % k]) in oriented, f"node {v}: ({ring[i]}, {ring[(i + 1) % k]}) not a face"
            n_checked += 1
    # each face is seen once from each of its three corners
    assert n_checked == 3 * mesh.n_faces


def random_hull_mesh(n, seed):
    """Irregular closed mesh: convex hull of random points on the unit sphere, outward faces."""
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    faces = ConvexHull(x).simplices.copy()
    p = x[faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    inward = np.einsum("ij,ij->i", normal, p.sum(axis=1)) < 0
    faces[inward] = faces[inward][:, [0, 2, 1]]
    return x, faces


def scrambled_icosphere(n_nodes, seed):
    """Radially perturbed, randomly relabelled icosphere with shuffled, rotated, reversed faces."""
    rng = np.random.default_rng(seed)
    m = icosphere(n_nodes)
    pts = m.points * (1.0 + 0.2 * rng.uniform(-1, 1, size=(m.n_nodes, 1)))
    perm = rng.permutation(m.n_nodes)  # new label of old node i is perm[i]
    new_pts = np.empty_like(pts)
    new_pts[perm] = pts
    faces = perm[m.faces]
    faces = faces[rng.permutation(len(faces))]
    shift = rng.integers(0, 3, size=len(faces))
    faces = np.take_along_axis(faces, (np.arange(3)[None, :] + shift[:, None]) % 3, axis=1)
    faces = faces[:, ::-1]  # all inward: validate_mesh must flip them
    return new_pts, faces


# ---------------------------------------------------------------------------
# icosphere
# ---------------------------------------------------------------------------


def test_icosphere_sizes():
    assert icosphere_sizes() == [12, 42, 162, 642, 2562, 10242, 40962, 163842]
    assert icosphere_sizes(2) == [12, 42, 162]


@pytest.mark.parametrize("n", [42, 162, 642, 2562])
@pytest.mark.parametrize("radius", [1.0, 2.5])
def test_icosphere_counts_radius_orientation(n, radius):
    m = icosphere(n, radius=radius)
    assert isinstance(m, Mesh)
    assert m.points.dtype == np.float64 and m.points.flags.c_contiguous
    assert m.faces.dtype == np.int32 and m.faces.flags.c_contiguous
    assert m.n_nodes == n
    assert m.n_faces == 2 * n - 4
    assert m.n_nodes - n_edges(m.faces) + m.n_faces == 2
    r = np.linalg.norm(m.points, axis=1)
    assert np.max(np.abs(r - radius)) <= 1e-14 * radius
    topo = build_topology(m)
    assert np.bincount(topo.valence).tolist() == [0] * 5 + [12, n - 12]
    assert np.all(topo.valence[:12] == 5)  # the icosahedron vertices come first
    # outward: positive volume and every face normal points away from the centre
    assert signed_volume(m.points, m.faces) > 0
    p = m.points[m.faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(np.einsum("ij,ij->i", normal, p.mean(axis=1)) > 0)


def test_icosphere_converges_to_sphere():
    # measured relative deficits (1 - A/4piR^2, 1 - V/(4/3 piR^3)):
    #   N=42: 0.0717, 0.127; 162: 0.0188, 0.0338; 642: 0.00476, 0.00861; 2562: 0.00119, 0.00216
    R = 1.7
    errs = []
    for n in [42, 162, 642, 2562]:
        m = icosphere(n, radius=R)
        ea = 1.0 - surface_area(m.points, m.faces) / (4 * np.pi * R**2)
        ev = 1.0 - signed_volume(m.points, m.faces) / (4 / 3 * np.pi * R**3)
        assert ea > 0 and ev > 0  # inscribed polyhedron is smaller
        errs.append((ea, ev))
    assert errs[-1][0] < 1.3e-3 and errs[-1][1] < 2.3e-3
    for (a0, v0), (a1, v1) in zip(errs, errs[1:], strict=False):
        assert 3.2 < a0 / a1 < 4.1, (a0, a1)  # second-order: ~4x per level
        assert 3.0 < v0 / v1 < 4.1, (v0, v1)


def test_icosphere_deterministic_and_valid():
    a, b = icosphere(642), icosphere(642)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.faces, b.faces)
    v = validate_mesh(a.points, a.faces)
    assert np.array_equal(v.points, a.points) and np.array_equal(v.faces, a.faces)


@pytest.mark.parametrize("bad", [100, 0, 41, 12.5, "many", -42])
def test_icosphere_invalid_node_count(bad):
    with pytest.raises(MeshError, match="10 \\* 4\\*\\*k \\+ 2") as exc:
        icosphere(bad)
    assert "642" in str(exc.value) and "163842" in str(exc.value)


@pytest.mark.parametrize("radius", [0.0, -1.0, float("nan"), float("inf")])
def test_icosphere_invalid_radius(radius):
    with pytest.raises(MeshError, match="radius"):
        icosphere(42, radius=radius)


# ---------------------------------------------------------------------------
# topology
# ---------------------------------------------------------------------------


def test_ring_contract_icosphere_642():
    m = icosphere(642)
    topo = build_topology(m)
    assert isinstance(topo, Topology)
    assert topo.ring.shape == (642, 6) and topo.ring.dtype == np.int32
    assert topo.valence.dtype == np.int32 and topo.ring2.dtype == np.int32
    check_ring_contract(m, topo)
    # rings start at the smallest neighbour
    first = topo.ring[:, 0]
    masked = np.where(topo.ring < 0, np.iinfo(np.int32).max, topo.ring)
    assert np.array_equal(first, masked.min(axis=1))


def test_ring_contract_scrambled_mesh():
    pts, faces = scrambled_icosphere(642, seed=3)
    assert signed_volume(pts, faces) < 0
    m = validate_mesh(pts, faces)
    assert m.n_nodes == 642 and signed_volume(m.points, m.faces) > 0
    topo = build_topology(m)
    check_ring_contract(m, topo)


def test_ring_contract_irregular_valence():
    pts, faces = random_hull_mesh(400, seed=7)
    m = validate_mesh(pts, faces)
    topo = build_topology(m)
    assert topo.valence.min() <= 4 and topo.valence.max() >= 8  # genuinely irregular
    assert topo.ring.shape[1] == topo.valence.max()
    assert topo.valence.sum() == 3 * m.n_faces
    check_ring_contract(m, topo)


def test_topology_independent_of_face_order():
    m = icosphere(162)
    rng = np.random.default_rng(0)
    f = m.faces[rng.permutation(m.n_faces)]
    f = np.roll(f, 1, axis=1)
    t1, t2 = build_topology(m), build_topology(Mesh(m.points, f))
    assert np.array_equal(t1.ring, t2.ring) and np.array_equal(t1.ring2, t2.ring2)


def bfs_within_two(nb, v):
    dist = {v: 0}
    q = deque([v])
    while q:
        u = q.popleft()
        if dist[u] == 2:
            continue
        for w in nb[u]:
            if w not in dist:
                dist[w] = dist[u] + 1
                q.append(w)
    return {u for u, d in dist.items() if 0 < d <= 2}, {u for u, d in dist.items() if d == 1}


@pytest.mark.parametrize("which", ["icosphere", "hull"])
def test_ring2_equals_bfs(which):
    if which == "icosphere":
        m = icosphere(162)
    else:
        m = validate_mesh(*random_hull_mesh(300, seed=11))
    topo = build_topology(m)
    nb = neighbour_sets(m)
    assert topo.ring2.shape[1] == topo.ring2_size.max()
    for v in range(m.n_nodes):
        s = int(topo.ring2_size[v])
        row = topo.ring2[v].tolist()
        within2, ring1 = bfs_within_two(nb, v)
        assert len(set(row[:s])) == s and all(x == -1 for x in row[s:])
        assert set(row[:s]) == within2
        k = int(topo.valence[v])
        assert row[:k] == topo.ring[v, :k].tolist()  # one-ring first, in ring order
        assert set(row[:k]) == ring1
    if which == "icosphere":
        # valence-6 node far from the 12 poles: 6 + 12 nodes; pole: 5 + 10
        assert np.bincount(topo.ring2_size).tolist()[15:] == [12, 0, 60, 90]


def test_build_topology_rejects_unvalidated_mesh():
    m = icosphere(42)
    f = m.faces.copy()
    f[0] = f[0, ::-1]
    with pytest.raises(MeshError, match="validate_mesh"):
        build_topology(Mesh(m.points, f))
    with pytest.raises(MeshError, match="validate_mesh"):
        build_topology(Mesh(m.points, m.faces[1:]))


# ---------------------------------------------------------------------------
# file round trips
# ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    "ext,kwargs",
    [(".obj", {}), (".ply", {}), (".vtu", {}), (".off", {}), (".stl", {"binary": False}), (".stl", {"binary": True})],
)
def test_round_trip_through_meshio(tmp_path, ext, kwargs):
    m = icosphere(642, radius=1.3)
    pts = m.points
    if kwargs.get("binary"):
        pts = pts.astype(np.float32).astype(np.float64)  # binary STL stores float32
    path = tmp_path / f"cell{ext}"
    meshio.write(str(path), meshio.Mesh(pts, [("triangle", m.faces)]), **kwargs)
    loaded = load_mesh(path)
    assert loaded.n_nodes == 642 and loaded.n_faces == 1280
    v_ref = signed_volume(pts, m.faces)
    assert abs(signed_volume(loaded.points, loaded.faces) - v_ref) <= 1e-12 * v_ref
    assert abs(surface_area(loaded.points, loaded.faces) - surface_area(pts, m.faces)) <= 1e-12 * 4 * np.pi * 1.69
    if ext != ".stl":  # node order is preserved for indexed formats
        assert np.array_equal(loaded.points, pts) and np.array_equal(loaded.faces, m.faces)


def test_triangle_soup_is_merged():
    m = icosphere(642)
    rng = np.random.default_rng(5)
    soup = m.points[m.faces].reshape(-1, 3)
    soup = soup + 1e-13 * rng.uniform(-1, 1, size=soup.shape)  # below 1e-10 x diagonal
    faces = np.arange(len(soup)).reshape(-1, 3)
    v = validate_mesh(soup, faces, name="soup")
    assert v.n_nodes == 642 and v.n_faces == 1280
    ref = signed_volume(m.points, m.faces)
    assert abs(signed_volume(v.points, v.faces) - ref) <= 1e-11 * ref
    check_ring_contract(v, build_topology(v))


def test_reversed_faces_come_back_outward(caplog):
    m = icosphere(162)
    rev = m.faces[:, ::-1]
    assert signed_volume(m.points, rev) < 0
    with caplog.at_level(logging.INFO, logger="cortex_ti.surface"):
        v = validate_mesh(m.points, rev)
    assert signed_volume(v.points, v.faces) == pytest.approx(signed_volume(m.points, m.faces), rel=1e-14)
    assert signed_volume(v.points, v.faces) > 0
    assert "reversed" in caplog.text


def test_unreferenced_points_dropped_with_warning(caplog):
    m = icosphere(42)
    pts = np.vstack([[[5.0, 5.0, 5.0]], m.points, [[7.0, 0.0, 0.0]]])
    with caplog.at_level(logging.WARNING, logger="cortex_ti.surface"):
        v = validate_mesh(pts, m.faces + 1)
    assert v.n_nodes == 42
    assert np.array_equal(v.points, m.points) and np.array_equal(v.faces, m.faces)
    assert "dropped 2 point(s)" in caplog.text


# ---------------------------------------------------------------------------
# bad input
# ---------------------------------------------------------------------------


def two_spheres(offset):
    a = icosphere(42)
    pts = np.vstack([a.points, a.points + offset])
    faces = np.vstack([a.faces, a.faces + a.n_nodes])
    return pts, faces


def test_error_not_closed():
    m = icosphere(162)
    with pytest.raises(MeshError, match=r"not closed: 3 boundary edge\(s\)"):
        validate_mesh(m.points, m.faces[1:])


def test_error_third_face_on_edge():
    m = icosphere(162)
    a, b, _ = m.faces[0]
    pts = np.vstack([m.points, [[3.0, 0.0, 0.0]]])
    faces = np.vstack([m.faces, [[a, b, 162]]])
    with pytest.raises(MeshError, match=r"not manifold \(edge shared by 3 faces\)") as exc:
        validate_mesh(pts, faces)
    assert f"({min(a, b)}, {max(a, b)})" in str(exc.value)


def test_error_bow_tie():
    # second sphere translated by 2 p_0, so that its node antipodal to 0 sits on node 0
    # of the first sphere: the spheres touch at one point and share one node with two fans
    a = icosphere(42)
    j = int(np.argmin(np.linalg.norm(a.points + a.points[0], axis=1)))
    assert np.linalg.norm(a.points[j] + a.points[0]) < 1e-15
    pts, faces = two_spheres(offset=2 * a.points[0])
    assert np.linalg.norm(pts[42 + j] - pts[0]) < 1e-15
    with pytest.raises(MeshError, match="not manifold at node 0: its faces form 2 separate fans"):
        validate_mesh(pts, faces)


def test_error_flipped_face():
    m = icosphere(162)
    f = m.faces.copy()
    f[7] = f[7, ::-1]
    with pytest.raises(MeshError, match="inconsistently oriented: faces") as exc:
        validate_mesh(m.points, f)
    assert "7" in str(exc.value) and "in the same direction" in str(exc.value)


def test_error_degenerate_duplicated_point():
    # node c moved onto node a: the merged face (a, b, a) repeats a node
    m = icosphere(42)
    a, b, c = m.faces[4]
    pts = m.points.copy()
    pts[c] = pts[a]
    with pytest.raises(MeshError, match="degenerate triangle") as exc:
        validate_mesh(pts, m.faces)
    assert "same node twice" in str(exc.value)


def test_error_degenerate_zero_area():
    # node c moved onto the midpoint of edge (a, b): face 4 keeps 3 nodes but has zero area
    m = icosphere(42)
    a, b, c = m.faces[4]
    pts = m.points.copy()
    pts[c] = 0.5 * (pts[a] + pts[b])
    with pytest.raises(MeshError, match="degenerate triangle.*near-zero area: face 4 ") as exc:
        validate_mesh(pts, m.faces)
    assert "mean face area" in str(exc.value)


def test_error_repeated_index_in_face():
    m = icosphere(42)
    f = m.faces.copy()
    f[9] = [f[9, 0], f[9, 0], f[9, 1]]
    with pytest.raises(MeshError, match="degenerate triangle.*face 9 .*same node twice"):
        validate_mesh(m.points, f)


def test_error_duplicate_face():
    m = icosphere(42)
    f = np.vstack([m.faces, m.faces[[5]]])
    with pytest.raises(MeshError, match="duplicate face.*faces 5 and 80"):
        validate_mesh(m.points, f)


def test_error_two_disjoint_spheres():
    pts, faces = two_spheres(offset=np.array([3.0, 0.0, 0.0]))
    with pytest.raises(MeshError, match="has 2 separate surfaces .*42, 42.*cortex-ti simulates one closed surface"):
        validate_mesh(pts, faces)


def test_error_nan_point():
    m = icosphere(42)
    pts = m.points.copy()
    pts[17, 1] = np.nan
    with pytest.raises(MeshError, match=r"1 non-finite point\(s\).*node 17"):
        validate_mesh(pts, m.faces)


def test_error_zero_volume():
    # a square covered twice, with different diagonals: closed, manifold, oriented, flat
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    faces = np.array([[0, 1, 2], [0, 2, 3], [1, 0, 3], [3, 2, 1]])
    with pytest.raises(MeshError, match="encloses no volume"):
        validate_mesh(pts, faces)


@pytest.mark.parametrize(
    "faces,pattern",
    [
        (np.array([[0, 1, 2, 3]]), "only triangles"),
        (np.array([[0, 1, 99]]), "out of range"),
        (np.array([[0.0, 1.5, 2.0]]), "integer node indices"),
        (np.zeros((0, 3), dtype=int), "no triangles"),
        ([[0, 1, 2], [0, 1]], "faces"),
    ],
)
def test_error_bad_face_arrays(faces, pattern):
    pts = np.eye(3)
    with pytest.raises(MeshError, match=pattern):
        validate_mesh(pts, faces, name="x.obj")


def test_error_bad_points_shape():
    with pytest.raises(MeshError, match=r"shape \(N, 3\)"):
        validate_mesh(np.zeros((4, 2)), [[0, 1, 2]])


def test_error_message_names_the_file(tmp_path):
    m = icosphere(42)
    path = tmp_path / "cell.obj"
    meshio.write(str(path), meshio.Mesh(m.points, [("triangle", m.faces[1:])]))
    with pytest.raises(MeshError, match=r"mesh '.*cell\.obj' is not closed: 3 boundary edge"):
        load_mesh(path)


def test_load_missing_file(tmp_path):
    with pytest.raises(MeshError, match="mesh file '.*nothere.obj' does not exist"):
        load_mesh(tmp_path / "nothere.obj")


@pytest.mark.parametrize(
    "fname,content", [("cell.qqq", "hello"), ("cell.vtu", "<not xml"), ("cell.ply", "ply\ngarbage\n")]
)
def test_load_unreadable_file(tmp_path, fname, content):
    path = tmp_path / fname
    path.write_text(content)
    with pytest.raises(MeshError, match=f"cannot read mesh file '.*{fname}'"):
        load_mesh(path)


def test_load_non_triangle_cells(tmp_path):
    m = icosphere(42)
    quads = np.array([[0, 1, 2, 3]])
    path = tmp_path / "mixed.vtu"
    meshio.write(str(path), meshio.Mesh(m.points, [("triangle", m.faces), ("quad", quads)]))
    with pytest.raises(MeshError, match=r"non-triangle cells \(1 quad\)"):
        load_mesh(path)
    path = tmp_path / "lines.vtu"
    meshio.write(str(path), meshio.Mesh(m.points, [("line", np.array([[0, 1], [1, 2]]))]))
    with pytest.raises(MeshError, match=r"non-triangle cells \(2 line\)"):
        load_mesh(path)


def test_load_no_triangles(tmp_path):
    path = tmp_path / "points.obj"
    path.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
    with pytest.raises(MeshError, match="contains no triangles"):
        load_mesh(path)


# ---------------------------------------------------------------------------
# affine
# ---------------------------------------------------------------------------


def test_affine_shear_keeps_volume_and_topology():
    m = icosphere(642)
    shear = np.array([[1.0, 0.0, 0.75], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    s = affine(m, shear, offset=(0.5, -1.0, 2.0))
    assert np.allclose(s.points[:, 0], m.points[:, 0] + 0.75 * m.points[:, 2] + 0.5, atol=1e-15)
    v0, v1 = signed_volume(m.points, m.faces), signed_volume(s.points, s.faces)
    assert abs(v1 - v0) <= 1e-12 * v0
    assert np.array_equal(s.faces, m.faces)
    t0, t1 = build_topology(m), build_topology(s)
    assert np.array_equal(t0.ring, t1.ring) and np.array_equal(t0.ring2, t1.ring2)
    assert s.points.dtype == np.float64 and s.faces.dtype == np.int32


def test_affine_reflection_stays_outward():
    m = icosphere(162)
    r = affine(m, np.diag([-1.0, 2.0, 1.0]))
    v = signed_volume(r.points, r.faces)
    assert v == pytest.approx(2 * signed_volume(m.points, m.faces), rel=1e-13)
    assert v > 0
    p = r.points[r.faces]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    assert np.all(np.einsum("ij,ij->i", normal, p.mean(axis=1)) > 0)
    check_ring_contract(r, build_topology(r))
    # validate_mesh agrees: nothing to flip
    assert np.array_equal(validate_mesh(r.points, r.faces).faces, r.faces)


def test_affine_singular_matrix():
    with pytest.raises(MeshError, match="singular"):
        affine(icosphere(42), np.diag([1.0, 1.0, 0.0]))
    with pytest.raises(MeshError, match="3x3"):
        affine(icosphere(42), np.eye(2))
