"""The SLURM profile on a real cluster: tests/slurm_cluster.sh brings up a one-node SLURM cluster
on this machine (munged, MariaDB, slurmdbd, slurmctld, slurmd; Debian's packages, installed when
missing), a small configuration (tests/data/slurm_workflow.yaml: nine simulation jobs, one of
them failing on purpose) runs through profiles/slurm into a temporary folder, every
simulation job is tracked to completion by snakemake-executor-plugin-slurm (which reads job
states from sacct), and the cluster goes down again.

When it runs: CORTEX_TI_SLURM=1 asks for it, CORTEX_TI_SLURM=0 turns it off, and unset it runs
in CI only (CI=true). Either way it needs root (it installs packages, writes /etc/slurm and
starts daemons) and Debian's packages or apt-get; otherwise it is skipped, saying why.

    CORTEX_TI_SLURM=1 python -m pytest -m slurm -s tests/studies/test_slurm.py

Measured on the 2-core machine (it prints its timings): 2 min 4 s with the packages installed
and the machine idle (up 3 s, Snakemake 114 s, down 2 s); the first time add ~30 s for
apt-get; 3-4 min when other work shares the two cores.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "tests" / "data" / "slurm_workflow.yaml"  # what the workflow computes: test_workflow.py
CLUSTER_SH = Path(os.environ.get("CORTEX_TI_SLURM_CLUSTER", Path(__file__).parents[1] / "slurm_cluster.sh"))
PACKAGES = ("munge", "mariadb-server", "slurmdbd", "slurmctld", "slurmd", "slurm-client")
ACCOUNT, PARTITION = "cortex", "main"  # what slurm_cluster.sh creates (its defaults)
#: seconds before the plugin's first status check, and between checks once a job finished
POLL = int(os.environ.get("CORTEX_TI_SLURM_POLL", "5"))


def _packages_installed() -> bool:
    if shutil.which("dpkg-query") is None:
        return False
    res = subprocess.run(["dpkg-query", "-W", "-f=${Status}\\n", *PACKAGES], capture_output=True, text=True)
    return res.returncode == 0 and res.stdout.count("install ok installed") == len(PACKAGES)


def _skip_reason() -> str | None:
    wanted = os.environ.get("CORTEX_TI_SLURM", "")
    if wanted == "0":
        return "CORTEX_TI_SLURM=0"
    if wanted != "1" and os.environ.get("CI", "").lower() not in ("1", "true", "yes"):
        return (
            "a real SLURM cluster on this machine: opt in with CORTEX_TI_SLURM=1 (root; installs "
            "munge, mariadb-server, slurmdbd, slurmctld, slurmd and starts them); runs by itself in CI"
        )
    if not sys.platform.startswith("linux"):
        return "Linux only"
    if os.geteuid() != 0:
        return "needs root: installs Debian packages, writes /etc/slurm, starts munged/mariadbd/slurm daemons"
    if not _packages_installed() and shutil.which("apt-get") is None:
        return f"the Debian packages {', '.join(PACKAGES)} are missing and there is no apt-get to install them"
    if not CLUSTER_SH.is_file():
        return f"{CLUSTER_SH} not found"
    if shutil.which("bash") is None:
        return "needs bash"
    return None


pytestmark = [
    pytest.mark.slurm,
    pytest.mark.slow,
    pytest.mark.skipif(_skip_reason() is not None, reason=str(_skip_reason())),
]

TIMINGS: dict[str, float] = {}


def _cluster(action: str, timeout: float) -> subprocess.CompletedProcess:
    env = dict(os.environ, CORTEX_SLURM_ACCOUNT=ACCOUNT, CORTEX_SLURM_PARTITION=PARTITION)
    return subprocess.run(["bash", str(CLUSTER_SH), action], capture_output=True, text=True, timeout=timeout, env=env)


@pytest.fixture(scope="module")
def cluster():
    """The cluster, up; brought down afterwards unless it was already up before."""
    was_up = _cluster("status", 60).returncode == 0
    t0 = time.monotonic()
    up = _cluster("up", 900)  # first time: apt-get install (~40 s here)
    TIMINGS["up"] = time.monotonic() - t0
    assert up.returncode == 0, f"cluster.sh up failed:\n{up.stdout[-3000:]}\n{up.stderr[-3000:]}"
    yield
    if not was_up:
        t0 = time.monotonic()
        down = _cluster("down", 300)
        TIMINGS["down"] = time.monotonic() - t0
        print(
            "\nslurm test timings (s): "
            + ", ".join(f"{k} {v:.1f}" for k, v in TIMINGS.items())
            + ", load average {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())
        )
        assert down.returncode == 0, f"cluster.sh down failed:\n{down.stdout}\n{down.stderr}"
    else:
        print(
            "\nslurm test timings (s): "
            + ", ".join(f"{k} {v:.1f}" for k, v in TIMINGS.items())
            + ", load average {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())
            + " (the cluster was up before: left up)"
        )


def _profile(tmp_path: Path) -> Path:
    """The project's profile, with this cluster's account and partition and a short first poll."""
    profile = tmp_path / "profile"
    shutil.copytree(ROOT / "profiles" / "slurm", profile)
    cfg = yaml.safe_load((profile / "config.yaml").read_text())
    cfg.setdefault("default-resources", {}).update(slurm_account=ACCOUNT, slurm_partition=PARTITION)
    cfg["slurm-init-seconds-before-status-checks"] = POLL
    (profile / "config.yaml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    return profile


def _n_simulation_jobs(config: dict) -> int:
    """The jobs the workflow submits for ``config``: the static runs (scenes x nodes x the fits of
    every formulation), the configured studies' runs and their axisymmetric twins."""
    from cortex_ti.studies.registry import STUDIES, configured_studies
    from cortex_ti.studies.sweeps import expand_runs, twin_rows

    static = config["static"]
    n_static = len(static["scenes"]) * len(static["nodes"]) * sum(len(f) for f in static["methods"].values())
    rows = {s: expand_runs(s, config[s]["runs"]) for s in configured_studies(config)}
    n_twins = sum(
        len(twin_rows([r for src in spec.twin_of for r in rows[src]], spec.columns))
        for spec in STUDIES.values()
        if spec.twin_of
    )
    return n_static + sum(map(len, rows.values())) + n_twins


