"""Every benchmark script runs: its ``--smoke`` mode (a tiny case, seconds) in a process of its own,
from an empty folder, must finish with status 0, print its report, and write nothing where it was
started (a smoke run's files go to a temporary folder). The numbers of a smoke run mean nothing and
are not checked: the benchmarks' measurements live on the validation pages, never in pass/fail
tests. Marked slow (about a minute or two in all). A benchmark of a peer library (an optional extra
that the test extra does not install, ``NEEDS``) is skipped with one line where that library is missing.
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: benchmark -> (the module it needs, the extra that installs it)
NEEDS = {"peer_ngsolve": ("ngsolve", "peers")}
SCRIPTS = sorted(p for p in (ROOT / "benchmarks").glob("*.py") if not p.name.startswith("_") and p.name != "page.py")


def test_every_benchmark_has_a_smoke_mode():
    missing = [p.name for p in SCRIPTS if "--smoke" not in p.read_text()]
    assert missing == []


@pytest.mark.slow
@pytest.mark.parametrize("script", SCRIPTS, ids=[p.stem for p in SCRIPTS])
def test_smoke_mode_runs(script, tmp_path):
    module, extra = NEEDS.get(script.stem, (None, None))
    if module and importlib.util.find_spec(module) is None:
        pytest.skip(f"{script.name} needs {module} (the {extra} extra: pip install -e '.[{extra}]')")
    env = {
        **os.environ,
        "MPLBACKEND": "Agg",
        "CORTEX_TI_THREADS": "1",
        "OMP_NUM_THREADS": "1",
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    res = subprocess.run(
        [sys.executable, str(script), "--smoke"], cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600
    )
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-3000:]
    assert res.stdout.strip(), "a benchmark prints its report"
    assert list(tmp_path.iterdir()) == [], "a smoke run writes only into a temporary folder"


@pytest.mark.slow
def test_a_benchmark_writes_its_validation_page(tmp_path):
    """benchmarks/page.py: the page carries the commit, the date, the machine and the command."""
    from cortex_ti import provenance

    path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
    env = {**os.environ, "CORTEX_TI_THREADS": "1", "PYTHONPATH": path}
    res = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "page.py"),
            "demo",
            "--title",
            "Demo",
            "--out-dir",
            str(tmp_path),
            "--",
            "spectrum",
            "--smoke",
        ],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    text = (tmp_path / "demo.md").read_text()
    assert text.startswith("# Demo\n")
    assert f"commit {provenance()['cortex_ti_commit']} on " in text
    assert "cores" in text and "python benchmarks/spectrum.py --smoke" in text
    assert "| case |" in text  # the benchmark's own table


def test_a_failing_benchmark_writes_no_page(tmp_path):
    res = subprocess.run(
        [
            sys.executable,
            str(ROOT / "benchmarks" / "page.py"),
            "demo",
            "--out-dir",
            str(tmp_path),
            "--",
            "spectrum",
            "--no-such-option",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode != 0
    assert list(tmp_path.iterdir()) == []
