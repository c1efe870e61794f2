"""A dumbbell-shaped closed surface for the division tests: an icosphere whose sections are narrowed
to a neck of radius ``neck`` at z = 0 (``r(z) = neck + (1 - neck)(1 - exp(-(z / width)^2))`` times
the sphere's), stretched ``stretch`` times along z."""

from __future__ import annotations

import numpy as np

from cortex_ti.surface.mesh import icosphere


def dumbbell(nodes: int = 642, neck: float = 0.15, width: float = 0.35, stretch: float = 1.3):
    """``(points, faces)`` of the dumbbell (module docstring), outward oriented."""
    m = icosphere(nodes)
    p = m.points.copy()
    f = neck + (1.0 - neck) * (1.0 - np.exp(-((p[:, 2] / width) ** 2)))
    p[:, 0] *= f
    p[:, 1] *= f
    p[:, 2] *= stretch
    return p, m.faces.copy()
