"""The spectrum of a mesh of two bodies (after a division) and ARPACK's eigenvalues against the dense ones.

Two bodies without a surrounding fluid do not interact, and each has its own volume constraint and
rigid-motion gauge (cortex_ti/simulation/bodies.py): the Jacobian of the normal dynamics of the two
is block diagonal, so its spectrum is the union of each body's alone (a consistency check of the
body-by-body linearisation against the one-body one, the code against itself).

ARPACK (``which='LR'`` and ``'SR'``, :data:`cortex_ti.simulation.modes.ARPACK_TOL`) against LAPACK on
the same Jacobian: a Ritz pair is accepted when ``|J x - theta x| <= tol |theta|`` (|x| = 1), so
``|theta - lambda| <= kappa tol |theta|`` to first order (Bauer-Fike for one simple eigenvalue,
``kappa = 1 / |y^H x|`` from the left and right eigenvectors); LAPACK's own error is
``kappa u ||J||`` (backward stable), and the two multiply by one factorisation in different
orders (rounding ~cond(KKT) u in J's entries, taken as 1e-12 ||J||). The bound is ten times their sum
(docs/derivations/modes_arpack.md).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import cortex_ti as ct
from cortex_ti.dynamics.spectrum import normal_jacobian, normal_spectrum
from cortex_ti.dynamics.state import State
from cortex_ti.simulation.core import Simulation
from cortex_ti.simulation.modes import ARPACK_TOL
from cortex_ti.surface.mesh import icosphere


@pytest.fixture(scope="module")
def two():
    """A sphere and an ellipsoid of 162 nodes each, with a tension 1 + z^2 / 2 on the sphere's nodes."""
    m = icosphere(162)
    sim = Simulation(ct.load_scene("constriction_p4", ["mesh.nodes=162", "mesh.remesh.min_angle=null"]))
    a, b = m.points, m.points * np.array([0.8, 0.8, 1.3]) + 3.0
    zeta = 1.0 + 0.5 * m.points[:, 2] ** 2

    def on(x, faces, z):
        sim.use_mesh(x, faces)
        sim.state0 = State(x, {"prescribed_tension": z}, faces)
        return sim

    alone = []
    for x in (a, b):
        alone.append(np.asarray(normal_spectrum(on(x, m.faces, zeta), x, dense=True).eigenvalues))
    sim = on(np.vstack([a, b]), np.concatenate([m.faces, m.faces + 162]), np.concatenate([zeta, zeta]))
    assert sim.bodies is not None and len(sim.bodies) == 2
    return sim, alone


def test_two_bodies_have_the_union_of_their_spectra(two):
    sim, alone = two
    both = np.asarray(normal_spectrum(sim, sim.mesh.points, dense=True).eigenvalues)
    union = np.concatenate(alone)
    assert both.size == union.size == 324
    scale = np.abs(union).max()
    np.testing.assert_allclose(np.sort_complex(both), np.sort_complex(union), rtol=0, atol=1e-10 * scale)


def test_arpack_finds_the_dense_growing_and_stiffest_eigenvalues(two):
    sim, _ = two
    jd = normal_jacobian(sim, sim.mesh.points).dense()
    w, vl, vr = scipy.linalg.eig(jd, left=True, right=True)
    kappa = 1.0 / np.abs(np.einsum("ij,ij->j", vl.conj(), vr))  # columns of unit norm
    norm = np.linalg.norm(jd, 2)
    for which, count in (("LR", 4), ("SR", 2)):
        got = np.asarray(
            normal_spectrum(sim, sim.mesh.points, k=count + 4, dense=False, which=which, tol=ARPACK_TOL).eigenvalues
        )
        got = got[:count] if which == "LR" else got[-count:]
        for theta in got:
            j = int(np.argmin(np.abs(w - theta)))
            bound = 10 * kappa[j] * (ARPACK_TOL * abs(theta) + 1e-12 * norm)
            assert abs(theta - w[j]) <= bound, (which, theta, w[j], bound)
        # and they are the ends of the spectrum asked for
        ends = np.sort(w.real)[::-1][:count] if which == "LR" else np.sort(w.real)[:count]
        np.testing.assert_allclose(np.sort(got.real), np.sort(ends), rtol=1e-6, atol=1e-9 * norm)
