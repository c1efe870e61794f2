"""The physics of the cortex: active-stress patterns, the force-balance terms and their assembly.

Owns the vocabulary of effects and the coefficients a run uses (``model``), the active-stress
patterns (``patterns``, ``user_patterns``; registry
:data:`~cortex_ti.physics.patterns.PATTERNS`), functions on the sphere (``spherical``), one module
per physical term (``terms/``, registry :data:`~cortex_ti.physics.terms.TERMS`; each term says
what it adds to every formulation), and the discretisations of the force balance a scene chooses
(``formulations``, registry :data:`~cortex_ti.physics.formulations.FORMULATIONS`): the paper's
strong form (``assembly``) and the Rayleighian on the flat triangles (``galerkin``), each looping
over the switched-on terms; the flat-triangle blocks that a term and a formulation both use live
in ``p1_blocks`` (a term imports no formulation). May import ``surface`` and ``solve.system`` (the systems it
produces); not scenes, dynamics or I/O. The registries import no Taichi (the scene layer reads
them); the assemblies and the paper's viscous kernel load it when they first run.
"""

# the pattern types register themselves on import: the built-in ones (patterns) and the user's
# field and python patterns (user_patterns), before anything reads the registry
from . import patterns, user_patterns  # noqa: E402,F401
