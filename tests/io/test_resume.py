"""A killed run resumes from its .partial file and reaches the uninterrupted result."""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from cortex_ti.io import open_trajectory, partial_path

pytestmark = pytest.mark.slow

ARGS = [
    "furrow_p4_a1",
    "--set",
    "mesh.nodes=2562",
    "--set",
    "time.scheme=euler",
    "--set",
    "time.dt=2.5e-3",
    "--set",
    "time.t_end=0.15",
    "--set",
    "solver.reuse=false",
    "--threads",
    "2",
]


def cli(*args):
    return [sys.executable, "-m", "cortex_ti", "run", *args]


def test_resume_after_kill_reproduces_the_uninterrupted_run(tmp_path):
    ref = tmp_path / "ref.h5"
    t0 = time.time()
    subprocess.run(cli(*ARGS, "-o", str(ref)), check=True, capture_output=True)
    ref_seconds = time.time() - t0

    out = tmp_path / "killed.h5"
    proc = subprocess.Popen(cli(*ARGS, "-o", str(out)), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    part = partial_path(out)
    # HDF5 locks a file being written, so wait for the partial file, then a few more seconds
    deadline = time.time() + 120
    while time.time() < deadline and proc.poll() is None and not part.exists():
        time.sleep(0.05)
    time.sleep(ref_seconds / 3)
    assert proc.poll() is None, "the run finished before it could be killed"
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not out.exists() and part.exists()
    with open_trajectory(part) as ds:
        kept = ds.sizes["time"]
        assert 1 <= kept < 16 and np.all(np.isfinite(ds["points"].values))

    res = subprocess.run(cli(*ARGS, "-o", str(out), "--resume"), capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert out.exists() and not part.exists()
    with open_trajectory(ref) as a, open_trajectory(out) as b:
        assert a.sizes["time"] == b.sizes["time"] == 16
        np.testing.assert_allclose(b["time"].values, a["time"].values, rtol=0, atol=1e-12)
        for var in ("points", "velocity", "pole_radius", "furrow_radius", "volume"):
            np.testing.assert_allclose(b[var].values, a[var].values, rtol=0, atol=1e-10, err_msg=var)
        assert "resumed" in b.attrs
