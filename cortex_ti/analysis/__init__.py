"""Measuring results: shape diagnostics, exact solutions and reference data.

Owns the per-frame diagnostics of a shape (``diagnostics``: volume, radii, orientation, fold,
mesh quality), the analytic solutions on a static sphere and the error measures of paper
Eqs. 57-58 (``analytic``), and the comparison with the shipped external axisymmetric reference
(``reference``, data in ``cortex_ti/data/axisym``), and the exact spectral flow on a sphere for
any pattern (``sphere_exact``, which imports nothing of the package: it is a truth for tests).
May import ``physics.patterns`` and ``physics.spherical`` (to evaluate a pattern); never the
solver, and no file beyond its own data.
"""
