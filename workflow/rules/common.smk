# Sweep tables (config -> one row per run), run folders, job resources, and the lists of stores,
# figures and tables: everything the rules compute, in one place (the registry of studies and
# figures is cortex_ti.studies.registry).
import os
import shlex
from pathlib import Path

import pandas as pd
from snakemake.utils import Paramspace

from cortex_ti.physics.formulations import FORMULATIONS
from cortex_ti.studies.registry import FIGURES, STUDIES, TABLE_CATEGORY, TABLES, configured_studies, figures_of, stores_of
from cortex_ti.studies.sweeps import expand_runs, job_resources as estimate_resources, scene_overrides, twin_key, twin_rows


def _space(study, rows):
    return Paramspace(pd.DataFrame(rows, columns=list(STUDIES[study].columns), dtype=str), single_wildcard="params")


# One Paramspace per study: a run's folder is named after its parameters,
# e.g. results/runs/furrow/scene~furrow_p8_a1/zeta_hat~1/p~8/nodes~2562/fit~quadratic/...
# The configured studies first (an optional one only if the config has it); then the derived ones
# (the axisymmetric twins of their runs).
SPACES = {s: _space(s, expand_runs(s, config[s]["runs"])) for s in configured_studies(config)}
SPACES.update({
    s: _space(s, twin_rows([r for src in spec.twin_of for r in SPACES[src].dataframe.to_dict("records")],
                           spec.columns))
    for s, spec in STUDIES.items() if spec.twin_of
})
FORMATS = config["figures"].get("formats", ["png", "pdf"])
STATIC = config["static"]
# (scene, nodes, formulation, fit): the fits each formulation is asked for (config static.methods)
STATIC_RUNS = [(s, n, form, f) for s in STATIC["scenes"] for n in STATIC["nodes"]
               for form, fits in STATIC["methods"].items() for f in fits]
# one folder per static run, and its files
STATIC_RUN = {name: os.path.join("results", "runs", "static", "{scene}", "{formulation}", "N{nodes}_{fit}", name)
              for name in ("trajectory.h5", "summary.json", "run.log", "benchmark.tsv")}

STORES = stores_of(config)
STORE_FILES = expand("results/aggregate/{store}.nc", store=STORES)
FIGURE_FILES = expand("results/figures/{name}.{fmt}", name=figures_of(config), fmt=FORMATS)
TABLE_FILES = expand("results/figures/{name}.html", name=list(TABLES))


wildcard_constraints:
    study="|".join(s for s, spec in STUDIES.items() if not spec.failures_are_data),
    store="|".join(STORES),
    name="|".join([*figures_of(config), *TABLES]),
    scene=r"[^/]+",
    nodes=r"\d+",
    fit=r"[a-z_]+",
    formulation="|".join(FORMULATIONS),


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
    return [pattern.format(scene=s, nodes=n, formulation=form, fit=f) for s, n, form, f in STATIC_RUNS]


def twin_trajectory(study, row):
    """The trajectory of a run's axisymmetric twin (None without one)."""
    for twin, spec in STUDIES.items():
        if study in spec.twin_of:
            key = twin_key(row)
            for pattern, trow in zip(SPACES[twin].instance_patterns, run_rows(twin)):
                if twin_key(trow) == key:
                    return f"results/runs/{twin}/{pattern}/trajectory.h5"
    return None


def cost_runs():
    """Every run of the workflow as (study, label, parameters, summary file, twin trajectory or
    None), for the cost store."""
    out = [("static", f"{s} N={n} {form} {f}", {"scene": s, "nodes": n, "formulation": form, "fit": f},
            STATIC_RUN["summary.json"].format(scene=s, nodes=n, formulation=form, fit=f), None)
           for s, n, form, f in STATIC_RUNS]
    for study in SPACES:
        for pattern, row in zip(SPACES[study].instance_patterns, run_rows(study)):
            out.append((study, pattern, row, f"results/runs/{study}/{pattern}/summary.json",
                        twin_trajectory(study, row)))
    return out


COST_RUNS = cost_runs()


# The frame times a study's runs must have: every time a figure drawn from its trajectories asks
# for (its *_times options, e.g. the paper's snapshot times 3.5e-3, 3.5e-2, 8.7e-2), so the figure
# shows the run at that time rather than at the nearest saved frame.
FRAME_TIMES = {
    study: sorted({float(t) for spec in FIGURES.values() if spec.source == "runs" and study in spec.data
                   for opt in spec.options if opt.endswith("_times") for t in config["figures"].get(opt, [])})
    for study in STUDIES
}


def overrides(row, study=None):
    """The run's ``--set`` options: its sweep values, and the frame times its figures need."""
    sets = scene_overrides(row)
    if FRAME_TIMES.get(study):
        sets.append("time.save_times=[" + ", ".join(f"{t:g}" for t in FRAME_TIMES[study]) + "]")
    return " ".join(f"--set {shlex.quote(o)}" for o in sets)


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


def figure_inputs(wildcards):
    """A figure's stores, or the trajectories of its studies (in the order of their tables)."""
    spec = FIGURES[wildcards.name]
    if spec.source == "store":
        return [f"results/aggregate/{store}.nc" for store in spec.data]
    if spec.source == "static":
        # the registered resolution and method if the config runs them, else the nearest it has
        nodes = int(spec.data[0]) if int(spec.data[0]) in STATIC["nodes"] else max(STATIC["nodes"])
        methods = STATIC["methods"]
        form = spec.data[2] if spec.data[2] in methods else next(iter(methods))
        fit = spec.data[1] if spec.data[1] in methods[form] else methods[form][0]
        return [STATIC_RUN["trajectory.h5"].format(scene=s, nodes=nodes, formulation=form, fit=fit)
                for s in STATIC["scenes"]]
    return [f for study in spec.data for f in study_files("results/runs/{study}/{params}/trajectory.h5", study)]


def figure_rows(wildcards):
    """The sweep-table rows of a figure's trajectories, by study."""
    spec = FIGURES[wildcards.name]
    return {study: run_rows(study) for study in spec.data} if spec.source == "runs" else {}
