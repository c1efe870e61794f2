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


# --------------------------------------------------------------------- one output rule for every door
RUN = dict(nodes=162, t_end=0.01, threads=1)


def _md5(path):
    import hashlib

    return hashlib.md5(path.read_bytes()).hexdigest()


def _cli_error(capsys, *argv):
    from cortex_ti.cli import main

    assert main(list(argv)) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("cortex-ti: error: ")
    return lines[0][len("cortex-ti: error: ") :]


def test_every_door_refuses_an_existing_output_and_an_interrupted_partial_leaving_both_files(tmp_path, capsys):
    """ct.run, Simulation.run and the axisymmetric run refuse what `cortex-ti run` refuses, with its
    message (one function decides: cortex_ti.io.claim.check_output), and touch neither file."""
    from cortex_ti.axisymmetric.run import AxisymmetricRun
    from cortex_ti.errors import CortexError
    from cortex_ti.io.trajectory import committed_frames
    from cortex_ti.simulation.core import Simulation

    done = tmp_path / "a.h5"
    ct.run("furrow_p8_a1", output=done, **RUN)
    killed = tmp_path / "b.h5"
    partial = tmp_path / "b.h5.partial"
    partial.write_bytes(done.read_bytes())  # a run's committed frames, as a killed run leaves them
    assert committed_frames(partial)[0] == 2
    sums = {p: _md5(p) for p in (done, partial)}
    scene = ct.load_scene("furrow_p8_a1", nodes=162, t_end=0.01)
    for out in (done, killed):
        said = _cli_error(capsys, "run", "furrow_p8_a1", "-o", str(out), "--set", "mesh.nodes=162", "--threads", "1")
        doors = {
            "ct.run": lambda out=out: ct.run("furrow_p8_a1", output=out, **RUN),
            "ct.run model=axisymmetric": lambda out=out: ct.run(
                "furrow_p8_a1", output=out, model="axisymmetric", t_end=0.01
            ),
            "Simulation.run": lambda out=out: Simulation(scene).run(out, progress=False),
            "AxisymmetricRun.run": lambda out=out: AxisymmetricRun(ct.load_scene(scene, model="axisymmetric")).run(out),
        }
        for door, call in doors.items():
            with pytest.raises(CortexError) as caught:
                call()
            assert str(caught.value) == said, door
            assert {p: _md5(p) for p in sums} == sums, door
    assert "exists; pass --force" in str(caught.value) or "interrupted run" in str(caught.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.h5", "b.h5.partial"]
    # force replaces (the partial file too); resume continues the interrupted run
    ct.run("furrow_p8_a1", output=done, force=True, **RUN)
    resumed = ct.run("furrow_p8_a1", output=killed, resume=True, **RUN)
    assert resumed.sizes["time"] == 2 and not partial.exists()
    with pytest.raises(CortexError, match="pass one of them"):
        ct.run("furrow_p8_a1", output=done, force=True, resume=True, **RUN)


def test_a_scene_file_is_never_an_output(tmp_path, capsys):
    from cortex_ti.errors import CortexError

    yaml = tmp_path / "my.yaml"
    yaml.write_text(ct.load_scene("furrow_p8_a1", nodes=162, t_end=0.01).to_yaml())
    before = _md5(yaml)
    said = _cli_error(capsys, "run", str(yaml), "-o", str(yaml), "--force")
    assert "named like a scene or config file" in said
    with pytest.raises(CortexError) as caught:
        ct.run(yaml, output=yaml, force=True, threads=1)
    assert str(caught.value) == said and _md5(yaml) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["my.yaml"]


@pytest.mark.parametrize("threads", [-3, 2.5, True, "abc", "0"])
def test_bad_threads_are_refused_in_python(threads):
    from cortex_ti.errors import CortexError

    with pytest.raises(CortexError, match="threads must be a whole number >= 1"):
        ct.run("furrow_p8_a1", **{**RUN, "threads": threads})


def test_zero_threads_or_a_bad_environment_is_an_error_not_an_abort(tmp_path):
    """threads=0 reached Taichi, whose C++ assertion aborted the interpreter (a notebook kernel dies)."""
    code = (
        "import cortex_ti as ct\nfrom cortex_ti.errors import CortexError\n"
        "try:\n    ct.run('furrow_p8_a1', nodes=162, t_end=0.01, threads={})\n"
        "except CortexError as e:\n    print('refused:', e)\n"
    )
    for threads, env in (("0", {}), ("None", {"CORTEX_TI_THREADS": "abc"})):
        import os

        res = subprocess.run(
            [sys.executable, "-c", code.format(threads)],
            capture_output=True,
            text=True,
            env={**os.environ, **env},
            cwd=tmp_path,
        )
        assert res.returncode == 0, res.stderr
        assert res.stdout.startswith("refused: ") and "must be a whole number >= 1" in res.stdout
        assert "CORTEX_TI_THREADS" in res.stdout or not env


def test_one_override_may_be_a_string():
    assert ct.load_scene("furrow_p8_a1", "mesh.nodes=642").settings.mesh.nodes == 642
    with pytest.raises(SceneError, match="KEY=VALUE"):
        ct.load_scene("furrow_p8_a1", [642])
