"""The per-triangle normal form of ``rayleigh_p1`` (bending viscosity, semi-implicit tension) against
its definition: ``B_T`` is the corner mean of ``B^cd e_c e_d`` projected on the triangle and clipped to
its positive semidefinite part, and the force of :func:`~cortex_ti.physics.p1_blocks.normal_form_force`
is the blocks of :func:`~cortex_ti.physics.p1_blocks.normal_blocks` applied to the rate. The truths are
computed here with numpy's dense eigendecomposition and matrix products; the bounds are round-off
(a few ulp of the entries, 1e-12 relative)."""

import numpy as np
import pytest

from cortex_ti.physics.p1_blocks import _triangle_form, normal_blocks, normal_form_force
from cortex_ti.scene import load_scene
from cortex_ti.simulation import Simulation
from cortex_ti.surface.transport import triangle_gradients


@pytest.fixture(scope="module")
def shape():
    sim = Simulation(load_scene("furrow_p4_a1", ["mesh.nodes=162"]))
    rng = np.random.default_rng(3)
    x = sim.state0.points + 0.02 * rng.standard_normal(sim.state0.points.shape)  # no symmetry left
    geo = sim.shape_geometry(x)
    area, tnormal, grads = triangle_gradients(x, sim.mesh.faces)
    return geo, sim.mesh.faces, area, tnormal, grads, rng


@pytest.mark.parametrize("shift", [3.0, 0.0, -3.0])  # definite, indefinite (some clipped), negative (all)
def test_the_triangle_form_is_the_clipped_projected_corner_mean(shape, shift):
    geo, faces, _, tnormal, _, rng = shape
    b = shift * geo.metric_inv + 0.5 * rng.standard_normal(geo.metric_inv.shape)
    b = 0.5 * (b + b.transpose(0, 2, 1))
    e = geo.tangents
    mean = np.einsum("vci,vcd,vdj->vij", e, b, e)[faces].mean(axis=1)
    proj = np.eye(3) - np.einsum("ti,tj->tij", tnormal, tnormal)
    w, vec = np.linalg.eigh(proj @ mean @ proj)
    truth = np.einsum("tia,ta,tja->tij", vec, np.clip(w, 0.0, None), vec)
    got = _triangle_form(geo, faces, b, tnormal)
    scale = np.abs(mean).max()
    assert np.abs(got - truth).max() < 1e-12 * scale
    assert np.abs(np.einsum("tij,tj->ti", got, tnormal)).max() < 1e-12 * scale  # in the plane
    clipped = (w < -1e-12 * scale).any(axis=1)
    assert clipped.any() if shift < 3.0 else not clipped.any()  # the case tests what it says


def test_the_normal_force_is_the_blocks_applied_to_the_rate(shape):
    geo, faces, area, tnormal, grads, rng = shape
    b = 0.5 * geo.metric_inv + 0.3 * rng.standard_normal(geo.metric_inv.shape)
    b = 0.5 * (b + b.transpose(0, 2, 1))
    rate = rng.standard_normal(geo.normal.shape)
    blocks = normal_blocks(geo, faces, b, tnormal, grads, area)  # (T, 9, 9)
    truth = np.einsum("tij,tj->ti", blocks, rate[faces].reshape(-1, 9))
    got = normal_form_force(geo, faces, b, tnormal, grads, area, rate)
    assert np.abs(got - truth).max() < 1e-12 * np.abs(truth).max()
