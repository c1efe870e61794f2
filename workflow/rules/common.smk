# Sweep tables (config -> one row per run), run folders and the lists of stores and figures.
import shlex
from pathlib import Path

import pandas as pd
from snakemake.utils import Paramspace

from cortex_ti.sweeps import STUDY_COLUMNS, expand_runs, scene_overrides

STUDIES = ("furrow", "fold", "reorientation", "accuracy")
TIME_STUDIES = ("furrow", "fold", "reorientation")

# One Paramspace per study: a run's folder is named after its parameters,
# e.g. results/runs/furrow/scene~furrow_p8_a1/zeta_hat~1/p~8/nodes~2562/fit~quadratic/...
SPACES = {
    study: Paramspace(
        pd.DataFrame(expand_runs(study, config[study]["runs"]), columns=list(STUDY_COLUMNS[study]), dtype=str),
        single_wildcard="params",
    )
    for study in STUDIES
}
FORMATS = config["figures"].get("formats", ["png", "pdf"])
STATIC = config["static"]


wildcard_constraints:
    study="|".join(TIME_STUDIES),
    scene=r"[^/]+",
    nodes=r"\d+",
    fit="quadratic|quartic",


def run_dirs(study):
    return [f"results/runs/{study}/{p}" for p in SPACES[study].instance_patterns]


def run_rows(study):
    return SPACES[study].dataframe.to_dict("records")


def static_dirs():
    return [f"results/runs/static/{s}/N{n}_{f}" for s in STATIC["scenes"] for n in STATIC["nodes"] for f in STATIC["fit"]]


def run_row(wildcards, study=None):
    return SPACES[study or wildcards.study].instance(wildcards)


def overrides(row):
    return " ".join(f"--set {shlex.quote(o)}" for o in scene_overrides(row))


def figure_files(name):
    return expand("results/figures/{name}.{fmt}", name=name, fmt=FORMATS)


STORES = [f"results/aggregate/{s}.nc" for s in ("convergence", *TIME_STUDIES, "cost")]
FIGURE_NAMES = ["convergence", "furrow_radii", "velocity_profiles", "fold_depth", "snapshots_fold", "orientation",
                "snapshots_reorientation", "accuracy_cost"]
FIGURES = [f for n in FIGURE_NAMES for f in figure_files(n)]

# the environment of every simulation job: its threads for Taichi and the BLAS/PARDISO
THREADS_ENV = "CORTEX_TI_THREADS={threads} OMP_NUM_THREADS={threads} MKL_NUM_THREADS={threads} "
# continue an interrupted run (its frames are flushed to <trajectory>.partial as they go)
RESUME = "$( [ -f {output.trajectory}.partial ] && echo --resume )"


def job_resources(study, nodes):
    """Memory (MB) and runtime (minutes) of a job, from the benchmark files of earlier runs of
    the same study at the same resolution (1.5 x the largest seen), else a default by N."""
    from cortex_ti.sweeps import job_resources as estimate

    return estimate(sorted(Path("results/runs").glob(f"{study}/**/benchmark.tsv")), nodes)
