"""
A short furrow
==============

A contractile ring (paper Eq. 59, :math:`p = 8`) pulls in a furrow while the poles extend
(paper Figs. 4-5). Here on a 642-node mesh to :math:`t = 0.3\\,t_a` (the paper runs 2562 nodes
to :math:`t = 3`), with the scene's defaults otherwise: ``rayleigh_p1``, Euler at
:math:`dt = 5\\cdot 10^{-3}` with the semi-implicit tension.
"""

# %%
import matplotlib.pyplot as plt

import cortex_ti as ct
from cortex_ti.viz.plotting import plot_frame, plot_timeseries

ds = ct.run("furrow_p8_a1", nodes=642, t_end=0.3)  # the trajectory in memory (no file kept)
print(f"{ds.sizes['time']} frames to t = {float(ds.time[-1]):.2f}, {ds.sizes['node']} nodes")

# %%
# The last frame coloured by the active tension, and the radii over time.
fig = plt.figure(figsize=(10, 4))
plot_frame(ds, -1, color="active_stress", ax=fig.add_subplot(1, 2, 1, projection="3d"))
plot_timeseries(ds, ["pole_radius", "furrow_radius"], ax=fig.add_subplot(1, 2, 2))
fig.tight_layout()