def _sacct(run_id: str, since: str) -> list[dict[str, str]]:
    fields = ["JobIDRaw", "State", "ExitCode", "Account", "Partition", "Submit", "Start", "End", "ElapsedRaw"]
    res = subprocess.run(
        ["sacct", "-X", "-n", "-P", "--name", run_id, "-S", since, "-E", "now", "-o", ",".join(fields)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert res.returncode == 0, res.stderr
    return [dict(zip(fields, line.split("|"), strict=False)) for line in res.stdout.splitlines() if line.strip()]


def test_small_configuration_through_the_slurm_profile(cluster, tmp_path):
    pytest.importorskip("snakemake_executor_plugin_slurm")
    xr = pytest.importorskip("xarray")
    from cortex_ti.studies.registry import TABLES, stores_of

    config = yaml.safe_load(CONFIG.read_text())
    workdir = tmp_path / "work"
    workdir.mkdir()
    since = time.strftime("%Y-%m-%dT%H:%M:%S", time.localtime(time.time() - 60))
    # the Python that runs the tests runs Snakemake; the Snakefile puts its bin folder on PATH,
    # which the jobs inherit (the plugin submits with --export=ALL)
    cmd = [
        sys.executable,
        "-m",
        "snakemake",
        "-s",
        str(ROOT / "Snakefile"),
        "--directory",
        str(workdir),
        "--profile",
        str(_profile(tmp_path)),
        # the stores and tables, not the figures: they are drawn locally, the same code as in
        # test_workflow.py's tiny configuration, and would only add local CPU time here
        # (targets before --configfile, which takes every word after it)
        *[f"results/aggregate/{name}.nc" for name in stores_of(config)],
        *[f"results/figures/{table}.html" for table in TABLES],
        "--configfile",
        str(CONFIG),
    ]
    t0 = time.monotonic()
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=900, cwd=workdir)
    TIMINGS["snakemake"] = time.monotonic() - t0
    t_end = time.time()
    log = res.stdout + res.stderr
    (tmp_path / "snakemake.log").write_text(log)
    assert res.returncode == 0, log[-5000:]

    # every simulation job went through SLURM, the light rules ran here
    n_jobs = _n_simulation_jobs(config)
    submitted = re.findall(r"has been submitted with SLURM jobid (\d+)", log)
    assert len(submitted) == n_jobs, f"{len(submitted)} submissions, expected {n_jobs}"
    run_id = re.search(r"SLURM run ID: (\S+)", log).group(1)
    jobs = _sacct(run_id, since)
    assert sorted(j["JobIDRaw"] for j in jobs) == sorted(submitted)
    assert all(j["State"] == "COMPLETED" and j["ExitCode"] == "0:0" for j in jobs), jobs
    assert {(j["Account"], j["Partition"]) for j in jobs} == {(ACCOUNT, PARTITION)}
    # tracked: Snakemake finished soon after the last job (polls every POLL s, then the local
    # aggregation and figures: 25 s on the idle 2-core machine, 65 s when it was shared),
    # not by a timeout
    stamp = lambda s: time.mktime(time.strptime(s, "%Y-%m-%dT%H:%M:%S"))  # noqa: E731
    last_end = max(stamp(j["End"]) for j in jobs)
    TIMINGS["first submit to last job end"] = last_end - min(stamp(j["Submit"]) for j in jobs)
    TIMINGS["job time (sum)"] = sum(int(j["ElapsedRaw"]) for j in jobs)
    TIMINGS["after last job"] = t_end - last_end
    assert t_end - last_end < 240, f"Snakemake ended {t_end - last_end:.0f} s after the last job"

    # the stores (convergence, furrow, fold, reorientation, cost), openable
    for name in stores_of(config):
        path = workdir / "results" / "aggregate" / f"{name}.nc"
        assert path.stat().st_size > 0, path
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            assert ds.sizes and ds.data_vars, name
            if name == "cost":
                assert ds.sizes["run"] == n_jobs
                assert (ds["status"].values == "failed").sum() == 1  # the deliberately unstable point
    for table in TABLES:
        assert (workdir / "results" / "figures" / f"{table}.html").stat().st_size > 0, table


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-v", "-s"]))
