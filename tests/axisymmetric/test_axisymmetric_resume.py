"""An axisymmetric run writes its frames as it reaches them and resumes (cortex_ti.axisymmetric.run).

Truths: a process killed without any clean-up (``os._exit`` where the next frame would be written,
as SIGKILL would) keeps every frame written before it in ``<output>.partial``, each equal to the
uninterrupted run's to round-off (the same computation up to there); ``--resume`` continues from
the last one and lands within the integrator's time error of the uninterrupted run. That error is
measured, not assumed: the uninterrupted run's distance from one at a 100x tighter
``axisymmetric.rtol``, times 2 (the resumed run restarts the integrator, so it differs by its own
error, of the same size; measured: resumed vs whole 2.3e-11, whole vs tight 2.2e-11).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from cortex_ti.axisymmetric.run import STATE_VAR, AxisymmetricRun
from cortex_ti.cli import main
from cortex_ti.io import load_trajectory
from cortex_ti.io.trajectory import committed_frames, partial_path
from cortex_ti.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
SETS = ["model=axisymmetric", "time.t_end=0.6", "time.save_every=0.1"]
KILL_AT = 4  # the process dies where the fifth frame (t = 0.4) would be written


def _run(path, sets=()):
    AxisymmetricRun(load_scene("furrow_p4_a1", [*SETS, *sets])).run(path, progress=False)
    return load_trajectory(path)


def _killed(path):
    """The run in a child process that ends itself with ``os._exit`` (no clean-up) at frame KILL_AT."""
    code = textwrap.dedent(
        f"""
        import os
        import cortex_ti.axisymmetric.run as run
        calls = [0]
        def die():
            calls[0] += 1
            if calls[0] > {KILL_AT}:
                os._exit(9)
        run.check_interrupted = die
        from cortex_ti.scene import load_scene
        run.AxisymmetricRun(load_scene("furrow_p4_a1", {SETS!r})).run({str(path)!r}, progress=False)
        """
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def whole(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("whole") / "a.h5")


@pytest.mark.slow
def test_a_killed_run_keeps_its_frames_and_resumes(tmp_path, whole):
    out = tmp_path / "b.h5"
    res = _killed(out)
    assert res.returncode == 9, res.stderr
    assert not out.exists()
    n, t = committed_frames(partial_path(out))
    assert (n, t) == (KILL_AT, pytest.approx(0.3))
    kept = load_trajectory(partial_path(out))
    assert kept[STATE_VAR].shape[0] == KILL_AT
    # written as they came: the same computation as the uninterrupted run up to there
    np.testing.assert_array_equal(kept.points.values, whole.points.values[:KILL_AT])
    kept.close()
    # refused without --resume, continued with it (the command line's rule and door)
    assert main(["run", "furrow_p4_a1", "-o", str(out), *sum((["--set", s] for s in SETS), [])]) == 2
    assert main(["run", "furrow_p4_a1", "-o", str(out), "--resume", *sum((["--set", s] for s in SETS), [])]) == 0
    resumed = load_trajectory(out)
    np.testing.assert_allclose(resumed.time.values, whole.time.values, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(resumed.points.values[:KILL_AT], whole.points.values[:KILL_AT])
    assert np.all(resumed.label_resolved.values == whole.label_resolved.values)
    tight = _run(tmp_path / "tight.h5", ["axisymmetric.rtol=1e-12"])
    error = float(np.abs(whole.points.values - tight.points.values).max())
    gap = float(np.abs(resumed.points.values - whole.points.values).max())
    assert 0 < gap <= 2 * error, (gap, error)
    # a radius moves by at most the points' largest move; the volume by at most the area times it
    area = float(whole.area.values.max())
    for name, scale in (("furrow_radius", 1.0), ("pole_radius", 1.0), ("volume", area)):
        assert np.abs(resumed[name].values - whole[name].values).max() <= 2 * error * scale, name


@pytest.mark.slow
def test_a_resume_without_a_partial_file_starts_over(tmp_path, whole):
    ds = AxisymmetricRun(load_scene("furrow_p4_a1", SETS))
    ds.run(tmp_path / "c.h5", resume=True, progress=False)
    np.testing.assert_array_equal(load_trajectory(tmp_path / "c.h5").points.values, whole.points.values)
