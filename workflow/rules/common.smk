# Sweep tables (config -> one row per run), run folders, job resources, and the lists of stores,
# figures and tables: everything the rules compute, in one place (the registry of studies and
# figures is cortex_ti.studies.registry).
import shlex
from pathlib import Path

import pandas as pd
from snakemake.utils import Paramspace

from cortex_ti.studies.registry import FIGURES, STORES, STUDIES, TABLE_CATEGORY, TABLES
from cortex_ti.studies.sweeps import expand_runs, job_resources as estimate_resources, scene_overrides

# One Paramspace per study: a run's folder is named after its parameters,
# e.g. results/runs/furrow/scene~furrow_p8_a1/zeta_hat~1/p~8/nodes~2562/fit~quadratic/...
SPACES = {
    study: Paramspace(
        pd.DataFrame(expand_runs(study, config[study]["runs"]), columns=list(STUDIES[study].columns), dtype=str),
        single_wildcard="params",
    )
    for study in STUDIES
}
FORMATS = config["figures"].get("formats", ["png", "pdf"])
STATIC = config["static"]
STATIC_RUNS = [(s, n, f) for s in STATIC["scenes"] for n in STATIC["nodes"] for f in STATIC["fit"]]

STORE_FILES = expand("results/aggregate/{store}.nc", store=STORES)
FIGURE_FILES = expand("results/figures/{name}.{fmt}", name=list(FIGURES), fmt=FORMATS)
TABLE_FILES = expand("results/figures/{name}.html", name=list(TABLES))


wildcard_constraints:
    study="|".join(s for s, spec in STUDIES.items() if not spec.failures_are_data),
    store="|".join(STORES),
    name="|".join([*FIGURES, *TABLES]),
    scene=r"[^/]+",
    nodes=r"\d+",
    fit=r"[a-z_]+",


def run_rows(study):
    """The study's sweep table, one dict of strings per run."""
    return SPACES[study].dataframe.to_dict("records")


def run_row(wildcards, study=None):
    return SPACES[study or wildcards.study].instance(wildcards)


def study_files(pattern, study):
    """``pattern`` (a rule's output with {study} and {params}) for every run of ``study``."""
    return expand(pattern, study=study, params=SPACES[study].instance_patterns)


def static_files(pattern):
    """``pattern`` (run_static's output) for every static run."""
    return [pattern.format(scene=s, nodes=n, fit=f) for s, n, f in STATIC_RUNS]


def cost_runs():
    """Every run of the workflow as (study, label, parameters, summary file), for the cost store."""
    out = [("static", f"{s} N={n} {f}", {"scene": s, "nodes": n, "fit": f},
            f"results/runs/static/{s}/N{n}_{f}/summary.json") for s, n, f in STATIC_RUNS]
    for study in STUDIES:
        for pattern, row in zip(SPACES[study].instance_patterns, run_rows(study)):
            out.append((study, pattern, row, f"results/runs/{study}/{pattern}/summary.json"))
    return out


COST_RUNS = cost_runs()


def overrides(row):
    return " ".join(f"--set {shlex.quote(o)}" for o in scene_overrides(row))


def job_resources(study, nodes):
    """Memory (MB) and runtime (minutes) of a job, from the benchmark files of earlier runs of
    the same study at the same resolution (1.5 x the largest seen), else a default by N."""
    return estimate_resources(sorted(Path("results/runs").glob(f"{study}/**/benchmark.tsv")), nodes)


def figure_report(fmt):
    """A figure file of any name; the PNG goes into the report with its registered caption and section."""
    path = f"results/figures/{{name}}.{fmt}"
    if fmt != "png":
        return path
    return report(path, caption="../report/figure.rst", category=lambda wc: FIGURES[wc.name].category)


def figure_rows(wildcards):
    spec = FIGURES[wildcards.name]
    return run_rows(spec.data) if spec.source == "runs" else []
