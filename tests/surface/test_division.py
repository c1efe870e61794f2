"""The cut of a closed surface into two (cortex_ti.surface.division) on a dumbbell: the volumes and the
amounts of the two sides add to the whole to round-off, each daughter is one closed oriented surface of
genus 0 enclosing its side's volume, with triangles of the usual quality; the side volumes of a sphere
converge to the spherical caps' closed form; the bodies of a mesh are its connected components."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cortex_ti.errors import CortexError
from cortex_ti.surface.division import (
    body_labels,
    body_volumes,
    cut_at_plane,
    euler_characteristic,
    remesh_bodies,
    restore_body_volumes,
    side_volumes,
)
from cortex_ti.surface.measures import enclosed_volume, min_angles
from cortex_ti.surface.measures import enclosed_volume as enclosed_volume_about
from cortex_ti.surface.mesh import icosphere
from cortex_ti.surface.remesh import RemeshOptions, remesh_available
from cortex_ti.surface.transport import dual_areas
from tests.dumbbell_tools import dumbbell

needs_mmg = pytest.mark.skipif(not remesh_available(), reason="needs mmgpy (the remesh extra)")


@pytest.fixture(scope="module")
def cut():
    """One cut of the 642-node dumbbell (neck 0.15) a little off its waist, with a density and a
    property, remeshed to a node budget with the runs' angle floor of 25 deg."""
    p, f = dumbbell()
    density = 1.0 + 0.5 * p[:, 0] + 0.2 * p[:, 2]
    prop = p[:, 2].copy()
    fields, kinds = {"m": density, "q": prop}, {"m": "density", "q": "property"}
    opts = RemeshOptions(nodes=642, min_angle=25.0, h_min=0.02, h_max=0.45)  # a run's, sized at 642 nodes
    res = cut_at_plane(p, f, (0.0, 0.0, 0.02), (0.0, 0.0, 1.0), 0.05, fields, kinds, opts)
    return p, f, fields, res


@needs_mmg
def test_the_sides_volumes_and_amounts_add_to_the_whole(cut):
    p, f, fields, res = cut
    v = enclosed_volume(p, f)
    assert abs(sum(res.volumes) - v) <= 1e-13 * v
    total = float(fields["m"] @ dual_areas(p, f))
    assert abs(sum(res.amounts["m"]) - total) <= 1e-13 * total
    # the daughters: their volumes those of the sides, their amounts too (each and in sum)
    n, lab = body_labels(res.faces, len(res.points))
    assert n == 2 and np.array_equal(lab, res.labels)
    area = dual_areas(res.points, res.faces)
    for b in range(2):
        faces = res.faces[lab[res.faces[:, 0]] == b]
        assert abs(enclosed_volume(res.points, faces) / res.volumes[b] - 1.0) <= 1e-12
        mine = lab == b
        assert abs(float(res.fields["m"][mine] @ area[mine]) / res.amounts["m"][b] - 1.0) <= 1e-12
    assert abs(float(res.fields["m"] @ area) / total - 1.0) <= 1e-12
    # body 0 lies on the axis' negative side (its dome over the neck reaches past the plane)
    assert res.points[lab == 0, 2].mean() < -0.3 and res.points[lab == 1, 2].mean() > 0.3


@needs_mmg
def test_each_daughter_is_one_closed_genus_0_surface_of_good_triangles(cut):
    _, _, fields, res = cut
    lab = res.labels
    for b in range(2):
        faces = res.faces[lab[res.faces[:, 0]] == b]
        assert euler_characteristic(faces) == 2
        edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
        _, counts = np.unique(edges, axis=0, return_counts=True)
        assert np.all(counts == 2)  # closed and manifold
        assert enclosed_volume(res.points, faces) > 0  # outward
    assert res.min_angle >= 25.0 and float(min_angles(res.points, res.faces).min()) == res.min_angle
    # a property is interpolated, not rescaled: z stays within the old surface's range on each side
    assert res.fields["q"][lab == 0].max() < 0.2 and res.fields["q"][lab == 1].min() > -0.2


