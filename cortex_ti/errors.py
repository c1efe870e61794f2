"""Errors a user can act on.

Every error raised for bad input derives from :class:`CortexError`; the command
line prints its message (no traceback) and exits non-zero.

:class:`Interrupted` is how SIGINT and SIGTERM end a command (:func:`interruptible`); it lives
here, at the bottom of the package, so that the command line installs its handlers before any
heavy import.

:func:`moved_to` is the ``__getattr__`` of a module that moved: the old path keeps working for one
release with a :class:`DeprecationWarning` a user can act on (change the import).
"""

import contextlib
import importlib
import signal
import threading
import warnings


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


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived: the run ends as after Ctrl-C (frames kept, summary written)."""

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)

    @property
    def name(self) -> str:
        return signal.Signals(self.signum).name

    @property
    def exit_code(self) -> int:
        """128 + the signal's number, as a shell reports it: 130 for SIGINT, 143 for SIGTERM."""
        return 128 + self.signum


_PENDING: list = []  # signals that arrived in an interruptible() block


@contextlib.contextmanager
def interruptible(restore: bool = True):
    """While in the block, SIGINT and SIGTERM raise :class:`Interrupted` (main thread only).

    The signal is also remembered: should a library swallow the exception (a bare ``except:`` in
    some start-up code), :func:`check_interrupted` raises it again at the run's next step.
    ``restore=False`` leaves the handlers the block ends with (the command line's program ignores
    a signal during its own shutdown, after its work is done)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        _PENDING.append(signum)
        if frame is not None and (frame.f_code.co_name == "__del__" or frame.f_code.co_filename.endswith("weakref.py")):
            return  # Python would print the exception and drop it: check_interrupted raises it instead
        raise Interrupted(signum)

    old = {sig: signal.signal(sig, handler) for sig in (signal.SIGINT, signal.SIGTERM)}
    outer = list(_PENDING)
    try:
        yield
    finally:
        if restore:
            for sig, h in old.items():
                signal.signal(sig, h)
        _PENDING[:] = outer


def check_interrupted() -> None:
    """Raise :class:`Interrupted` if a signal arrived whose exception did not end the run."""
    if _PENDING:
        raise Interrupted(_PENDING[0])


def interruption(exc: BaseException) -> "Interrupted | None":
    """The :class:`Interrupted` behind ``exc``: itself, or the signal that arrived while a library
    turned its exception into another (Taichi's import reports an ``ImportError``); else None."""
    if isinstance(exc, Interrupted):
        return exc
    if _PENDING:
        return Interrupted(_PENDING[0])
    if isinstance(exc, KeyboardInterrupt):
        return Interrupted(signal.SIGINT)
    return None


def thread_count(value=None, what: str = "threads") -> "int | None":
    """The CPU thread count ``value`` (an int, or its text from the command line), else
    ``CORTEX_TI_THREADS``, checked here, before Taichi sees it (Taichi aborts the interpreter on 0
    threads): a whole number >= 1, or None (neither given: all cores). A bad value raises
    :class:`CortexError` naming where it came from.

    >>> thread_count(2), thread_count("3", "--threads")
    (2, 3)
    >>> thread_count(0)
    Traceback (most recent call last):
    ...
    cortex_ti.errors.CortexError: threads must be a whole number >= 1, got 0
    """
    import os

    if value is None:
        text, what = os.environ.get("CORTEX_TI_THREADS", "").strip(), "CORTEX_TI_THREADS"
        if not text:
            return None
        value = text
    number = None
    if isinstance(value, str):
        try:
            number = int(value.strip())
        except ValueError:
            pass
    elif not isinstance(value, bool):
        import operator

        try:
            number = operator.index(value)  # int, numpy integers; not 2.5, not True
        except TypeError:
            pass
    if number is None or number < 1:
        unset = " (or unset: all cores)" if what == "CORTEX_TI_THREADS" else ""
        shown = f"'{value}'" if isinstance(value, str) else repr(value)
        raise CortexError(f"{what} must be a whole number >= 1{unset}, got {shown}")
    return number


def moved_to(old: str, new: str):
    """The module ``__getattr__`` of the deprecated module ``old``, which forwards every name of the
    module ``new`` (imported when first used) with a :class:`DeprecationWarning`; a probe for a name
    ``new`` lacks, or a dunder (doctest, pytest, pickle), is an :class:`AttributeError` and no warning.

    Usage, the whole body of the old module: ``__getattr__ = moved_to(__name__, "cortex_ti.x.y")``.
    """

    def __getattr__(name: str):
        moved = importlib.import_module(new)
        if name.startswith("__") or not hasattr(moved, name):
            raise AttributeError(f"module {old!r} has no attribute {name!r}")
        warnings.warn(f"{old} moved to {new}; the old path goes in the next release", DeprecationWarning, stacklevel=2)
        return getattr(moved, name)

    return __getattr__
