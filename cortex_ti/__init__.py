"""cortex-ti: the three-dimensional viscous active cell cortex of Bächer et al., Front. Phys. 9:753230 (2021).

Units throughout: lengths in the initial radius R0 = 1, viscosities in eta_s = 1,
times in t_a = eta_s / zeta_0. Sign conventions: outward normal n, curvature
C_ab = -n . d_a d_b X (a sphere has C = 2/R > 0), zeta > 0 is contractile tension,
P = p_inside - p_outside.

The Python front door (:mod:`cortex_ti.api`)::

    import cortex_ti as ct
    ds = ct.run("furrow_p8_a1", nodes=642, t_end=0.3)   # an xarray Dataset
"""

from .about import package_version, provenance

#: The version from the repository's tags (setuptools-scm), see :mod:`cortex_ti.about`
__version__ = package_version()

from .api import load_scene, open_trajectory, run, scenes  # noqa: E402  (light: imports nothing heavy)

__all__ = ["__version__", "provenance", "run", "load_scene", "open_trajectory", "scenes"]
