"""Measuring results: shape diagnostics, exact solutions and reference data.

Owns the per-frame diagnostics of a shape (``diagnostics``: volume, radii, orientation, fold,
mesh quality; the line and plane sections behind the radii in ``sections``, the flat-triangle
measures in :mod:`cortex_ti.surface.measures`),
the harmonic content of a field (``harmonics``), the linear stability of the
myosin model (``myosin_stability``) and the comparison with the shipped external axisymmetric
reference (``reference``, data in ``cortex_ti/data/axisym``). The exact solutions moved to
:mod:`cortex_ti.truth`; ``analytic`` and ``sphere_exact`` here forward to them with a
deprecation warning for one release.
May import ``physics.patterns`` and ``physics.spherical`` (to evaluate a pattern); never the
solver, and no file beyond its own data.
"""
