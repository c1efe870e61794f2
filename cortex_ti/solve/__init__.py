"""The linear algebra of one force-balance solve.

Owns the problem statements (``system``: a sparse least-squares system, or a symmetric
positive semidefinite energy system, each with dense constraints; the rigid-motion rows), the
sparse factorisations chosen by name (``factorizations``, registry
:data:`~cortex_ti.solve.factorizations.FACTORIZATIONS`), GMRES preconditioned on the right
(``krylov``) and the constrained solve with its bordered Schur complement, factorisation reuse
(and the rule for when to refactorise) and iterative refinement (``constrained``). Imports only
numpy, SciPy, the optional factorisation packages and :mod:`cortex_ti.errors`: it knows nothing
of the physics that built the system.
"""
