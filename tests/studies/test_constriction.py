"""The constriction study's reading of its store (cortex_ti.studies.constriction) on a store built
by hand, whose outcomes, twins and threshold are known by construction: prescribed rings by
(zeta_hat, p), and a myosin ring that forms by itself (its pattern columns nan, the store's null)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import xarray as xr

from cortex_ti.studies import constriction as c

T = np.linspace(0.0, 40.0, 81)


def _store() -> xr.Dataset:
    """Five runs on one time grid (nan after a run's end):

    0. axisymmetric, ratio 4 (zeta_hat 3), to t = 40: the neck levels off at 0.6 (arrested);
    1. axisymmetric, ratio 7, stops at t = 5 at 0.1 (closed);
    2. axisymmetric myosin ring, stops at t = 30 (closed); its label map unresolved from t = 25;
    3. 3D of the myosin ring, 0.01 wider than its twin, to t = 30;
    4. 3D of ratio 7, 0.002 narrower than its twin, to t = 5."""
    n = T.size
    neck = np.full((5, n), np.nan)
    neck[0] = 0.6 + 0.4 * np.exp(-T)
    early, late = T <= 5.0 + 1e-9, T <= 30.0 + 1e-9
    neck[1, early] = 1.0 - 0.18 * T[early]
    neck[2, late] = 1.0 - 0.03 * T[late]
    neck[3, late] = neck[2, late] + 0.01
    neck[4, early] = neck[1, early] - 0.002
    resolved = np.where(np.isfinite(neck), 1.0, np.nan)
    resolved[2, (T >= 25.0) & late] = 0.0
    nan = math.nan
    runs = {
        "scene": [
            "constriction_p4",
            "constriction_p4",
            "myosin_constriction",
            "myosin_constriction",
            "constriction_p4",
        ],
        "model": ["axisymmetric", "axisymmetric", "axisymmetric", "3d", "3d"],
        "zeta_hat": [3.0, 6.0, nan, nan, 6.0],
        "p": [4.0, 4.0, nan, nan, 4.0],
        "nodes": [0, 0, 0, 2562, 2562],
        "t_end": [40.0, 40.0, 60.0, 60.0, 5.0],
        "label": [f"run{i}" for i in range(5)],
    }
    volume = np.where(np.isfinite(neck), 1.0, np.nan)
    return xr.Dataset(
        {
            "neck_radius": (("run", "time"), neck),
            "furrow_radius": (("run", "time"), neck),
            "label_resolved": (("run", "time"), resolved),
            "min_angle_deg": (("run", "time"), np.where(np.isfinite(neck), 30.0, np.nan)),
            "volume_change": (("run", "time"), volume - 1.0),
        },
        coords={"time": T, "run": np.arange(5), **{k: ("run", np.asarray(v)) for k, v in runs.items()}},
    )


def test_outcomes_and_the_threshold_come_from_the_prescribed_rings_only():
    ds = _store()
    assert [c.outcome(ds, i) for i in range(3)] == ["arrested", "closed", "closed"]
    # the myosin ring closes too, but has no ratio: the bracket is the prescribed rings' (4, 7]
    assert c.threshold(ds) == {4.0: (4.0, 7.0)}


def test_a_3d_run_is_compared_with_its_own_ring_while_the_twin_is_resolved():
    ds = _store()
    assert c._twin(ds, 3) == 2 and c._twin(ds, 4) == 1  # nan pattern columns still pair up, by scene
    dev, until = c.deviation(ds, 3)
    assert until == 25.0 and math.isclose(dev, 0.01, rel_tol=1e-12)
    dev, until = c.deviation(ds, 4)
    assert until == 5.0 and math.isclose(dev, 0.002, rel_tol=1e-12)


def test_the_figure_gives_the_myosin_ring_a_panel_and_the_table_a_row():
    ds = _store()
    fig = c.constriction_figure(ds)
    assert [a.get_title() for a in fig.axes[:2]] == ["prescribed rings", "myosin rings that form by themselves"]
    assert len(fig.axes) == 3
    table = c.constriction_numbers([ds])
    assert table["ratio 1 + zeta_hat"].tolist()[:5] == ["4", "7", "myosin", "myosin", "7"]
    assert table["run"].tolist()[-1] == "threshold, p = 4"
    prescribed = c.constriction_figure(ds.isel(run=[0, 1, 4]))
    assert len(prescribed.axes) == 2


def test_rigid_rings_are_mapped_apart_from_the_threshold():
    """Issue 35: with a ``bending`` column, a rigid ring's run is not one of the threshold's (the
    threshold is that of the rings without rigidity) but a row of the rigidity map; a store without
    the column reads kappa = 0."""
    ds = _store()
    assert [c.bending(ds, i) for i in range(5)] == [0.0] * 5 and c.rigidity_map(ds) == []
    rigid = ds.assign_coords(bending=("run", np.array([0.0, 0.01, 0.0, 0.0, 0.0])))
    # run 1 (ratio 7, closed) is rigid now: no ring without rigidity closes, so the bracket opens
    assert c.threshold(rigid)[4.0][0] == 4.0 and math.isnan(c.threshold(rigid)[4.0][1])
    assert c.rigidity_map(rigid) == [(0.01, 7.0, "closed", pytest.approx(1.0 - 0.18 * 5.0))]
    c.constriction_figure(rigid)  # draws the rigid ring beside the others
    assert c.constriction_numbers([rigid])["kappa"].tolist()[:2] == ["0", "0.01"]