def test_side_volumes_converge_to_the_spherical_caps():
    """A unit sphere cut at z = 0.3: the cap above has pi (1-h)^2 (2+h) / 3 (the closed form), the
    icosphere's polyhedral cap converges to it at second order in the mesh size."""
    h = 0.3
    exact = math.pi * (1 - h) ** 2 * (2 + h) / 3
    errs = []
    for n in (642, 2562, 10242):
        m = icosphere(n)
        lo, hi = side_volumes(m.points, m.faces, (0, 0, h), (0, 0, 1))
        assert abs(lo + hi - enclosed_volume(m.points, m.faces)) <= 1e-13
        errs.append(abs(hi - exact))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 1.8), orders


def test_bodies_are_the_connected_components():
    m = icosphere(162)
    faces = np.concatenate([m.faces + 162, m.faces])  # the second sphere's triangles first
    n, lab = body_labels(faces, 324)
    assert n == 2 and np.all(lab[:162] == 0) and np.all(lab[162:] == 1)
    points = np.vstack([m.points, 0.5 * m.points + 3.0])
    v = body_volumes(points, faces)
    assert abs(v[1] / v[0] - 0.125) <= 1e-12
    back = restore_body_volumes(points * 1.01, faces, v)
    np.testing.assert_allclose(body_volumes(back, faces), v, rtol=1e-13)


@needs_mmg
def test_remesh_bodies_keeps_each_body_volume_and_amount():
    m = icosphere(162)
    points = np.vstack([m.points, 0.6 * m.points + 3.0])
    faces = np.concatenate([m.faces, m.faces + 162]).astype(np.int32)
    c = 1.0 + points[:, 0] ** 2
    res = remesh_bodies(points, faces, {"m": c}, {"m": "density"}, RemeshOptions(nodes=324))
    n, lab = body_labels(res.faces, len(res.points))
    assert n == 2
    np.testing.assert_allclose(body_volumes(res.points, res.faces), body_volumes(points, faces), rtol=1e-13)
    a_old, a_new = dual_areas(points, faces), dual_areas(res.points, res.faces)
    old_lab = body_labels(faces, len(points))[1]
    for b in range(2):
        old, new = float(c[old_lab == b] @ a_old[old_lab == b]), float(res.fields["m"][lab == b] @ a_new[lab == b])
        assert abs(new / old - 1.0) <= 1e-13


@needs_mmg
def test_remesh_bodies_resolves_a_small_sphere_with_as_many_nodes_as_a_large_one():
    """The budget is shared as one curvature size field over both bodies shares it: on two spheres,
    ``int kappa^2 dA = 4 pi`` whatever the radius, so equal node counts (each within the remesher's
    10 % of its share), where the areas' shares would give the sphere of radius 0.3 a tenth of the nodes."""
    m = icosphere(642)
    points = np.vstack([m.points, 0.3 * m.points + 3.0])
    faces = np.concatenate([m.faces, m.faces + 642]).astype(np.int32)
    res = remesh_bodies(points, faces, options=RemeshOptions(h_min=0.01, h_max=1.0, nodes=1284))
    n, lab = body_labels(res.faces, len(res.points))
    counts = np.bincount(lab, minlength=2)
    assert n == 2 and abs(counts[1] / counts[0] - 1.0) < 0.25, counts

    # each body's volume restored, the small one ten of its radii from the origin too (its tetrahedra
    # about the origin missed restore_volume's 1e-14 by round-off: it is taken about the nodes' mean,
    # and so measured here)
    def about_middle(x, f):
        return enclosed_volume_about(x, f, origin=x[np.unique(f)].mean(axis=0))

    new, old = body_volumes(res.points, res.faces, about_middle), body_volumes(points, faces, about_middle)
    np.testing.assert_allclose(new, old, rtol=1e-13)


def test_a_plane_away_from_any_neck_is_refused():
    p, f = dumbbell(162)
    with pytest.raises(CortexError, match="nothing on one side"):
        cut_at_plane(p, f, (0.0, 0.0, 5.0), (0.0, 0.0, 1.0), 0.05)
