"""Taichi start-up: float64 everywhere, CPU by default, the architecture selectable.

Every Taichi kernel of the package is declared with :func:`kernel` instead of ``ti.kernel``:
the first call of any of them initialises Taichi with the defaults (:func:`ensure`), so no
other module has to. Settings come from (in order) the arguments of :func:`init`, then the
environment:

``CORTEX_TI_ARCH``     ``cpu`` (default), ``gpu``, ``cuda``, ``vulkan``, ``metal``
``CORTEX_TI_THREADS``  CPU threads for Taichi and PARDISO (default: all cores; Snakemake jobs set it)

``default_fp=ti.f64`` matters: with Taichi's default f32, float *literals* inside
kernels stay single precision even when every field is f64.

Importing this module imports Taichi (without its banner and version check; the line ``ti.init``
prints, "[Taichi] Starting on arch=...", goes to the debug log, so stdout holds only what a command
prints); modules that
need no kernels (scene loading, sweeps, stores) do not import it, so that input errors are
reported before Taichi starts.
"""

from __future__ import annotations

import contextlib
import functools
import io
import logging
import os

os.environ.setdefault("TI_SKIP_VERSION_CHECK", "ON")
os.environ.setdefault("TI_ENABLE_TORCH", "0")
os.environ.setdefault("ENABLE_TAICHI_HEADER_PRINT", "False")

import taichi as ti  # noqa: E402  (after the environment it reads at import)

log = logging.getLogger(__name__)


class _OneLine:
    """Stands in for :class:`textwrap.TextWrapper` in Taichi's source positions: Taichi 1.7 formats
    a position (the line and a caret under the node) for every node of every kernel it transforms,
    wrapping both at 80 columns, and the wrapping was ~0.3 s of a process's start-up (issue 32,
    docs/validation/curved_cost.md); the positions only show in Taichi's own error messages, which
    keep their lines and carets, unwrapped."""

    def __init__(self, width: int = 80):
        self.width = width

    @staticmethod
    def wrap(text: str) -> list[str]:
        return [text] if text.strip() else []


def _unwrapped_positions() -> None:
    from taichi.lang.ast import ast_transformer_utils as utils

    if getattr(utils, "TextWrapper", None) is not None:
        utils.TextWrapper = _OneLine


_unwrapped_positions()

__all__ = ["ARCHES", "init", "ensure", "kernel", "ti", "f64_1", "f64_2", "f64_3", "f64_4", "i32_1", "i32_2"]

#: The Taichi architectures ``--arch`` / ``CORTEX_TI_ARCH`` accept.
ARCHES = ("cpu", "gpu", "cuda", "vulkan", "metal")
_state: dict | None = None

#: Array types of the kernels' arguments (numpy arrays passed as Taichi ndarrays).
f64_1 = ti.types.ndarray(dtype=ti.f64, ndim=1)
f64_2 = ti.types.ndarray(dtype=ti.f64, ndim=2)
f64_3 = ti.types.ndarray(dtype=ti.f64, ndim=3)
f64_4 = ti.types.ndarray(dtype=ti.f64, ndim=4)
i32_1 = ti.types.ndarray(dtype=ti.i32, ndim=1)
i32_2 = ti.types.ndarray(dtype=ti.i32, ndim=2)


def init(arch: str | None = None, threads: int | None = None) -> dict:
    """Initialise Taichi (idempotent). Returns the settings in force.

    A second call with different settings re-initialises Taichi (kernels are
    recompiled or loaded from the offline cache).
    """
    global _state
    arch = (arch or os.environ.get("CORTEX_TI_ARCH", "cpu")).lower()
    if arch not in ARCHES:
        from .errors import CortexError

        raise CortexError(f"unknown Taichi architecture {arch!r}; choose one of {', '.join(ARCHES)}")
    from .errors import thread_count

    threads = thread_count(threads)  # checked before Taichi sees it: 0 threads aborts the interpreter
    if threads is None:
        threads = os.cpu_count() or 1
    else:  # the sparse factorisations take their thread count from here too (solve.factorizations)
        os.environ["CORTEX_TI_THREADS"] = str(threads)
        _limit_blas(int(threads))
    wanted = {"arch": arch, "threads": int(threads)}
    if _state == wanted:
        return _state
    if _state is not None:
        ti.reset()
    banner = io.StringIO()  # ti.init prints "[Taichi] Starting on arch=..." to stdout: logged instead
    with contextlib.redirect_stdout(banner):
        ti.init(
            arch=getattr(ti, arch),
            default_fp=ti.f64,
            default_ip=ti.i32,
            cpu_max_num_threads=int(threads),
            offline_cache=True,
            log_level=ti.WARN,
        )
    _state = wanted
    log.debug("Taichi initialised: %s %s", wanted, " ".join(banner.getvalue().split()))
    return _state


def _limit_blas(threads: int) -> None:
    """At most ``threads`` BLAS threads (NumPy's and SciPy's OpenBLAS or MKL, by ``threadpoolctl``),
    for the rest of the process: a run asked for one thread uses one. The dense products of the
    curved cells are small and batched, and OpenBLAS's threads cost more than they bring there:
    ``rayleigh_p2`` at 642 nodes to t = 1 took 4.9 CPU s with OpenBLAS's default threads and 3.1
    with one; ``furrow_p4_a1`` at 2562 nodes 18.0 against 10.2 CPU s in the same wall time, 11 s
    (2-core machine, load ~1.5-2.4)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=threads, user_api="blas")


def ensure() -> None:
    """Initialise Taichi with the defaults if nothing has yet."""
    if _state is None:
        init()


def kernel(func):
    """``ti.kernel`` that initialises Taichi on its first call (see the module docstring)."""
    compiled = ti.kernel(func)

    @functools.wraps(func)
    def call(*args):
        ensure()
        return compiled(*args)

    return call
