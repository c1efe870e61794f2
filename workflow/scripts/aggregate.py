"""Aggregate runs into an xarray store (rules convergence, study_store, cost in aggregate.smk)."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from pathlib import Path  # noqa: E402

from cortex_ti.io import write_dataset  # noqa: E402
from cortex_ti.studies.convergence import convergence_dataset  # noqa: E402
from cortex_ti.studies.stores import (  # noqa: E402
    cost_dataset,
    study_dataset,
    trajectory_deviation,
    twin_deviation,
)

sm = snakemake  # noqa: F821
if sm.rule == "convergence":
    ds = convergence_dataset(sm.input)
elif sm.rule == "study_store":
    ds = study_dataset(sm.wildcards.study, sm.params.rows, list(sm.input))
else:  # cost: one entry per run of every study, with the error against the reference where one exists
    entries = []
    for study, label, row, summary, twin in sm.params.runs:
        folder = Path(summary).parent
        traj = folder / "trajectory.h5"
        ran = study != "static" and traj.exists()
        dev = twin_deviation(traj, twin) if ran and twin else None
        ext = trajectory_deviation(traj) if ran else None
        entries.append(
            {
                "study": study,
                "run": f"{study}/{label}",
                "params": row,
                "error": max(dev["pole"], dev["furrow"]) if dev else float("nan"),
                "error_external": max(ext["pole"], ext["furrow"]) if ext else float("nan"),
                "benchmark": folder / "benchmark.tsv",
                "summary": summary,
            }
        )
    ds = cost_dataset(entries)
write_dataset(ds, sm.output[0])
