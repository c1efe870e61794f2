"""Bookkeeping as documented (issue 34): the --summary of a run refused for its input, a summary
that cannot be written after a finished run (a warning, exit 0), a resume refused for a changed
scene naming the key and both values before anything is logged as resuming, and the stored scene's
time.t_end that of the frames."""

from __future__ import annotations

import errno
import hashlib
import json
import os

import pytest
import yaml

import cortex_ti as ct
from cortex_ti.cli import main

pytestmark = pytest.mark.usefixtures("taichi_runtime")

SMALL = ["--set", "mesh.nodes=162", "--set", "time.scheme=euler", "--set", "time.dt=5e-3", "--threads", "1"]


def _md5(path):
    return hashlib.md5(path.read_bytes()).hexdigest()


def _stored_t_end(path) -> float:
    return float(yaml.safe_load(ct.open_trajectory(path).attrs["scene"])["time"]["t_end"])


@pytest.mark.parametrize(
    "sets, words",
    [
        (["--set", "mesh.nodes=7"], "mesh.nodes"),
        (["--threads", "0"], "--threads must be a whole number"),
        (["--set", "time.dt=1e-300"], "time.dt = 1e-300 is too small"),
    ],
)
def test_an_input_error_writes_the_summary(tmp_path, capsys, sets, words):
    out, summary = tmp_path / "x.h5", tmp_path / "x.json"
    assert main(["run", "furrow_p8_a1", "-o", str(out), "--summary", str(summary), *sets]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and words in lines[0]
    info = json.loads(summary.read_text())
    assert info["status"] == "failed" and info["stopped"] == "input" and words in info["error"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.json"]


def test_a_summary_that_cannot_be_written_does_not_fail_a_finished_run(tmp_path, capsys, monkeypatch):
    import cortex_ti.io as io

    def full(obj, path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(io, "write_json", full)  # the disk filled during the run
    out, summary = tmp_path / "x.h5", tmp_path / "x.json"
    args = ["run", "furrow_p8_a1", "-o", str(out), "--summary", str(summary), *SMALL, "--set", "time.t_end=0.01"]
    assert main(args) == 0
    captured = capsys.readouterr()
    assert captured.out.strip() == str(out) and out.exists()
    lines = captured.err.strip().splitlines()
    assert [ln for ln in lines if ln.startswith("cortex-ti: ")] == [
        f"cortex-ti: warning: cannot write the summary '{summary}': No space left on device: '{summary}'"
    ]


def test_a_changed_scene_on_resume_is_refused_naming_the_key_before_any_resuming_line(tmp_path, capsys, caplog):
    out = tmp_path / "x.h5"
    assert main(["run", "furrow_p8_a1", "-o", str(out), *SMALL, "--set", "time.t_end=0.01"]) == 0
    before = _md5(out)
    capsys.readouterr()
    caplog.clear()
    changed = ["--set", "viscosity.shear=2", "--set", "time.t_end=0.02", "--resume"]
    assert main(["run", "furrow_p8_a1", "-o", str(out), *SMALL, *changed]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and "viscosity.shear is 1.0 in the file, 2.0 now" in lines[0]
    assert lines[0].startswith(f"cortex-ti: error: cannot extend '{out}': it was written for a different scene")
    assert lines[0].endswith("pass --force to replace it, or choose another output")
    said = [r.getMessage() for r in caplog.records]
    assert not [m for m in said if "resuming" in m or "extending" in m], said
    assert _md5(out) == before and sorted(p.name for p in tmp_path.iterdir()) == ["x.h5"]


def test_the_stored_t_end_is_that_of_the_frames(tmp_path, capsys):
    out = tmp_path / "x.h5"
    assert main(["run", "furrow_p8_a1", "-o", str(out), *SMALL, "--set", "time.t_end=0.02"]) == 0
    assert _stored_t_end(out) == 0.02
    # extended to a later t_end: records it
    assert main(["run", "furrow_p8_a1", "-o", str(out), *SMALL, "--set", "time.t_end=0.03", "--resume"]) == 0
    assert _stored_t_end(out) == 0.03 and float(ct.open_trajectory(out).time[-1]) == pytest.approx(0.03)
    # resumed with an earlier t_end: nothing to compute; the scene keeps the t_end its frames reach
    assert main(["run", "furrow_p8_a1", "-o", str(out), *SMALL, "--set", "time.t_end=0.01", "--resume"]) == 0
    assert _stored_t_end(out) == pytest.approx(0.03)


def test_a_disk_full_while_the_partial_file_is_created_is_one_error_and_no_file(tmp_path, monkeypatch):
    """HDF5 reports a failed write as a RuntimeError (h5py) whose text holds the errno, and then
    fails to close the file too: one OutputError naming the disk, and no partial file left (it was
    a traceback and a stray 32 kB partial file on a 20 kB tmpfs)."""
    import numpy as np

    from cortex_ti.io import TrajectoryWriter
    from cortex_ti.io.files import OutputError
    from cortex_ti.io.trajectory import TrajectoryWriter as Writer

    def full(self):
        raise RuntimeError(
            "Unable to flush file (file write failed: time = Fri Dec  4 15:36:36 2026\n, filename = 'x', "
            "file descriptor = 4, errno = 28, error message = 'No space left on device', buf = 0x1, total "
            "write size = 235, bytes this sub-write = 235, offset = 8192)"
        )

    monkeypatch.setattr(Writer, "_flush", full)
    tri = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [1, 3, 2]])
    with pytest.raises(OutputError, match="cannot create .*x.h5.partial': No space left on device$"):
        TrajectoryWriter(tmp_path / "x.h5", tri, 4, {"scene": "name: x\n", "effects": "a"})
    assert list(tmp_path.iterdir()) == []
