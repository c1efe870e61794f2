# Gather the runs into xarray stores under results/aggregate (units and descriptions in their attributes).


rule convergence:
    input:
        [f"{d}/trajectory.h5" for d in static_dirs()],
    output:
        "results/aggregate/convergence.nc",
    log:
        "results/logs/aggregate/convergence.log",
    script:
        "../scripts/aggregate.py"


rule study_store:
    input:
        lambda wc: [f"{d}/trajectory.h5" for d in run_dirs(wc.study)],
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
        summaries=[f"{d}/summary.json" for d in static_dirs()]
        + [f"{d}/summary.json" for s in STUDIES for d in run_dirs(s)],
    output:
        "results/aggregate/cost.nc",
    params:
        runs=[("static", f"{s} N={n} {f}", {"scene": s, "nodes": n, "fit": f}, f"results/runs/static/{s}/N{n}_{f}")
              for s in STATIC["scenes"] for n in STATIC["nodes"] for f in STATIC["fit"]]
        + [(s, p, row, f"results/runs/{s}/{p}") for s in STUDIES
           for p, row in zip(SPACES[s].instance_patterns, run_rows(s))],
    log:
        "results/logs/aggregate/cost.log",
    script:
        "../scripts/aggregate.py"
