# cortex-ti workflow: `snakemake --cores 2` runs the quick default configuration.
# Rules live in workflow/rules; scripts in workflow/scripts are thin (the physics is in cortex_ti).
configfile: "config/config.yaml"


include: "workflow/rules/static.smk"


rule all:
    default_target: True
    input:
        "results/aggregate/convergence.nc",
