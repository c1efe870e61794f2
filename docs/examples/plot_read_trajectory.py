"""
Reading a trajectory with xarray
================================

A trajectory file is netCDF4 (HDF5): xarray opens it as it is, with units and definitions on every
variable. We run a short furrow on a 162-node mesh, open the file with plain xarray, and plot the
furrow radius over time against its axisymmetric twin (the same scene with
``model: axisymmetric``, the in-house truth).
"""

# %%
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import xarray as xr

from cortex_ti.axisymmetric.run import AxisymmetricRun
from cortex_ti.scene import load_scene
from cortex_ti.simulation.core import Simulation

out = Path(tempfile.mkdtemp())
overrides = ["mesh.nodes=162", "time.t_end=0.5"]
Simulation(load_scene("furrow_p4_a1", overrides)).run(out / "p4.h5", progress=False)
AxisymmetricRun(load_scene("furrow_p4_a1", [*overrides, "model=axisymmetric"])).run(out / "p4_ax.h5")

# %%
# What the file holds, and what made it (the provenance attributes).
ds = xr.open_dataset(out / "p4.h5", engine="h5netcdf")
print(ds.furrow_radius.attrs["long_name"], "[", ds.furrow_radius.attrs["units"], "]")
print({k: ds.attrs[k] for k in ("cortex_ti_version", "cortex_ti_commit", "taichi_version")})

# %%
# The furrow radius over time, 3D at 162 nodes against the axisymmetric solution.
twin = xr.open_dataset(out / "p4_ax.h5", engine="h5netcdf")
fig, ax = plt.subplots(figsize=(6, 4))
ds.furrow_radius.plot(ax=ax, label="3D, 162 nodes")
twin.furrow_radius.plot(ax=ax, label="axisymmetric", ls="--")
ax.set_ylabel("furrow radius (R0)")
ax.legend()
print(f"largest difference: {abs(ds.furrow_radius - twin.furrow_radius.interp(time=ds.time)).max().item():.1e} R0")
