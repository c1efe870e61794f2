"""Deprecated: moved to :mod:`cortex_ti.truth.analytic` (the truths live apart from production code).

``from cortex_ti.analysis.analytic import x`` still works in this release, with a
:class:`DeprecationWarning`; it will be removed in the next one.
"""

from __future__ import annotations

import warnings


def __getattr__(name: str):
    from ..truth import analytic as _moved

    if name.startswith("__") or not hasattr(_moved, name):  # probes (doctest, pytest, pickle): not a use
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(
        "cortex_ti.analysis.analytic moved to cortex_ti.truth.analytic; the old path goes in the next release",
        DeprecationWarning,
        stacklevel=2,
    )
    return getattr(_moved, name)
