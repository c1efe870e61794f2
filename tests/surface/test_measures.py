"""The flat-triangle measures (cortex_ti.surface.measures) against closed forms: the unit
tetrahedron ``(0, e_x, e_y, e_z)`` has volume 1/6, area ``3/2 + sqrt(3)/2`` and faces of area
1/2 (three) and ``sqrt(3)/2`` (the slanted one); the enclosed volume of a closed surface does not
depend on the origin the corners are taken relative to (divergence theorem)."""

import math

import numpy as np
import pytest

from cortex_ti.surface.measures import area_centroid, enclosed_volume, face_areas, surface_area, volume_centroid
from cortex_ti.surface.mesh import icosphere

POINTS = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
FACES = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # outward


def test_face_areas_and_area_of_the_unit_tetrahedron():
    np.testing.assert_allclose(face_areas(POINTS, FACES), [0.5, 0.5, 0.5, math.sqrt(3) / 2], rtol=1e-15)
    assert surface_area(POINTS, FACES) == pytest.approx(1.5 + math.sqrt(3) / 2, rel=1e-15)


@pytest.mark.parametrize("origin", [None, (0.0, 0.0, 0.0), (5.0, -3.0, 2.0)])
def test_the_enclosed_volume_is_one_sixth_about_any_origin(origin):
    assert enclosed_volume(POINTS, FACES, origin=origin) == pytest.approx(1.0 / 6.0, rel=1e-14)


def test_inward_faces_give_a_negative_volume():
    assert enclosed_volume(POINTS, FACES[:, ::-1]) == pytest.approx(-1.0 / 6.0, rel=1e-14)


def test_the_area_centroid_weights_each_face_by_its_area():
    centroids = POINTS[FACES].mean(axis=1)
    a = np.array([0.5, 0.5, 0.5, math.sqrt(3) / 2])
    np.testing.assert_allclose(area_centroid(POINTS, FACES), a @ centroids / a.sum(), rtol=1e-14)


def test_volume_centroid_of_a_tetrahedron_and_of_a_moved_symmetric_polyhedron():
    """A tetrahedron's volume centroid is the mean of its corners; an icosphere's (symmetric under
    x -> -x) moved by d and stretched about it has its centroid at d, to round-off."""
    pts = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) * 2.0 + 0.5
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    np.testing.assert_allclose(volume_centroid(pts, faces), pts.mean(axis=0), atol=1e-15)
    m = icosphere(642)
    moved = m.points * np.array([1.5, 1.0, 0.7]) + np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(volume_centroid(moved, m.faces), [0.1, -0.2, 0.3], atol=1e-14)
