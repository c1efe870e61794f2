"""
The flow on a static sphere against its closed form
===================================================

The simplest scene: a sphere whose active tension is the spherical harmonic :math:`Y_{20}`
(paper Fig. 2). With shear and bulk viscosity, the normal force balance and an incompressible
interior, the exact flow is purely normal, :math:`v = -(R / 2\\eta_b)\\,\\zeta_l\\, n`
(see the conventions page): inward at the poles, outward at the equator. We solve it on a
642-node icosphere with both formulations and compare.
"""

# %%
# Load the built-in scene with a smaller mesh, and solve it once (a static scene writes one frame).
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from cortex_ti.io import Trajectory
from cortex_ti.scene import load_scene
from cortex_ti.simulation.core import Simulation
from cortex_ti.truth.analytic import error_measures, scene_solution

out = Path(tempfile.mkdtemp())
results = {}
for formulation, fit in [("paper", "quartic"), ("rayleigh_p1", "quadratic")]:
    scene = load_scene(
        "sphere_y20_full", ["mesh.nodes=642", f"numerics.formulation={formulation}", f"numerics.fit={fit}"]
    )
    path = Simulation(scene).run(out / f"y20_{formulation}.h5", progress=False)
    results[formulation] = Trajectory(path)

# %%
# The exact flow at the same nodes, and the paper's error measure eps_rel (Eq. 58).
fig, ax = plt.subplots(figsize=(6, 4))
for formulation, tr in results.items():
    points = tr.ds.points.values[0]
    v = tr.ds.velocity.values[0]
    exact = scene_solution(tr.settings, points)
    eps, eps_rel = error_measures(v, exact)
    print(f"{formulation:12s} eps_rel = {eps_rel:.2e}")
    theta = np.arccos(np.clip(points[:, 2] / np.linalg.norm(points, axis=1), -1, 1))
    n = points / np.linalg.norm(points, axis=1, keepdims=True)
    ax.plot(theta, np.einsum("ij,ij->i", v, n), ".", ms=3, label=f"{formulation}: v_n at the nodes")
order = np.argsort(theta)
ax.plot(theta[order], np.einsum("ij,ij->i", exact, n)[order], "k-", lw=1, label="exact")
ax.set_xlabel("polar angle θ")
ax.set_ylabel("normal velocity v_n (R0/t_a)")
ax.legend()
fig.tight_layout()
