"""``time.stop_neck``: a run whose neck closes stops cleanly at the first frame at or below it, its
frames kept, in either model; a value the run could not start below is refused in one line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from cortex_ti.analysis.diagnostics import neck_radius
from cortex_ti.cli import main
from cortex_ti.io.trajectory import Trajectory, frame_mesh


def test_3d_run_stops_at_the_first_frame_past_the_neck(tmp_path):
    """A 162-node deep ring (amplitude 12, no remeshing) closes its neck past 0.6 R0 near t = 0.75:
    the run ends there with exit 0 and the summary's ``neck``; the neck recomputed from the stored
    frames is above the stop (or absent: a convex body) on every frame but the last, at or below it
    on the last."""
    out, summary = tmp_path / "n.h5", tmp_path / "n.json"
    args = ["run", "constriction_p4", "-o", str(out), "--summary", str(summary), "--threads", "1"]
    for s in ("mesh.nodes=162", "active_stress.0.amplitude=12", "time.stop_neck=0.6", "mesh.remesh.min_angle=null"):
        args += ["--set", s]
    assert main(args) == 0
    info = json.loads(summary.read_text())
    assert info["stopped"] == "neck"
    ds = Trajectory(out).ds
    necks = np.array([neck_radius(*frame_mesh(ds, k))[0] for k in range(ds.sizes["time"])])
    assert necks[-1] <= 0.6 and not np.any(necks[:-1] <= 0.6) and len(necks) > 3  # nan: no neck yet
    # the run writes the neck it judged by (the same function on the same frames: a regression check)
    np.testing.assert_array_equal(ds["neck_radius"].values, necks)
    # the constriction study's store takes it, and its neck is the ring plane's radius until one forms
    from cortex_ti.studies.constriction import neck
    from cortex_ti.studies.stores import neck_series, study_dataset
    from cortex_ti.studies.sweeps import expand_runs

    rows = expand_runs("constriction", [{"scene": "constriction_p4", "zeta_hat": 12, "nodes": 162, "t_end": 5.0}])
    store = study_dataset("constriction", rows, [out])
    np.testing.assert_array_equal(store["neck_radius"].values[0], necks)
    np.testing.assert_array_equal(neck_series(Trajectory(out)), necks)  # a file without it: computed
    has = np.isfinite(necks)
    assert np.array_equal(neck(store, 0)[has], necks[has])
    assert np.array_equal(neck(store, 0)[~has], ds["furrow_radius"].values[~has])
    assert info["t_reached"] == float(ds["time"].values[-1]) < 5.0


@pytest.mark.slow
def test_axisymmetric_run_stops_at_time_stop_neck(tmp_path):
    """The meridian run stops at the crossing itself: its last furrow radius (the neck of a
    symmetric ring) is the stop to the event's tolerance."""
    out = tmp_path / "a.h5"
    args = ["run", "furrow_p4_a3", "-o", str(out), "--set", "model=axisymmetric"]
    assert main(args + ["--set", "time.stop_neck=0.8", "--set", "time.t_end=2"]) == 0
    ds = Trajectory(out).ds
    furrow = ds["furrow_radius"].values
    assert abs(furrow[-1] - 0.8) <= 1e-9 and np.all(furrow[:-1] > 0.8)
    # the meridian's own neck: none while the shallow furrow leaves r largest at the equator, then
    # the symmetric ring's furrow radius
    neck = ds["neck_radius"].values
    has = np.isfinite(neck)
    assert not has[0] and has[-1] and abs(neck[-1] - 0.8) <= 1e-9
    assert np.all(has[np.argmax(has) :])  # once formed, a closing neck stays
    np.testing.assert_allclose(neck[has], furrow[has], rtol=0, atol=1e-9)


def test_stop_neck_at_the_radius_is_refused(tmp_path, capsys):
    out = tmp_path / "n.h5"
    code = main(["run", "constriction_p4", "-o", str(out), "--set", "time.stop_neck=1.0"])
    assert code == 2 and not out.exists()
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("cortex-ti: error:") and "time.stop_neck" in err[0]
