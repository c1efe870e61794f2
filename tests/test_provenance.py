"""Provenance: every output file says what made it (cortex_ti.about), and the version comes from the
repository's tags with a fallback when there is no git metadata.

Truths: the installed distributions' own metadata (importlib.metadata), git's own answer for the checkout's
commit, and setuptools-scm's documented fallback for a source tree without git.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import zipfile
from importlib import metadata
from pathlib import Path

import pytest
import xarray as xr

import cortex_ti
from cortex_ti.about import DEPENDENCIES, PROVENANCE_KEYS, provenance

ROOT = Path(__file__).resolve().parents[1]


def _git(*args):
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True)


def test_provenance_names_the_dependencies_as_installed():
    p = provenance()
    assert set(p) == set(PROVENANCE_KEYS)
    assert all(isinstance(v, str) and v for v in p.values())
    for name in DEPENDENCIES:
        assert p[f"{name}_version"] == metadata.version(name)
    assert p["cortex_ti_version"] == cortex_ti.__version__


def test_reading_the_versions_does_not_start_taichi():
    code = "import sys, cortex_ti; cortex_ti.provenance(); assert 'taichi' not in sys.modules"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert res.returncode == 0, res.stderr


@pytest.mark.skipif(
    shutil.which("git") is None or _git("rev-parse", "HEAD").returncode != 0, reason="not a git checkout"
)
def test_the_commit_is_the_checkouts():
    head = _git("rev-parse", "HEAD").stdout.strip()
    commit = provenance()["cortex_ti_commit"]
    assert commit.removesuffix("-dirty") == head
    dirty = _git("status", "--porcelain", "--untracked-files=no", "--", "cortex_ti").stdout.strip() != ""
    assert commit.endswith("-dirty") == dirty


@pytest.mark.parametrize("model", ["3d", "axisymmetric"])
def test_every_trajectory_carries_the_provenance(tmp_path, model):
    out = tmp_path / f"{model}.h5"
    res = subprocess.run(
        [
            sys.executable,
            "-m",
            "cortex_ti",
            "run",
            "sphere_y20_full",
            "-o",
            str(out),
            "--set",
            "mesh.nodes=162",
            "--set",
            f"model={model}",
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
        timeout=300,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])},
    )
    assert res.returncode == 0, res.stderr[-2000:]
    with xr.open_dataset(out, engine="h5netcdf") as ds:
        assert {k: ds.attrs[k] for k in PROVENANCE_KEYS} == provenance()


def test_the_stores_carry_the_provenance():
    from cortex_ti.studies.stores import cost_dataset

    assert {k: cost_dataset([]).attrs[k] for k in PROVENANCE_KEYS} == provenance()


@pytest.mark.slow
@pytest.mark.skipif(
    shutil.which("git") is None or _git("rev-parse", "HEAD").returncode != 0, reason="not a git checkout"
)
def test_a_source_archive_without_git_builds_with_the_fallback_version(tmp_path):
    """`pip install .` from an archive of the sources (no .git, no tag): setuptools-scm's fallback_version."""
    src = tmp_path / "src"
    files = _git("ls-files", "--cached", "--others", "--exclude-standard").stdout.split()  # the tree as it is now
    for name in files:
        if (ROOT / name).is_file():
            (src / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(ROOT / name, src / name)
    assert not (src / ".git").exists()
    res = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(tmp_path / "wheel"), str(src)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr[-2000:]
    wheel = next((tmp_path / "wheel").glob("cortex_ti-*.whl"))
    fallback = "0.1.0"  # [tool.setuptools_scm] fallback_version in pyproject.toml
    assert wheel.name.startswith(f"cortex_ti-{fallback}-")
    assert fallback in zipfile.ZipFile(wheel).read("cortex_ti/_version.py").decode()


def test_citation_and_license_agree_with_the_package():
    """CITATION.cff (format 1.2.0) names the license pyproject.toml declares and the paper by its DOI;
    LICENSE is that license's text."""
    import yaml

    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11

    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert cff["cff-version"] == "1.2.0" and cff["type"] == "software"
    assert cff["license"] == project["license"]["text"] == "MIT"
    assert any(ref.get("doi") == "10.3389/fphy.2021.753230" for ref in cff["references"])
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
