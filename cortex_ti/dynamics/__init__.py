"""Time: how a shape advances, and what stops a run that goes wrong.

Owns the time schemes (``schemes``, registry :data:`~cortex_ti.dynamics.schemes.SCHEMES`, with
the rules that belong to a scheme as class properties; ``bdf3`` in its own module, imported here so
that reading the registry registers it), the stability guard (``guard``), when a run
remeshes and with which options (``remesh_policy``; how, is ``surface.remesh``), the
integration loop with its frame times (``integrate``) and the spectrum of the linearised
normal dynamics (``spectrum``; one sphere mode's rate by two solves in ``mode_rates``). The loop
works on any ``evaluate(points, dt)`` callable; the
spectrum linearises a simulation's own system (it asks it for ``shape_geometry`` and
``system``) and factorises with :mod:`cortex_ti.solve`. Imports numpy, scipy,
:mod:`cortex_ti.errors`, ``solve`` and the shape diagnostics of ``analysis``, never a scene.
"""

from . import bdf3  # noqa: F401  (registration)
