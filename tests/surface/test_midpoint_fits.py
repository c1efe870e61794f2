"""The curved cells' midpoints fitted through midpoints only (``StencilChooser(..., apart=...)``, what
``rayleigh_p2`` with the quartic fit uses: why, in :mod:`cortex_ti.physics.galerkin_p2`, "the
corner-midpoint mode").

Truths used here, none taken from the code under test:

* the property the stencils are for: moving the cells' corners (every corner by eps along the radius)
  leaves the midpoints' fitted surface unchanged, where a stencil of all nodes turns their mean
  curvature by ~eps / h^2 (largest: 111 eps and 424 eps at 642 / 2562 nodes, a factor 3.8 per
  refinement: the h^-2 of a mesh-scale bump); with the midpoints apart it moves by < 1e-2 eps (the
  tangent frame still leans on the corners; measured 4.6e-3 eps and 1.1e-3 eps);
* a sphere of radius R: ``C = 2 / R`` at every node; the quartic fit through the midpoints' wider stencil
  stays third order or better (error ratio > 6 per halving of h; measured 1.65e-3 / 9.4e-5 at 642 / 2562
  nodes, ratio 17.6, against 1.1e-3 / 8.1e-5 with all nodes: the wider stencil costs 1.2-1.5x).
"""

from __future__ import annotations

import numpy as np
import pytest

from cortex_ti.surface.curved import midpoint_mask
from cortex_ti.surface.fits import FIT_SCHEMES, StencilChooser
from cortex_ti.surface.geometry import compute_geometry
from cortex_ti.surface.mesh import icosphere
from cortex_ti.surface.topology import build_topology

pytestmark = pytest.mark.usefixtures("taichi_runtime")


def _sphere(n):
    m = icosphere(n)
    return m, build_topology(m), midpoint_mask(m.faces, n)


def test_the_midpoints_stencils_hold_midpoints_only_and_the_corners_keep_theirs():
    m, topo, mid = _sphere(642)
    assert mid.sum() == 480 and not mid[:162].any()  # the 480 edges of the 162-node sphere; its nodes come first
    plain = StencilChooser(topo, "quartic").arrays()
    rows, size = StencilChooser(topo, "quartic", mid, m.points).arrays()
    for i in range(642):
        r = rows[i, : size[i]]
        if mid[i]:
            assert mid[r].all() and i not in r
            assert size[i] == StencilChooser.APART_SIZE > FIT_SCHEMES["quartic"].n_terms  # 16 for 14 monomials
        else:
            np.testing.assert_array_equal(r, plain[0][i, : plain[1][i]])


@pytest.fixture(scope="module")
def dents():
    """Per node count and stencil: the midpoints' largest change of mean curvature per eps when every
    corner moves in by eps, and the largest error of the fitted mean curvature on the unit sphere."""
    out = {}
    for n in (642, 2562):
        m, topo, mid = _sphere(n)
        eps = 1e-6
        moved = m.points - eps * (~mid)[:, None] * m.points
        for name, apart in (("all", None), ("apart", mid)):
            ch = StencilChooser(topo, "quartic", apart, m.points)
            g0 = compute_geometry(m.points, topo, ch, operators=False)
            g1 = compute_geometry(moved, topo, ch, operators=False)
            turn = np.abs(g1.mean_curvature - g0.mean_curvature)[mid].max() / eps
            out[n, name] = (turn, np.abs(g0.mean_curvature - 2.0)[mid].max())
    return out


def test_moving_the_corners_leaves_the_midpoints_fitted_surface_alone(dents):
    assert dents[2562, "all"][0] > 200 and dents[2562, "all"][0] / dents[642, "all"][0] > 3  # ~ eps / h^2
    assert dents[642, "apart"][0] < 1e-2 and dents[2562, "apart"][0] < 1e-2


def test_the_midpoints_own_fit_keeps_the_curvature_third_order(dents):
    coarse, fine = dents[642, "apart"][1], dents[2562, "apart"][1]
    assert coarse / fine > 6.0, (coarse, fine)
