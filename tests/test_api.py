"""The Python front door (cortex_ti.api, cortex_ti.models): a run from Python returns the trajectory
as a Dataset, settings are keywords, scenes are immutable, models come from one registry."""

import subprocess
import sys

import numpy as np
import pytest

import cortex_ti as ct
from cortex_ti.errors import SceneError
from cortex_ti.models import MODELS


def test_run_returns_the_trajectory_as_a_dataset(tmp_path):
    ds = ct.run("furrow_p8_a1", nodes=162, t_end=0.02, time__save_every=0.01)
    assert ds.sizes["node"] == 162 and ds.sizes["time"] == 3
    assert np.all(np.isfinite(ds.points.values))
    kept = ct.run("furrow_p8_a1", output=tmp_path / "k.h5", nodes=162, t_end=0.01)
    assert (tmp_path / "k.h5").exists() and kept.sizes["time"] == 2
    again = ct.open_trajectory(tmp_path / "k.h5")
    np.testing.assert_array_equal(again.points.values, kept.points.values)


def test_every_model_of_the_schema_is_registered_and_runs_from_python():
    from cortex_ti.scene import current_schema

    assert list(MODELS) == current_schema()["properties"]["model"]["enum"]
    ds = ct.run("furrow_p8_a1", model="axisymmetric", t_end=0.02)
    assert ds.attrs["scene"].count("model: axisymmetric") == 1


def test_a_scene_is_immutable_and_an_override_makes_a_new_one():
    scene = ct.load_scene("furrow_p8_a1")
    data = scene.data
    data["mesh"]["nodes"] = 42  # edits a copy
    assert scene.settings.mesh.nodes == 2562 and scene["mesh.nodes"] == 2562
    other = ct.load_scene(scene, nodes=642)
    assert other is not scene and other.settings.mesh.nodes == 642 and scene.settings.mesh.nodes == 2562


def test_bad_keywords_name_the_key():
    with pytest.raises(SceneError, match="mesh.nodes"):
        ct.load_scene("furrow_p8_a1", nodes=7)
    with pytest.raises(SceneError, match="time.dtt"):
        ct.load_scene("furrow_p8_a1", time__dtt=1.0)


def test_importing_the_package_starts_no_taichi():
    code = "import sys, cortex_ti as ct; ct.load_scene('furrow_p8_a1', nodes=642); assert 'taichi' not in sys.modules"
    subprocess.run([sys.executable, "-c", code], check=True)
