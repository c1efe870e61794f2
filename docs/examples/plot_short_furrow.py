"""
A short furrow
==============

A contractile ring (paper Eq. 59, :math:`p = 8`) pulls in a furrow while the poles extend
(paper Figs. 4-5). Here on a 642-node mesh to :math:`t = 0.3\\,t_a` (the paper runs 2562 nodes
to :math:`t = 3`), with the scene's defaults otherwise: ``rayleigh_p1``, Euler at
:math:`dt = 5\\cdot 10^{-3}` with the semi-implicit tension.
"""

# %%
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt

from cortex_ti.io import Trajectory
from cortex_ti.scene import load_scene
from cortex_ti.simulation.core import Simulation
from cortex_ti.viz.plotting import plot_frame, plot_timeseries

scene = load_scene("furrow_p8_a1", ["mesh.nodes=642", "time.t_end=0.3"])
sim = Simulation(scene)
path = sim.run(Path(tempfile.mkdtemp()) / "furrow.h5", progress=False)
print(f"{sim.stats.steps} steps, {sim.stats.solves} solves")

# %%
# The last frame coloured by the active tension, and the radii over time.
ds = Trajectory(path).ds
fig = plt.figure(figsize=(10, 4))
plot_frame(ds, -1, color="active_stress", ax=fig.add_subplot(1, 2, 1, projection="3d"))
plot_timeseries(ds, ["pole_radius", "furrow_radius"], ax=fig.add_subplot(1, 2, 2))
fig.tight_layout()
