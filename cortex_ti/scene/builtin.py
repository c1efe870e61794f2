"""The built-in scenes: the paper's scenes, shipped inside the package (``cortex_ti/scene/scenes``).

They are package data read through :mod:`importlib.resources`, so a wheel or a non-editable
install has them too, from any working directory.
"""

from __future__ import annotations

import importlib.resources
import os
from pathlib import Path

from ..errors import SceneError

__all__ = ["builtin_scene_names", "builtin_scene_path"]


def _builtin_dir() -> Path:
    return Path(str(importlib.resources.files("cortex_ti.scene").joinpath("scenes")))


def builtin_scene_names() -> list[str]:
    """Names of the built-in scenes (sorted)."""
    folder = _builtin_dir()
    return sorted(p.stem for p in folder.glob("*.yaml")) if folder.is_dir() else []


def builtin_scene_path(name: str) -> Path:
    """Path of the built-in scene ``<name>.yaml``.

    Parameters
    ----------
    name : str
        Scene name, with or without the ``.yaml`` suffix.

    Raises
    ------
    SceneError
        If there is no such scene (the message lists the available ones).

    Examples
    --------
    >>> builtin_scene_path("furrow_p8_a1").name
    'furrow_p8_a1.yaml'
    """
    stem = name[:-5] if name.endswith(".yaml") else name
    path = _builtin_dir() / f"{stem}.yaml"
    if "/" not in stem and os.sep not in stem and path.is_file():
        return path
    names = ", ".join(builtin_scene_names()) or "(none)"
    raise SceneError(f"no built-in scene '{stem}'; available scenes: {names}")
