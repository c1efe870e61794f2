"""The cytokinesis study's reading of its store (cortex_ti.studies.cytokinesis) on a store built by
hand, whose outcomes, cut times, volume ratios and late-time law are known by construction; and the
volume split at a plane (cortex_ti.surface.division.side_volumes, which the store reads) on a cube, exact
for flat faces."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr
from scipy.spatial import ConvexHull

from cortex_ti.studies import cytokinesis as c
from cortex_ti.surface.division import side_volumes

# run 0's law: neck = A (t_p - t)^a, cut at the neck 0.1
A, TP, EXP, CUT = 0.5, 1.0, 1.5, 0.1
T_CUT = TP - (CUT / A) ** (1.0 / EXP)
T = np.union1d(np.linspace(0.0, T_CUT, 200), np.linspace(0.0, 3.0, 61))


def _store() -> xr.Dataset:
    """Four runs on one time grid (nan after a run's end):

    0. axisymmetric, neck A (t_p - t)^a, stops at its cut (neck 0.1) at T_CUT before t_end: complete;
       equal sides (2, 2): symmetric;
    1. axisymmetric, the neck levels off at 0.3 and the run reaches t_end = 3: failed;
    2. 3D, one body to t = 1, two (2.2 above, 1.8 below) from t = 1.05 to t_end = 2: complete,
       cut at 1.05, ratio 2.2 / 1.8: slipping;
    3. 3D, one body to t_end = 2 with a neck of 0.5: failed."""
    n = T.size
    nan = math.nan
    neck, bodies = np.full((4, n), nan), np.full((4, n), nan)
    up, down = np.full((4, n), nan), np.full((4, n), nan)
    first = T <= T_CUT + 1e-12
    neck[0, first] = A * (TP - T[first]) ** EXP
    neck[0, np.flatnonzero(first)[-1]] = CUT  # the run stops at its cut
    up[0, first], down[0, first] = 2.0, 2.0
    lobe = np.full((4, n), nan)  # run 0's lobe rate 2 + 3 t at every 10th frame and the last
    at = np.r_[np.flatnonzero(first)[::10], np.flatnonzero(first)[-1]]
    lobe[0, at] = 2.0 + 3.0 * T[at]
    neck[1] = 0.3 + 0.7 * np.exp(-3.0 * T)
    up[1], down[1] = 2.0, 2.0
    two = T <= 2.0 + 1e-12
    neck[2, two] = np.maximum(0.9 - 0.8 * T[two], 0.1)
    bodies[2, two] = np.where(T[two] > 1.0 + 1e-12, 2.0, 1.0)
    up[2, two], down[2, two] = np.where(bodies[2, two] > 1, 2.2, 2.05), np.where(bodies[2, two] > 1, 1.8, 1.95)
    neck[3, two], bodies[3, two] = 0.5, 1.0
    up[3, two], down[3, two] = 2.0, 2.0
    volume = np.where(np.isfinite(neck), 4.0, nan)
    runs = {
        "scene": ["constriction_rigid", "constriction_p4", "cytokinesis_rigid", "cytokinesis"],
        "model": ["axisymmetric", "axisymmetric", "3d", "3d"],
        "zeta_hat": [30.0, 3.0, 30.0, 12.0],
        "bending": [0.1, 0.0, 0.1, 0.0],
        "neck": [CUT, CUT, CUT, CUT],
        "nodes": [2562, 2562, 642, 642],
        "t_end": [5.0, 3.0, 2.0, 2.0],
        "label": [f"run{i}" for i in range(4)],
    }
    return xr.Dataset(
        {
            "neck_radius": (("run", "time"), neck),
            "n_bodies": (("run", "time"), bodies),
            "volume": (("run", "time"), volume),
            "volume_upper": (("run", "time"), up),
            "volume_lower": (("run", "time"), down),
            "lobe_rate": (("run", "time"), lobe),
        },
        coords={"time": T, "run": np.arange(4), **{k: ("run", np.asarray(v)) for k, v in runs.items()}},
    )


@pytest.fixture(scope="module")
def store():
    return _store()


def test_outcomes_and_cut_times(store):
    assert [c.divided(store, i) for i in range(4)] == [True, False, True, False]
    assert c.cut_time(store, 0) == pytest.approx(T_CUT, abs=1e-12)
    assert c.cut_time(store, 2) == pytest.approx(1.05, abs=1e-12)  # the first two-body frame
    assert math.isnan(c.cut_time(store, 1)) and math.isnan(c.cut_time(store, 3))


def test_volume_ratio_symmetric_or_slipping(store):
    assert c.volume_ratio(store, 0) == 1.0
    assert c.volume_ratio(store, 2) == pytest.approx(2.2 / 1.8, rel=1e-14)
    table = c.cytokinesis_numbers([store])
    assert list(table["furrow"][:4]) == ["symmetric", "symmetric", "slipping", "symmetric"]
    off = store.assign_coords(center=("run", np.array([np.pi / 2, np.pi / 2, np.pi / 2 - 0.001, np.pi / 2])))
    # an off-centre ring's ratio is the ring's, not a slip (the centred ones unchanged)
    assert list(c.cytokinesis_numbers([off])["furrow"][:4]) == [
        "symmetric",
        "symmetric",
        "off-centre (ring at 1.5698 rad)",
        "symmetric",
    ]
    assert list(table["division"][:4]) == ["complete", "failed", "complete", "failed"]
    assert table["run"].str.startswith("published").sum() == len(c.PUBLISHED)


def test_late_law_recovers_the_exponent(store):
    """Exact power-law data: the fit returns its exponent, amplitude and pinch time to the solver's
    tolerance (least_squares' default 1e-8 on the cost; 1e-5 leaves a margin)."""
    a, amp, tp = c.neck_law(store, 0)
    assert a == pytest.approx(EXP, rel=1e-5)
    assert amp == pytest.approx(A, rel=1e-5)
    assert tp == pytest.approx(TP, rel=1e-5)
    # r / |dr/dt| = (t_p - t) / a, by a backward difference: relative error (a - 1) dt / (2 (t_p - t))
    s, dt = TP - T_CUT, T_CUT / 199
    assert c.closing_time(store, 0) == pytest.approx(s / EXP, rel=2 * (EXP - 1) * dt / (2 * s))
    assert math.isnan(c.neck_law(store, 3)[0])  # no frame below the law's neck


def test_lobe_growth_integrates_the_rate(store):
    """A rate linear in time: the trapezoid rule is exact, G = 2 T + 1.5 T^2 from t = 0 (neck 0.5)."""
    first, last, g = c.lobe_growth(store, 0)
    assert (first, last) == (2.0, pytest.approx(2.0 + 3.0 * T_CUT, rel=1e-14))
    assert g == pytest.approx(2.0 * T_CUT + 1.5 * T_CUT**2, rel=1e-13)
    assert math.isnan(c.lobe_growth(store, 2)[2])  # a 3D run has none


def test_figure_draws(store):
    fig = c.cytokinesis_figure(store)
    assert len(fig.axes) == 4


def _cube():
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    faces = ConvexHull(corners).simplices.copy()
    p = corners[faces]
    outward = np.einsum("ij,ij->i", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p.mean(1)) > 0
    faces[~outward] = faces[~outward][:, ::-1]
    return corners, faces


@pytest.mark.parametrize(
    ("axis", "point", "above"),
    [((0, 0, 1), (0, 0, 0.2), 0.3), ((0, 0, -1), (0.3, -0.1, 0.2), 0.7), ((1, 1, 1), (0, 0, 0), 0.5)],
)
def test_volume_split_of_a_cube(axis, point, above):
    """Flat faces clipped exactly: the unit cube's parts on either side of a plane, to round-off."""
    pts, faces = _cube()
    down, up = side_volumes(pts, faces, point, axis)
    assert up == pytest.approx(above, abs=1e-14)
    assert down == pytest.approx(1.0 - above, abs=1e-14)
