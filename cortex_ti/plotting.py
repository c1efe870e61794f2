"""Deprecated: moved to :mod:`cortex_ti.viz.plotting` (pictures of a run live in their layer).

``from cortex_ti.plotting import x`` still works in this release, with a
:class:`DeprecationWarning`; it will be removed in the next one.
"""

from __future__ import annotations

import warnings


def __getattr__(name: str):
    from .viz import plotting as _moved

    if name.startswith("__") or not hasattr(_moved, name):  # probes (doctest, pytest, pickle): not a use
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    warnings.warn(
        "cortex_ti.plotting moved to cortex_ti.viz.plotting; the old path goes in the next release",
        DeprecationWarning,
        stacklevel=2,
    )
    return getattr(_moved, name)
