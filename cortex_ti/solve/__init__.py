"""The linear algebra of one force-balance solve.

Owns the problem statement (``system``: a sparse least-squares system with dense constraints,
and the rigid-motion rows), the sparse factorisations chosen by name (``factorizations``,
registry :data:`~cortex_ti.solve.factorizations.FACTORIZATIONS`) and the constrained solve with
its bordered Schur complement and factorisation reuse (``constrained``). Imports only numpy,
SciPy and :mod:`cortex_ti.errors`: it knows nothing of the physics that built the system.
"""
