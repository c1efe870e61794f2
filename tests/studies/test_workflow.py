"""The Snakemake workflow: config validation, the DAG, and a tiny configuration end to end."""

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
import yaml

ROOT = Path(__file__).resolve().parents[2]
TINY = ROOT / "tests" / "data" / "tiny_workflow.yaml"
SNAKEMAKE = shutil.which("snakemake")

pytestmark = pytest.mark.skipif(SNAKEMAKE is None, reason="snakemake is installed with the test extra")

from cortex_ti.studies.registry import TABLES, figures_of, stores_of  # noqa: E402  (what the workflow produces)


def snakemake(workdir, *args, timeout=900):
    cmd = [SNAKEMAKE, "-s", str(ROOT / "Snakefile"), "--directory", str(workdir), *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def expected_outputs(config):
    formats = config["figures"].get("formats", ["png", "pdf"])
    out = [f"results/aggregate/{s}.nc" for s in stores_of(config)]
    out += [f"results/figures/{f}.{fmt}" for f in figures_of(config) for fmt in formats]
    out += [f"results/figures/{f}_numbers.html" for f in figures_of(config)]
    return out + [f"results/figures/{t}.html" for t in TABLES]


@pytest.mark.parametrize("configfile", ["config/config.yaml", "config/smoke.yaml", "config/paper.yaml"])
@pytest.mark.slow
def test_dry_run_reaches_every_store_and_figure(tmp_path, configfile):
    res = snakemake(tmp_path, "-n", "--cores", "2", "--configfile", str(ROOT / configfile), timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    config = yaml.safe_load((ROOT / configfile).read_text())
    for path in expected_outputs(config):
        assert path in res.stdout, f"{path} is not in the DAG of {configfile}"
    # one simulation job per configured run: the static product and every study's rows
    from cortex_ti.studies.registry import STUDIES
    from cortex_ti.studies.sweeps import expand_runs, twin_rows

    n_methods = sum(len(fits) for fits in config["static"]["methods"].values())
    n_static = len(config["static"]["scenes"]) * len(config["static"]["nodes"]) * n_methods
    n_dynamic = sum(
        len(expand_runs(s, config[s]["runs"]))
        for s in ("furrow", "fold", "reorientation", "constriction", "self_organisation", "fluids", "cytokinesis")
        if s in config
    )
    n_accuracy = len(expand_runs("accuracy", config["accuracy"]["runs"]))
    # plus one axisymmetric twin per distinct axisymmetric problem of the furrow and accuracy runs
    twin_sources = [r for s in ("furrow", "accuracy") for r in expand_runs(s, config[s]["runs"])]
    n_dynamic += len(twin_rows(twin_sources, STUDIES["axisymmetric"].columns))
    for rule, n in (("run_static", n_static), ("run_dynamic", n_dynamic), ("run_accuracy", n_accuracy)):
        row = [line.split() for line in res.stdout.splitlines() if line.split()[:1] == [rule]]
        assert row and int(row[0][1]) == n, f"{rule}: expected {n} jobs"


@pytest.mark.slow
def test_lint_gives_only_the_environment_advice(tmp_path):
    """``snakemake --lint`` finds nothing but its advice to give each rule a conda environment or a
    container (the README says why the package's own install is the environment)."""
    res = snakemake(tmp_path, "--lint", timeout=300)
    lints = {
        line.strip()[2:].rstrip(":") for line in (res.stdout + res.stderr).splitlines() if line.startswith("    * ")
    }
    assert lints == {"Specify a conda environment or container for each rule."}, lints


@pytest.mark.slow
def test_slurm_profile_dry_runs(tmp_path):
    pytest.importorskip("snakemake_executor_plugin_slurm")
    shutil.copytree(ROOT / "profiles", tmp_path / "profiles")
    res = snakemake(tmp_path, "-n", "--profile", str(tmp_path / "profiles" / "slurm"), timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]


@pytest.mark.parametrize(
    "change, message",
    [
        ({"furrow": {"runs": [{"scene": "furrow_p8_a1", "gamma": 0.3}]}}, "gamma"),
        ({"threads": 0}, "threads"),
        ({"accuracy": {"runs": [{"scene": "furrow_p8_a1", "scheme": "rk4"}]}}, "rk4"),
        ({"colour": "blue"}, "colour"),
    ],
)
@pytest.mark.slow
def test_invalid_config_is_rejected_naming_the_problem(tmp_path, change, message):
    config = yaml.safe_load(TINY.read_text())
    config.update(change)
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump(config))
    res = snakemake(tmp_path, "-n", "--cores", "1", "--configfile", str(bad), timeout=300)
    assert res.returncode != 0
    assert "Error validating config file" in res.stdout + res.stderr
    assert message in res.stdout + res.stderr


@pytest.mark.slow
def test_tiny_configuration_end_to_end(tmp_path):
    res = snakemake(tmp_path, "--cores", "2", "--configfile", str(TINY))
    assert res.returncode == 0, res.stderr[-4000:]
    config = yaml.safe_load(TINY.read_text())
    for path in expected_outputs(config):
        assert (tmp_path / path).stat().st_size > 0, path

    open_store = lambda name: xr.load_dataset(tmp_path / f"results/aggregate/{name}.nc", engine="h5netcdf")  # noqa: E731

    conv = open_store("convergence")
    assert set(conv.dims) == {"scene", "formulation", "fit", "nodes"}
    assert conv["nodes"].values.tolist() == [162, 642]
    assert conv["formulation"].values.tolist() == ["paper", "rayleigh_p1"]
    assert conv["eps_rel"].attrs["units"] == "1"
    assert np.all(conv["eps_rel"].isel(nodes=1) < conv["eps_rel"].isel(nodes=0))  # converges with N

    furrow = open_store("furrow")
    assert furrow["pole_radius"].dims == ("run", "time")
    assert furrow["time"].values.tolist() == [0.0, 0.01]
    assert furrow["pole_radius"].attrs["units"] == "R0"
    p, f = furrow["pole_radius"].values[0], furrow["furrow_radius"].values[0]
    assert p[1] > p[0] and f[1] < f[0]  # the ring pulls in, the poles move out
    assert abs(furrow["volume_change"].values[0, -1]) < 1e-4

    fold = open_store("fold")
    assert fold["fold_depth"].values[0, 0] == pytest.approx(0.0, abs=1e-9)  # a sphere has no fold
    assert fold["fold_depth"].values[0, -1] > 0.0

    reo = open_store("reorientation")
    assert reo["gamma"].values.tolist() == [0.35, 0.75]
    # the sheared sphere's long axis: the major axis of the ellipse x -> x + gamma z, from z
    for g, angle in zip(reo["gamma"].values, reo["orientation_angle"].values, strict=False):
        exact = 90.0 - 0.5 * np.degrees(np.arctan2(2.0, g))
        assert angle[0] == pytest.approx(exact, abs=0.1)
        assert angle[-1] < angle[0]  # turning back toward the pattern axis

    cost = open_store("cost")
    # + furrow_p8_a1's two twins (its rayleigh_p1 runs' bending form and its paper runs'), + constriction
    n_runs = 4 + 1 + 1 + 2 + 4 + 2 + 1
    assert cost.sizes["run"] == n_runs
    deep = open_store("constriction")
    assert deep["model"].values.tolist() == ["axisymmetric"]
    assert deep["material_stretch"].values[0, 0] == pytest.approx(1.0, abs=1e-12)  # the initial sphere
    assert np.all(np.diff(deep["furrow_radius"].values[0]) < 0)  # the ring pulls the neck in

    twin = cost["study"].values == "axisymmetric"
    assert (
        twin.sum() == 2
        and set(cost["model"].values[twin]) == {"axisymmetric"}
        and np.all(cost["wall_s"].values[twin] > 0)
    )
    # one twin per bending form: the rayleigh_p1 runs' and the paper runs' (the label holds the parameters)
    assert sorted("bending_form~paper" in str(label) for label in cost["run"].values[twin]) == [False, True]
    assert np.all(cost["wall_s"].values > 0) and np.all(cost["max_rss_mb"].values > 0)
    failed = cost["status"].values == "failed"
    assert failed.sum() == 1 and cost["nodes"].values[failed][0] == 642
    acc_ok = (cost["study"].values == "accuracy") & ~failed
    err = cost["error"].values[acc_ok]
    assert err.size == 3 and np.all((err > 0) & (err < 5e-3))  # against the axisymmetric solution of the scene
    assert sorted(cost["formulation"].values[acc_ok].tolist()) == ["paper", "rayleigh_p1", "rayleigh_p1"]
    assert cost["formulation"].values[failed][0] == "paper"
    assert np.isnan(cost["error"].values[cost["study"].values == "static"]).all()

    import matplotlib.image as mpimg

    img = mpimg.imread(tmp_path / "results/figures/accuracy_cost.png")
    assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100

    report = snakemake(tmp_path, "--cores", "1", "--configfile", str(TINY), "--report", "report.html", timeout=300)
    assert report.returncode == 0, report.stderr[-2000:]
    assert "ERROR" not in report.stdout + report.stderr  # captions are valid reStructuredText
    html = (tmp_path / "report.html").read_text(errors="replace")
    for name in figures_of(config):
        assert f"{name}.png" in html


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-v"]))
