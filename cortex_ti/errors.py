"""Errors a user can act on.

Every error raised for bad input derives from :class:`CortexError`; the command
line prints its message (no traceback) and exits non-zero.
"""


class CortexError(Exception):
    """Base class: a problem the user can fix, with a message that names it."""


class SceneError(CortexError):
    """An invalid scene file or override (unknown key, wrong type, bad value)."""


class MeshError(CortexError):
    """A mesh that cannot be used: unreadable, open, non-manifold, badly oriented, degenerate."""


class SolverError(CortexError):
    """The linear solve failed or produced a non-finite result."""


class StabilityError(CortexError):
    """A time step went unstable; the message names the step size to try."""
