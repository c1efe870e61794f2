"""The Python front door: run a scene and get its trajectory as an xarray Dataset.

>>> import cortex_ti as ct
>>> "furrow_p8_a1" in ct.scenes()
True
>>> scene = ct.load_scene("furrow_p8_a1", nodes=162, t_end=0.01)
>>> scene.settings.mesh.nodes, scene.settings.time.t_end
(162, 0.01)

``ct.run("furrow_p8_a1", nodes=642, t_end=0.3)`` runs the scene (any built-in name, a YAML path or
a :class:`~cortex_ti.scene.Scene`) and returns its trajectory read into memory; ``output=`` keeps
the file. Settings are given as keywords: the shorthands ``nodes``, ``t_end``, ``dt``, ``model``
and ``motion``, or any scene key with dots written as double underscores
(``time__save_every=0.1``), or a list of ``--set`` strings (``overrides=["mesh.shear=0.35"]``).
A scene is immutable once validated: every override makes a new one.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from pathlib import Path

__all__ = ["run", "load_scene", "open_trajectory", "scenes"]

#: keyword shorthands for the scene keys users set most
SHORTHANDS = {
    "nodes": "mesh.nodes",
    "t_end": "time.t_end",
    "dt": "time.dt",
    "model": "model",
    "motion": "mesh.motion",
    "scheme": "time.scheme",
    "formulation": "numerics.formulation",
}


def _assignments(settings: dict) -> list[str]:
    import json

    out = []
    for key, value in settings.items():
        dotted = SHORTHANDS.get(key, key.replace("__", "."))
        text = value if isinstance(value, str) else json.dumps(value)
        out.append(f"{dotted}={text}")
    return out


def scenes() -> list[str]:
    """The names of the built-in scenes."""
    from .scene import builtin_scene_names

    return list(builtin_scene_names())


def _override_list(overrides) -> list[str]:
    """``overrides`` as a list of ``KEY=VALUE`` strings: one string is one override."""
    from .errors import SceneError

    if isinstance(overrides, str):
        return [overrides]
    try:
        items = list(overrides)
    except TypeError:
        raise SceneError(
            f"overrides must be a list of 'KEY=VALUE' strings, got {type(overrides).__name__} {overrides!r}"
        ) from None
    for item in items:
        if not isinstance(item, str):
            raise SceneError(f"overrides must be 'KEY=VALUE' strings, got {item!r} in {overrides!r}")
    return items


def load_scene(scene, overrides: str | Sequence[str] = (), **settings):
    """A validated scene from a built-in name, a YAML path or a scene, with the keyword settings
    (module docstring) and ``--set``-style ``overrides`` applied (a new scene; the input is not
    changed): a list of ``KEY=VALUE`` strings, or one such string. Bad input raises
    :class:`cortex_ti.errors.SceneError` naming the key.

    >>> load_scene("furrow_p8_a1", "mesh.nodes=642").settings.mesh.nodes
    642
    """
    from .scene import Scene, scene_from_dict
    from .scene import load_scene as _load

    extra = _override_list(overrides) + _assignments(settings)
    if isinstance(scene, Scene):
        return scene_from_dict(scene.data, extra) if extra else scene
    return _load(scene, extra)


def open_trajectory(path):
    """A trajectory file read into memory as an xarray Dataset, the file closed again (works on the
    ``.partial`` file of a running simulation too): :func:`cortex_ti.io.load_trajectory`. (The lazy
    reader that keeps the file open is :func:`cortex_ti.io.open_trajectory`; the reader that knows
    the stored scene is :class:`cortex_ti.io.Trajectory`.)"""
    from .io.trajectory import load_trajectory

    return load_trajectory(path)


def run(
    scene,
    output=None,
    *,
    overrides: Sequence[str] = (),
    progress: bool = False,
    arch: str | None = None,
    threads: int | None = None,
    resume: bool = False,
    force: bool = False,
    **settings,
):
    """Run ``scene`` (see :func:`load_scene` for what it and the keywords may be) with its model and
    return the trajectory as an xarray Dataset in memory. ``output``: where to keep the file (by
    default a temporary one, removed after reading). What is already at ``output`` is treated as
    ``cortex-ti run`` treats it (the same rule, :func:`cortex_ti.io.claim.check_output`, and the same
    messages): an existing file, or an interrupted run's ``.partial`` file, is refused (nothing is
    touched) unless ``resume=True`` (continue or extend it) or ``force=True`` (replace it).
    ``threads`` (else ``CORTEX_TI_THREADS``) must be a whole number >= 1; all arguments are checked
    before Taichi starts, and bad ones raise :class:`cortex_ti.errors.CortexError`."""
    from .errors import CortexError, thread_count
    from .io.claim import check_output, claim_output
    from .models import make_runner

    if force and resume:
        raise CortexError("force=True starts over and resume=True continues: pass one of them")
    sc = load_scene(scene, overrides, **settings)
    threads = thread_count(threads)
    if output is not None:
        output = Path(output)
        with claim_output(output):  # refused before Taichi starts, as on the command line
            check_output(output, resume, force)
            runner = make_runner(sc, arch, threads)
            path = runner.run(output, resume=resume, progress=progress, force=force)
        return open_trajectory(path)
    runner = make_runner(sc, arch, threads)
    with tempfile.TemporaryDirectory(prefix="cortex-ti-") as tmp:
        path = runner.run(Path(tmp) / f"{sc.name}.h5", progress=progress)
        return open_trajectory(path)
