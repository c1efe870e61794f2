# cortex-ti workflow. `snakemake --cores 2` runs the quick default configuration (config/config.yaml);
# `snakemake --cores N --configfile config/paper.yaml` the paper's resolutions and times.
# Rules live in workflow/rules, thin scripts in workflow/scripts; the physics is in the cortex_ti package.
from snakemake.utils import min_version, validate

min_version("8.0")


configfile: "config/config.yaml"


validate(config, "config/schema/config.schema.yaml")


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/runs.smk"
include: "workflow/rules/aggregate.smk"
include: "workflow/rules/figures.smk"


rule all:
    default_target: True
    input:
        STORES,
        FIGURES,
        "results/figures/cost_table.html",
