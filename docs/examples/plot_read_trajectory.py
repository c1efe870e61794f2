"""
Reading a trajectory with xarray
================================

A trajectory file is netCDF4 (HDF5): xarray opens it as it is, with units and definitions on every
variable. We run a short furrow on a 162-node mesh and keep its file (``ct.run(..., output=...)``),
read it back with ``ct.open_trajectory`` (and with plain xarray: the same variables), and plot the
furrow radius over time against its axisymmetric twin (the same scene with
``model: axisymmetric``, the in-house truth).
"""

# %%
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import xarray as xr

import cortex_ti as ct

out = Path(tempfile.mkdtemp())
ct.run("furrow_p4_a1", out / "p4.h5", nodes=162, t_end=0.5)
twin = ct.run("furrow_p4_a1", out / "p4_ax.h5", nodes=162, t_end=0.5, model="axisymmetric")

# %%
# What the file holds, and what made it (the provenance attributes).
ds = ct.open_trajectory(out / "p4.h5")  # in memory; the file is closed again
print(ds.furrow_radius.attrs["long_name"], "[", ds.furrow_radius.attrs["units"], "]")
print({k: ds.attrs[k] for k in ("cortex_ti_version", "cortex_ti_commit", "taichi_version")})
with xr.open_dataset(out / "p4.h5", engine="h5netcdf") as plain:  # plain xarray reads the same file
    print("plain xarray:", plain.furrow_radius.equals(ds.furrow_radius))

# %%
# The furrow radius over time, 3D at 162 nodes against the axisymmetric solution.
fig, ax = plt.subplots(figsize=(6, 4))
ds.furrow_radius.plot(ax=ax, label="3D, 162 nodes")
twin.furrow_radius.plot(ax=ax, label="axisymmetric", ls="--")
ax.set_ylabel("furrow radius (R0)")
ax.legend()
print(f"largest difference: {abs(ds.furrow_radius - twin.furrow_radius.interp(time=ds.time)).max().item():.1e} R0")
