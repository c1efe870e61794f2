"""Deprecated: moved to :mod:`cortex_ti.truth.sphere_exact` (the truths live apart from production code).

``from cortex_ti.analysis.sphere_exact import x`` still works in this release, with a
:class:`DeprecationWarning`; it will be removed in the next one.
"""

from __future__ import annotations

from ..errors import moved_to

__getattr__ = moved_to(__name__, "cortex_ti.truth.sphere_exact")
