"""The remeshing that keeps a plane of mirror symmetry (cortex_ti.surface.mirror, mesh.remesh.mirror):
the curved remeshing of a mirror-symmetric surface is mirror-symmetric to round-off (its nodes map onto
its nodes, the curved volumes on the two sides of the plane are equal), where the whole surface's
remeshing is not; the result is one closed surface of curved cells with corner triangles of the
usual quality."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from cortex_ti.surface.curved import p2_cells
from cortex_ti.surface.curved_division import curved_side_volumes
from cortex_ti.surface.curved_remesh import corner_mesh, curved_volume, remesh_curved
from cortex_ti.surface.division import euler_characteristic
from cortex_ti.surface.measures import area_centroid, min_angles
from cortex_ti.surface.remesh import RemeshOptions, remesh_available
from tests.dumbbell_tools import dumbbell

pytestmark = pytest.mark.skipif(not remesh_available(), reason="needs mmgpy (the remesh extra)")

AXIS = np.array([0.0, 0.0, 1.0])
OPTIONS = RemeshOptions(nodes=642, min_angle=25.0, h_min=0.04, h_max=0.3)


def _split(x, f):
    lo, hi = curved_side_volumes(x, f, area_centroid(x, f), AXIS)
    return abs(lo - hi) / (lo + hi)


def _mirror_gap(x, f):
    """The largest distance of a node's mirror image (about the area centroid's plane) from a node."""
    c = area_centroid(x, f)
    image = x - 2.0 * np.outer((x - c) @ AXIS, AXIS)
    return float(cKDTree(x).query(image)[0].max())


@pytest.fixture(scope="module")
def meshes():
    """A dumbbell (neck 0.3) remeshed twice with the mirror (the first makes it symmetric) and once
    without, from the symmetric one (~2 CPU s)."""
    p, f = dumbbell(642, neck=0.3, width=0.6)
    first = remesh_curved(p, f, options=OPTIONS, mirror=AXIS)
    second = remesh_curved(first.points, first.faces, options=OPTIONS, mirror=AXIS)
    whole = remesh_curved(first.points, first.faces, options=OPTIONS)
    return first, second, whole


def test_the_mirrored_remeshing_is_symmetric_to_round_off(meshes):
    first, second, whole = meshes
    for r in (first, second):
        assert _mirror_gap(r.points, r.faces) < 1e-12
    # from a symmetric surface: the sides' curved volumes equal to round-off (measured 1e-16)
    assert _split(second.points, second.faces) < 1e-13
    # the whole surface's MMG mesh is not symmetric: it splits the volume at ~1e-6 - 1e-5 (measured)
    assert _split(whole.points, whole.faces) > 1e-9
    assert _mirror_gap(whole.points, whole.faces) > 1e-3


def test_the_mirrored_remeshing_is_one_closed_surface_of_good_cells(meshes):
    first, second, _ = meshes
    for r in (first, second):
        assert p2_cells(r.faces).shape[0] * 4 == len(r.faces)
        assert euler_characteristic(r.faces) == 2 and curved_volume(r.points, r.faces) > 0.0
        corners, tri = corner_mesh(r.points, r.faces)
        # MMG's floor on the half (25 deg), its boundary nodes put back on the plane (< 3e-4 R0)
        assert float(min_angles(corners, tri).min()) > 24.0
        assert abs(len(r.points) / 642 - 1.0) < 0.3  # the budget: half the nodes on each half
