"""Scenes: what one simulation is, from its YAML file to its resolved settings.

Owns the scene schema (``scene.schema.json``, completed from the registries of the layers
below), loading and ``--set`` overrides, the cross-key rules, file-path resolution, the
built-in scenes (``scenes/*.yaml``, package data) and :class:`RunSettings`, the one typed
resolution of a scene's settings. May import :mod:`cortex_ti.errors` and the light registry
modules of ``surface``, ``physics``, ``solve`` and ``dynamics`` (no Taichi): loading a scene
never starts the Taichi runtime.
"""

from .builtin import builtin_scene_names, builtin_scene_path
from .loader import Scene, load_scene, scene_from_dict, scene_from_yaml
from .overrides import apply_override
from .rules import VALID_NODE_COUNTS
from .schema import current_schema, full_schema
from .settings import RunSettings

__all__ = [
    "Scene",
    "RunSettings",
    "load_scene",
    "scene_from_dict",
    "scene_from_yaml",
    "apply_override",
    "builtin_scene_names",
    "builtin_scene_path",
    "current_schema",
    "full_schema",
    "VALID_NODE_COUNTS",
]
