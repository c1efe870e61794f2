"""Pinch-off on the meridian (cortex_ti.axisymmetric.division): the cut conserves the volume and
splits the material at the neck, the daughters are closed profiles, a run crosses a cut, and a scene
refuses a neck radius its points do not resolve.

The invariants are independent of the cut's construction: the mother's volume by its own spectral
quadrature (the daughters' by theirs, on other points), the closed profiles by the bases' parity
(r = 0 at both poles exactly, checked on the interpolant), the material split at the neck's label.
"""

from __future__ import annotations

import numpy as np
import pytest

from cortex_ti.axisymmetric.balance import ForceBalance, check_gauge, check_visc
from cortex_ti.axisymmetric.division import cut, resolution_floor, simulate_division, spectral_volume
from cortex_ti.axisymmetric.dynamics import Dynamics
from cortex_ti.axisymmetric.spectral import Spectral

VISC = dict(eta_s=1.0, eta_b=1.0, eta_bar=0.0, eta_bar_b=0.0)
ND = 64  # the daughters' points


def _dumbbell(n: int, symmetric: bool, shift: float = 0.0):
    """A smooth meridian with a neck of radius about 0.05 at the label pi/2 + shift (a sphere pinched
    by a Gaussian waist), with its label, and its adaptive-point dynamics."""
    sp = Spectral(n, symmetric)
    u = sp.u
    waist = 1.0 - 0.95 * np.exp(-((u - np.pi / 2 - shift) ** 2) / 0.08)
    waist_s = 1.0 - 0.95 * np.exp(-((np.pi - u - np.pi / 2 - shift) ** 2) / 0.08)  # even about the equator
    r = np.sin(u) * (waist if not symmetric else 0.5 * (waist + waist_s))
    z = 1.3 * np.cos(u)
    phys = check_visc(**VISC, radius=1.0, kappa=0.01)
    dyn = Dynamics(sp, ForceBalance(sp, phys, check_gauge("velocity")), lambda t: 1.0 + 0.0 * t, "adaptive")
    return dyn, np.concatenate([r, z, u.copy()])


@pytest.fixture(scope="module")
def cuts():
    out = {}
    for name, (n, sym, shift) in {"symmetric": (32, True, 0.0), "off-equator": (64, False, 0.15)}.items():
        dyn, y = _dumbbell(n, sym, shift)
        out[name] = (dyn, y, cut(dyn, y, ND))
    return out


@pytest.mark.parametrize("name", ["symmetric", "off-equator"])
def test_the_cut_conserves_the_volume_and_yields_two_closed_profiles(cuts, name):
    dyn, y, (north, south) = cuts[name]
    mother = spectral_volume(dyn.sp, y)
    # each daughter's own quadrature on its own ND points; the two add up to the mother's (its
    # quadrature on its points) to round-off: the shares are matched to 1e-15 by the joint's root
    assert abs(north.volume + south.volume - mother) <= 1e-13 * mother
    for d in (north, south):
        assert abs(d.volume - d.target) <= 1e-13 * mother
        sp = Spectral(ND, False)
        r_poles = sp.evaluate("R", d.y[:ND], [0.0, np.pi])
        assert np.all(np.abs(r_poles) < 1e-14)  # the profile reaches the axis at both ends
        sig = np.linspace(0.0, np.pi, 2001)[1:-1]
        assert sp.evaluate("R", d.y[:ND], sig).min() > 0.0  # and nowhere in between
        lam = d.y[2 * ND :]
        assert lam[0] > 0.0 and lam[-1] < np.pi and np.all(np.diff(lam) > 0)  # a label map that does not fold
    # the material splits at the neck's label: the north daughter carries [0, u_n], the south [u_n, pi]
    assert north.labels[0] == 0.0 and south.labels[1] == np.pi
    assert north.labels[1] == pytest.approx(south.labels[0], abs=1e-14)
    assert north.mother_label(np.pi) == pytest.approx(north.labels[1], abs=1e-14)
    # the north daughter lies above the neck, the south below
    assert north.y[ND : 2 * ND].min() > south.y[ND : 2 * ND].max() - 0.1


