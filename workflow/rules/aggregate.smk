# Gather the runs into xarray stores under results/aggregate (units and descriptions in their attributes).


rule convergence:
    input:
        static_files(rules.run_static.output.trajectory),
    output:
        "results/aggregate/convergence.nc",
    log:
        "results/logs/aggregate/convergence.log",
    script:
        "../scripts/aggregate.py"


rule study_store:
    input:
        lambda wc: study_files(rules.run_dynamic.output.trajectory, wc.study),
    output:
        "results/aggregate/{study}.nc",
    params:
        rows=lambda wc: run_rows(wc.study),
    log:
        "results/logs/aggregate/{study}.log",
    script:
        "../scripts/aggregate.py"


rule cost:
    input:
        [summary for _, _, _, summary, _ in COST_RUNS],
    output:
        "results/aggregate/cost.nc",
    params:
        runs=COST_RUNS,
    log:
        "results/logs/aggregate/cost.log",
    script:
        "../scripts/aggregate.py"
