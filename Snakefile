# cortex-ti workflow. `snakemake --cores 2` runs the quick default configuration (config/config.yaml);
# `snakemake --cores N --configfile config/paper.yaml` the paper's resolutions and times.
# Rules live in workflow/rules, thin scripts in workflow/scripts; the physics is in the cortex_ti package.
import os

from snakemake.utils import min_version, validate

min_version("8.0")


# the quick default; --configfile FILE overrides it (paths relative to this file, so --directory works)
configfile: os.path.join(workflow.basedir, "config", "config.yaml")


validate(config, "config/schema/config.schema.yaml")


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/runs.smk"
include: "workflow/rules/aggregate.smk"
include: "workflow/rules/figures.smk"


# light jobs: on a cluster they run on the submitting host, not in the queue
localrules:
    all,
    convergence,
    study_store,
    cost,
    cost_table,
    figure_convergence,
    figure_furrow_radii,
    figure_velocity_profiles,
    figure_fold_depth,
    figure_snapshots_fold,
    figure_orientation,
    figure_snapshots_reorientation,
    figure_accuracy_cost,


rule all:
    default_target: True
    input:
        STORES,
        FIGURES,
        "results/figures/cost_table.html",
