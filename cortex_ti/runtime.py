"""Taichi start-up: float64 everywhere, CPU by default, the architecture selectable.

Taichi is initialised once per process, lazily, by the first kernel call. Settings
come from (in order) the arguments of :func:`init`, then the environment:

``CORTEX_TI_ARCH``     ``cpu`` (default), ``gpu``, ``cuda``, ``vulkan``, ``metal``
``CORTEX_TI_THREADS``  CPU threads for Taichi (default: all cores; Snakemake jobs set it)

``default_fp=ti.f64`` matters: with Taichi's default f32, float *literals* inside
kernels stay single precision even when every field is f64.
"""

from __future__ import annotations

import logging
import os

log = logging.getLogger(__name__)

_ARCHES = ("cpu", "gpu", "cuda", "vulkan", "metal")
_state: dict | None = None


def init(arch: str | None = None, threads: int | None = None) -> dict:
    """Initialise Taichi (idempotent). Returns the settings in force.

    A second call with different settings re-initialises Taichi (kernels are
    recompiled or loaded from the offline cache).
    """
    global _state
    arch = (arch or os.environ.get("CORTEX_TI_ARCH", "cpu")).lower()
    if arch not in _ARCHES:
        from .errors import CortexError

        raise CortexError(f"unknown Taichi architecture {arch!r}; choose one of {', '.join(_ARCHES)}")
    if threads is None:
        threads = int(os.environ.get("CORTEX_TI_THREADS", "0")) or os.cpu_count() or 1
    wanted = {"arch": arch, "threads": int(threads)}
    if _state == wanted:
        return _state
    os.environ.setdefault("TI_SKIP_VERSION_CHECK", "ON")
    os.environ.setdefault("TI_ENABLE_TORCH", "0")
    import taichi as ti

    if _state is not None:
        ti.reset()
    ti.init(
        arch=getattr(ti, arch),
        default_fp=ti.f64,
        default_ip=ti.i32,
        cpu_max_num_threads=int(threads),
        offline_cache=True,
        log_level=ti.WARN,
    )
    _state = wanted
    log.debug("Taichi initialised: %s", wanted)
    return _state


def ensure() -> None:
    """Initialise Taichi with the defaults if nothing has yet."""
    if _state is None:
        init()
