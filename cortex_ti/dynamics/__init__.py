"""Time: how a shape advances, and what stops a run that goes wrong.

Owns the time schemes (``schemes``, registry :data:`~cortex_ti.dynamics.schemes.SCHEMES`, with
the rules that belong to a scheme as class properties), the stability guard (``guard``), the
integration loop with its frame times (``integrate``) and the stiffness of the linearised
normal dynamics (``spectrum``). Works on any ``evaluate(points, dt)`` callable: imports
numpy, :mod:`cortex_ti.errors` and the shape diagnostics of ``analysis``, never the solver.
"""