def test_the_symmetric_cut_gives_equal_daughters(cuts):
    _, _, (north, south) = cuts["symmetric"]
    assert north.volume == pytest.approx(south.volume, rel=1e-13)
    assert north.labels[1] == pytest.approx(np.pi / 2, abs=1e-13)  # the neck at the equator's material
    np.testing.assert_allclose(north.y[:ND], south.y[:ND][::-1], atol=1e-12)  # mirror images


def test_the_off_equator_cut_gives_the_larger_share_to_the_larger_lobe(cuts):
    _, _, (north, south) = cuts["off-equator"]
    assert north.labels[1] > np.pi / 2  # the waist below the equator: the north lobe is the larger
    assert north.volume > south.volume


@pytest.mark.slow
def test_a_run_crosses_a_cut_and_the_daughters_round_up():
    """A symmetric ring with rigidity at n = 24 to a neck of 0.1 (t = 1.2003), cut, the daughters
    evolved to t = 1.35 at 48 points: two bodies, their volumes kept by their incompressibility
    to the integrator's tolerance (measured 3e-10), each rounder at the end than at the cut (the
    spread of the distance from the centroid 0.155 -> 0.095). (n = 32 to a neck of 0.05 took 1.6x
    the time for the same checks.)"""
    ring = lambda th: 1.0 + 20.0 * np.exp(-10.0 * np.abs(np.asarray(th, dtype=float) - np.pi / 2) ** 4)  # noqa: E731
    res = simulate_division(
        ring,
        neck_radius=0.1,
        t_end=1.35,
        save_times=np.linspace(0.0, 1.35, 28),
        n=24,
        daughter_n=48,
        **VISC,
        kappa=0.01,
        rtol=1e-7,
        interpolate=True,
    )
    info = res.cut_info
    assert res.n_bodies[0] == 1 and res.n_bodies[-1] == 2
    assert info["neck"] == pytest.approx(0.1, abs=1e-9)
    assert sum(info["volumes"]) == pytest.approx(info["mother_volume"], rel=1e-13)
    v = res.body_volume
    assert np.all(np.isnan(v[res.n_bodies == 1, 1]))
    # incompressible daughters: Radau at rtol 1e-7 keeps each volume to ~1e-6 (measured 1e-8)
    np.testing.assert_allclose(
        v[res.n_bodies == 2], np.tile(info["volumes"], (int((res.n_bodies == 2).sum()), 1)), rtol=1e-6
    )
    for d in res.daughters:
        assert d.t[-1] == pytest.approx(1.35)
        spread = [np.ptp(np.hypot(d.r[i], d.z[i] - d.z_centroid[i])) for i in (0, -1)]
        assert spread[1] < 0.9 * spread[0]  # rounder: the distance from the centroid varies less


def test_division_below_the_resolution_is_refused():
    with pytest.raises(ValueError, match="below what 24 meridian points resolve") as err:
        simulate_division(
            lambda t: 1.0 + 0.0 * t,
            neck_radius=0.5 * resolution_floor(24),
            t_end=1.0,
            save_times=[0.0, 1.0],
            n=24,
            **VISC,
        )
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    "division,n,message",
    [
        ({"neck_radius": 1e-3}, 48, "division.neck_radius = 0.001 is below what axisymmetric.n = 48 points resolve"),
        ({"neck_radius": 1.5}, 48, "must be smaller than mesh.radius"),
    ],
)
def test_the_scene_refuses_an_unresolved_neck_radius(division, n, message):
    from cortex_ti.errors import SceneError
    from cortex_ti.scene import load_scene

    with pytest.raises(SceneError, match=message) as err:
        load_scene(
            "constriction_p4",
            overrides=[
                "model=axisymmetric",
                "mesh.remesh.min_angle=null",
                f"axisymmetric.n={n}",
                f"division.neck_radius={division['neck_radius']}",
            ],
        )
    assert "\n" not in str(err.value)
    ok = load_scene(
        "constriction_p4", overrides=["model=axisymmetric", "mesh.remesh.min_angle=null", "division.neck_radius=0.01"]
    )
    assert ok.settings.division_neck == 0.01
