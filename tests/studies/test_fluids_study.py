"""The fluids study's reading of its store (cortex_ti.studies.fluids) on a store built by hand, whose
depths, half times and speeds are known by construction, and Lamb's speed against the closed form
of a sphere translating in a fluid at equal viscosities."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from cortex_ti.studies import fluids as f
from cortex_ti.studies.figures import draw_figure

T = np.linspace(0.0, 3.0, 61)


def _store() -> xr.Dataset:
    """Five runs on one time grid (nan after a run's end):

    0, 1. furrow_in_fluid, axisymmetric and 3D, ell = 1: R_f = 1 - 0.1 (1 - e^{-t}) (3D 1e-3 deeper at the end);
    2. furrow_in_fluid, axisymmetric, ell = 10: R_f = 1 - 0.1 (1 - e^{-4 t});
    3, 4. polarised_swimmer, axisymmetric and 3D, ell = 1, to t = 1: centroid z = -0.02 t (3D: -0.0198 t + 1e-3 t^2 / 2,
       whose late slope over [0.5, 1] is -0.0198 + 1e-3 * 0.75)."""
    n = T.size
    furrow = np.full((5, n), np.nan)
    furrow[0] = 1.0 - 0.1 * (1.0 - np.exp(-T))
    furrow[1] = furrow[0] - 1e-3 * T / 3.0
    furrow[2] = 1.0 - 0.1 * (1.0 - np.exp(-4.0 * T))
    centroid = np.full((5, n), np.nan)
    short = T <= 1.0 + 1e-12
    centroid[3, short] = -0.02 * T[short]
    centroid[4, short] = -0.0198 * T[short] + 0.5e-3 * T[short] ** 2
    for i in (3, 4):
        furrow[i, short] = 1.0
    runs = {
        "scene": ["furrow_in_fluid"] * 3 + ["polarised_swimmer"] * 2,
        "model": ["axisymmetric", "3d", "axisymmetric", "axisymmetric", "3d"],
        "inner": [1.0, 1.0, 0.1, 1.0, 1.0],
        "outer": [1.0, 1.0, 0.1, 1.0, 1.0],
        "nodes": [642] * 5,
        "t_end": [3.0, 3.0, 3.0, 1.0, 1.0],
        "label": [f"run{i}" for i in range(5)],
    }
    return xr.Dataset(
        {"furrow_radius": (("run", "time"), furrow), "centroid_axial": (("run", "time"), centroid)},
        coords={
            "time": T,
            **{
                k: ("run", np.asarray(v, dtype=object if k in ("scene", "model", "label") else None))
                for k, v in runs.items()
            },
        },
    )


def test_depth_half_time_and_speed_are_read_as_constructed():
    ds = _store()
    assert f.hydrodynamic_length(ds, 2) == pytest.approx(10.0)
    assert f.depth(ds, 0) == pytest.approx(0.1 * (1.0 - math.exp(-3.0)), rel=1e-12)
    assert f.depth(ds, 1) - f.depth(ds, 0) == pytest.approx(1e-3, rel=1e-9)
    # half of the depth: 1 - e^{-t} = (1 - e^{-3}) / 2; linear between frames 0.05 apart, error <= h^2 max|R''| / 8
    exact = -math.log(1.0 - 0.5 * (1.0 - math.exp(-3.0)))
    assert f.half_time(ds, 0) == pytest.approx(exact, abs=0.05**2 * 0.1 / 8 / (0.1 * math.exp(-exact)))
    assert f.half_time(ds, 2) < f.half_time(ds, 0)  # the thinner fluids let the ring pull in faster
    assert f.swim_speed(ds, 3) == pytest.approx(-0.02, rel=1e-12)
    assert f.swim_speed(ds, 4) == pytest.approx(-0.0198 + 0.75e-3, rel=1e-9)
    assert math.isnan(f.half_time(ds, 3))  # the swimmer's furrow does not move


def test_numbers_and_figure_pair_each_3d_run_with_its_twin(tmp_path):
    ds = _store()
    table = f.fluids_numbers([ds]).set_index("run")
    assert float(table.loc["run1", "depth - twin's"]) == pytest.approx(1e-3, rel=1e-3)
    ratio = (-0.0198 + 0.75e-3) / -0.02 - 1.0
    assert float(table.loc["run4", "speed / twin's - 1"]) == pytest.approx(ratio, rel=1e-3)
    path = tmp_path / "fluids.nc"
    ds.to_netcdf(path, engine="h5netcdf")
    fig = draw_figure("fluids", [path], {})  # as the workflow's figure rule draws it
    assert len(fig.axes) == 4  # three panels and the half time's axis


def test_lamb_speed_scales_with_every_viscosity():
    """Every viscosity (the surface's and both fluids') times c divides every velocity by c, exactly (the
    force balance is linear and homogeneous in them); the cell swims away from the high-tension pole,
    slower in thicker fluids. The scene's value (-0.023267, docs/validation/fluids.md) is a regression."""
    base = f.lamb_speed(1.0, 1.0)
    assert f.lamb_speed(10.0, 10.0, eta_s=10.0, eta_b=10.0) * 10.0 == pytest.approx(base, rel=1e-12)
    assert f.lamb_speed(0.5, 2.0, eta_s=3.0, eta_b=0.7) == pytest.approx(
        4.0 * f.lamb_speed(2.0, 8.0, eta_s=12.0, eta_b=2.8), rel=1e-12
    )
    assert base < 0.0 and abs(f.lamb_speed(10.0, 10.0)) < abs(base)
    assert base == pytest.approx(-0.023267, abs=1e-6)


def test_swimmer_drive_is_the_scenes_degree_one_tension():
    """Lamb's line is drawn for the scene's own tension: the Y_10 projection of its patterns (the
    orthonormal harmonic recovers the scene's coefficient, 0.5, and the uniform ring adds nothing; a
    quadrature error, ~1e-13), and its viscosities. The projection is about the axis it is taken on: Y_11
    (x) has none about +z and all of it about +x."""
    drive = f.swimmer_drive("polarised_swimmer")
    assert drive["coeff"] == pytest.approx(0.5, abs=1e-10)
    assert (drive["eta_s"], drive["eta_b"]) == (1.0, 1.0)
    from cortex_ti.physics.patterns import integrate_patterns

    tilted = [{"type": "harmonics", "terms": [{"l": 1, "m": 1, "coeff": 0.3}]}]
    # Y_11 is sqrt(3 / 4 pi) x: its projection on Y_10 about +z vanishes, about +x it is the coefficient
    y10 = (3.0 / (4.0 * np.pi)) ** 0.5
    assert abs(integrate_patterns(tilted, weight=lambda p: y10 * p[:, 2])) < 1e-12
    assert integrate_patterns(tilted, weight=lambda p: y10 * p[:, 0]) == pytest.approx(0.3, abs=1e-10)
