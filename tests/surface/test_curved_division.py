"""The cut of a surface of curved six-node cells into two (cortex_ti.surface.curved_division) on the
642-node dumbbell: the sides' curved volumes add to the cells' volume and the densities' amounts over
the cells to the total, to round-off; each daughter is curved cells (the split layout) of one closed
genus-0 surface enclosing its side's curved volume and holding its side's amount, with corner
triangles of the usual quality; the curved side volumes of a sphere converge to the spherical caps'
closed form, faster than the flat ones."""

from __future__ import annotations

import math

import numpy as np
import pytest

from cortex_ti.surface.curved import p2_cells
from cortex_ti.surface.curved_division import curved_side_volumes, cut_curved
from cortex_ti.surface.curved_remesh import corner_mesh, curved_masses, curved_volume
from cortex_ti.surface.division import body_labels, euler_characteristic, face_labels, side_volumes
from cortex_ti.surface.measures import min_angles
from cortex_ti.surface.mesh import icosphere
from cortex_ti.surface.remesh import RemeshOptions, remesh_available
from tests.dumbbell_tools import dumbbell

needs_mmg = pytest.mark.skipif(not remesh_available(), reason="needs mmgpy (the remesh extra)")

PLANE = (0.0, 0.0, 0.02)  # a little off the waist: the two sides differ


@pytest.fixture(scope="module")
def cut():
    """One cut of the 642-node dumbbell (neck 0.15; 160 curved cells) with a density and a property,
    remeshed to a run's options at 642 nodes (~1 CPU s)."""
    p, f = dumbbell()
    density = 1.0 + 0.5 * p[:, 0] + 0.2 * p[:, 2]
    fields, kinds = {"m": density, "q": p[:, 2].copy()}, {"m": "density", "q": "property"}
    opts = RemeshOptions(nodes=642, min_angle=25.0, h_min=0.02, h_max=0.45)
    return p, f, density, cut_curved(p, f, PLANE, (0, 0, 1), 0.1, fields, kinds, opts)


def _bodies(res):
    n, lab = body_labels(res.faces, len(res.points))
    flab = face_labels(res.faces, lab)
    for b in range(n):
        nodes = np.flatnonzero(lab == b)
        local = np.full(len(res.points), -1, dtype=np.int64)
        local[nodes] = np.arange(nodes.size)
        yield nodes, res.points[nodes], local[res.faces[flab == b]]


@needs_mmg
def test_the_curved_sides_add_to_the_whole_and_each_daughter_keeps_its_side(cut):
    p, f, density, res = cut
    whole = curved_volume(p, f)
    assert abs(sum(res.volumes) / whole - 1.0) < 1e-13  # the excesses add to curved - flat exactly
    assert abs(res.volumes[0] / res.volumes[1] - 1.0) > 1e-3  # the plane is off the waist
    total = float(curved_masses(p, f) @ density)
    assert abs(sum(res.amounts["m"]) / total - 1.0) < 1e-13
    bodies = list(_bodies(res))
    assert len(bodies) == 2
    for b, (nodes, x, faces) in enumerate(bodies):
        # the Newton offset to the side's volume (tolerance 1e-14) and keep_amount's scaling: round-off
        assert abs(curved_volume(x, faces) / res.volumes[b] - 1.0) < 1e-12
        assert abs(float(curved_masses(x, faces) @ res.fields["m"][nodes]) / res.amounts["m"][b] - 1.0) < 1e-12


@needs_mmg
def test_each_daughter_is_curved_cells_of_one_closed_surface_of_good_corners(cut):
    _, _, _, res = cut
    for _, x, faces in _bodies(res):
        assert p2_cells(faces).shape[0] * 4 == len(faces)  # the split layout (raises otherwise)
        assert euler_characteristic(faces) == 2
        assert curved_volume(x, faces) > 0.0  # outward
        corners, tri = corner_mesh(x, faces)
        assert float(min_angles(corners, tri).min()) >= 25.0  # MMG's angle floor on the corner mesh
    # the property is the old cells' interpolant: z stays within the side's range
    assert np.all(res.fields["q"][res.labels == 0] < 0.1) and np.all(res.fields["q"][res.labels == 1] > -0.1)


def test_curved_side_volumes_converge_to_the_spherical_caps():
    """The cap above z = h of the unit sphere: pi (1 - h)^2 (2 + h) / 3. The cells across the plane share
    their excess over their flat sub-triangles by area: an O(h^3) error per cell along a line of O(1/h)
    cells, second order (measured: orders 2.5 and 2.2 over 162 / 642 / 2562 nodes, 2.0 to 10242); the
    flat sides' own error is second order and 10-11 times larger."""
    h = 0.3
    exact = math.pi * (1.0 - h) ** 2 * (2.0 + h) / 3.0
    err, flat = [], []
    for n in (162, 642, 2562):
        m = icosphere(n)
        lo, hi = curved_side_volumes(m.points, m.faces, (0, 0, h), (0, 0, 1))
        assert abs(lo + hi - curved_volume(m.points, m.faces)) < 1e-13
        err.append(abs(hi - exact))
        flat.append(abs(side_volumes(m.points, m.faces, (0, 0, h), (0, 0, 1))[1] - exact))
    orders = np.log2(np.array(err[:-1]) / np.array(err[1:]))
    assert np.all(orders > 1.8)
    assert err[-1] < 0.2 * flat[-1]
    # a mirror-symmetric surface cut at its mirror plane (the equator's nodes on it) splits evenly
    m = icosphere(642)
    lo, hi = curved_side_volumes(m.points, m.faces, (0, 0, 0), (0, 0, 1))
    assert abs(lo - hi) < 1e-13
