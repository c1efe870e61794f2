"""Truths: exact solutions the tests, the benchmarks and the validation studies compare the code with.

Owns the analytic flows on a static sphere and the error measures of paper Eqs. 57-58
(``analytic``) and the exact spectral flow on a sphere for any pattern, with bending viscosity
(``sphere_exact``, written from its own derivation, with its spherical harmonics in
``spherical_harmonics``; they import nothing else of the package), the sphere between a cytoplasm
and a medium (``fluid_sphere``: Lamb's solution with the cortex's viscosities; flows, shape
relaxation, sedimentation, Faxén's laws), and the shape-mode rates of a sphere with Helfrich
bending rigidity (``helfrich_sphere``, likewise). Production
code (everything but ``studies``, which draws the validation figures, and the deprecated
``analysis.analytic`` / ``analysis.sphere_exact`` paths that forward here) never imports a truth:
``tests/repository/test_layers.py`` refuses it, so a solver cannot come to agree with its own
reference. May import ``physics.patterns`` and ``physics.spherical`` (to evaluate a pattern).
"""
