"""Deprecated: moved to :mod:`cortex_ti.viz.plotting` (pictures of a run live in their layer).

``from cortex_ti.plotting import x`` still works in this release, with a
:class:`DeprecationWarning`; it will be removed in the next one.
"""

from __future__ import annotations

from .errors import moved_to

__getattr__ = moved_to(__name__, "cortex_ti.viz.plotting")
