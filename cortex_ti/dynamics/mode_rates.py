"""The linearised rate of one normal shape mode of the unit sphere, by two solves.

A normal displacement ``eps Y_lm`` of the unit sphere's nodes relaxes (or grows) at the rate
``lambda`` with ``v_n = lambda eps Y_lm + O(eps^2)`` plus what the discretisation mixes in from other
degrees. :func:`normal_mode_rate` takes the central difference of the normal speed at ``r = 1 +- eps
Y_lm`` and projects it on ``Y_lm``: with the curved cells' mass matrix on a formulation of curved
cells (:func:`cortex_ti.surface.curved_bending.cell_matrices`), with the dual areas otherwise. It is
a Galerkin projection of the spectrum of :mod:`.spectrum` on one harmonic, for shapes whose
linearisation is not local (the bending rigidity of ``rayleigh_p2`` couples every node through its
mass-matrix solve), at two solves per mode. Like the spectrum tool it asks the simulation for
``shape_geometry``, ``system`` and ``solver`` only.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..physics.spherical import direction_angles, real_sph_harm
from ..surface.transport import dual_areas

__all__ = ["normal_mode_rate"]


def normal_mode_rate(sim, l: int, m: int = 0, eps: float = 1e-4, curved: bool = True) -> float:
    """The rate (1/t_a) of the normal mode ``Y_lm`` of the unit sphere through ``sim``'s mesh nodes
    (module docstring); ``curved``: project with the curved cells' mass matrix (the mesh in their split
    layout), else with the flat triangles' dual areas."""
    x0 = sim.mesh.points / np.linalg.norm(sim.mesh.points, axis=1)[:, None]
    theta, phi = direction_angles(x0)
    y = real_sph_harm(l, m, theta, phi)
    if curved:
        from ..surface.curved import p2_cells
        from ..surface.curved_bending import cell_matrices

        mass = cell_matrices(x0, p2_cells(sim.mesh.faces))[0]
    else:
        mass = sp.diags(dual_areas(x0, sim.mesh.faces))
    speeds = []
    for s in (1.0, -1.0):
        x = x0 * (1.0 + s * eps * y)[:, None]
        geometry = sim.shape_geometry(x)
        system = sim.system(geometry)
        v, _, _ = sim.solver.solve(system, x)
        speeds.append(np.einsum("nc,nc->n", system.velocity(v), geometry.normal))
    d = (speeds[0] - speeds[1]) / (2.0 * eps)
    return float(y @ (mass @ d) / (y @ (mass @ y)))
