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
import matplotlib.pyplot as plt
import numpy as np

import cortex_ti as ct
from cortex_ti.truth.analytic import error_measures, scene_solution

results = {}
for formulation, fit in [("paper", "quartic"), ("rayleigh_p1", "quadratic")]:
    scene = ct.load_scene("sphere_y20_full", nodes=642, formulation=formulation, numerics__fit=fit)
    results[formulation] = (scene, ct.run(scene))  # the trajectory in memory: one frame

# %%
# The exact flow at the same nodes, and the paper's error measure eps_rel (Eq. 58).
fig, ax = plt.subplots(figsize=(6, 4))
for formulation, (scene, ds) in results.items():
    points = ds.points.values[0]
    v = ds.velocity.values[0]
    exact = scene_solution(scene.settings, points)
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
