# cortex-ti workflow. `snakemake --cores 2` runs the default configuration (config/config.yaml);
# `snakemake --cores N --configfile config/paper.yaml` the extended study.
# Rules live in workflow/rules, thin scripts in workflow/scripts; the studies, stores and figures
# are registered in cortex_ti/studies/registry.py and computed by the cortex_ti package.
import os
import sys

from snakemake.utils import min_version, validate

min_version("8.0")

# Jobs call the `cortex-ti` of the Python environment that runs Snakemake (it imports cortex_ti
# below), activated or not: cluster jobs (sbatch --export=ALL) re-run this file with the same
# interpreter, so they find it too.
_bin = os.path.dirname(sys.executable)
if os.environ.get("PATH", "").split(os.pathsep)[0] != _bin:
    os.environ["PATH"] = os.pathsep.join(p for p in (_bin, os.environ.get("PATH")) if p)


# the jobs need PATH (set above); snakemake passes it on to remote jobs
envvars:
    "PATH",


# the default; --configfile FILE overrides it (paths relative to this file, so --directory works)
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
    figure,
    table,


rule all:
    default_target: True
    input:
        STORE_FILES,
        FIGURE_FILES,
        TABLE_FILES,
