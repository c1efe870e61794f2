# Static sphere scenes (paper Sec. 4.1, Figs. 2-3): one job per (scene, nodes, fit).

STATIC = config["static"]


rule run_static:
    output:
        "results/runs/{scene}/N{nodes}_{fit}/trajectory.h5",
    log:
        "results/logs/run_static/{scene}_N{nodes}_{fit}.log",
    benchmark:
        "results/benchmarks/run_static/{scene}_N{nodes}_{fit}.tsv"
    threads: 1
    shell:
        "CORTEX_TI_THREADS={threads} OMP_NUM_THREADS={threads} MKL_NUM_THREADS={threads} "
        "cortex-ti -v run {wildcards.scene} -o {output} "
        "--set mesh.nodes={wildcards.nodes} --set numerics.fit={wildcards.fit} > {log} 2>&1"


rule convergence:
    input:
        expand("results/runs/{scene}/N{nodes}_{fit}/trajectory.h5",
               scene=STATIC["scenes"], nodes=STATIC["nodes"], fit=STATIC["fit"]),
    output:
        "results/aggregate/convergence.nc",
    log:
        "results/logs/convergence.log",
    script:
        "../scripts/convergence.py"
