# One job per simulation. Each writes its trajectory (netCDF4/HDF5), a run summary (JSON) and a
# Snakemake benchmark file, with its `threads` given to Taichi and the BLAS/PARDISO; an
# interrupted job resumes from its flushed frames. Resources for a cluster: common.smk.


rule run_static:
    output:
        trajectory=STATIC_RUN["trajectory.h5"],
        summary=STATIC_RUN["summary.json"],
    log:
        STATIC_RUN["run.log"],
    benchmark:
        STATIC_RUN["benchmark.tsv"]
    threads: config["threads"]
    resources:
        mem_mb=lambda wc: job_resources("static", int(wc.nodes))["mem_mb"],
        runtime=lambda wc: job_resources("static", int(wc.nodes))["runtime"],
    shell:
        "CORTEX_TI_THREADS={threads} OMP_NUM_THREADS={threads} MKL_NUM_THREADS={threads} "
        "cortex-ti -v run {wildcards.scene} -o {output.trajectory} --summary {output.summary} "
        "--set mesh.nodes={wildcards.nodes} --set numerics.formulation={wildcards.formulation} "
        "--set numerics.fit={wildcards.fit} > {log} 2>&1"


rule run_dynamic:
    output:
        trajectory="results/runs/{study}/{params}/trajectory.h5",
        summary="results/runs/{study}/{params}/summary.json",
    log:
        "results/runs/{study}/{params}/run.log",
    benchmark:
        "results/runs/{study}/{params}/benchmark.tsv"
    params:
        scene=lambda wc: run_row(wc)["scene"],
        overrides=lambda wc: overrides(run_row(wc), wc.study),
    threads: config["threads"]
    resources:
        mem_mb=lambda wc: job_resources(wc.study, int(run_row(wc).get("nodes", 0)))["mem_mb"],
        runtime=lambda wc: job_resources(wc.study, int(run_row(wc).get("nodes", 0)))["runtime"],
    shell:
        "CORTEX_TI_THREADS={threads} OMP_NUM_THREADS={threads} MKL_NUM_THREADS={threads} "
        "cortex-ti -v run {params.scene} -o {output.trajectory} --summary {output.summary} {params.overrides} "
        "$( [ -f {output.trajectory}.partial ] && echo --resume ) > {log} 2>&1"


# The accuracy sweep deliberately includes configurations that may go unstable: such a run
# still succeeds as a job, with status "failed" and the reason in its summary, and shows up
# as a failed point in the accuracy-vs-cost figure. Its trajectory (when it finished) sits
# beside the summary.
rule run_accuracy:
    output:
        summary="results/runs/accuracy/{params}/summary.json",
    log:
        "results/runs/accuracy/{params}/run.log",
    benchmark:
        "results/runs/accuracy/{params}/benchmark.tsv"
    params:
        scene=lambda wc: run_row(wc, "accuracy")["scene"],
        overrides=lambda wc: overrides(run_row(wc, "accuracy")),
        trajectory=lambda wc, output: Path(output.summary).with_name("trajectory.h5"),
    threads: config["threads"]
    resources:
        mem_mb=lambda wc: job_resources("accuracy", int(run_row(wc, "accuracy")["nodes"]))["mem_mb"],
        runtime=lambda wc: job_resources("accuracy", int(run_row(wc, "accuracy")["nodes"]))["runtime"],
    shell:
        "rm -f {params.trajectory} {params.trajectory}.partial; "
        "CORTEX_TI_THREADS={threads} OMP_NUM_THREADS={threads} MKL_NUM_THREADS={threads} "
        "cortex-ti -v run {params.scene} -o {params.trajectory} --summary {output.summary} {params.overrides} "
        "> {log} 2>&1 || test -s {output.summary}"
