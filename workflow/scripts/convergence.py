"""Aggregate eps and eps_rel (paper Eqs. 57-58) of the static sphere runs into an xarray store."""

import sys

sys.stderr = open(snakemake.log[0], "w")  # noqa: F821

from cortex_ti.convergence import convergence_dataset  # noqa: E402
from cortex_ti.io import write_dataset  # noqa: E402

write_dataset(convergence_dataset(snakemake.input), snakemake.output[0])  # noqa: F821
