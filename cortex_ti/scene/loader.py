"""Scenes: self-contained YAML descriptions of one simulation, loaded and validated.

A scene names the initial mesh, the viscous coefficients, the active-stress pattern, the
physical effects switched on, and the solver and time-stepping settings. The keys, their types
and their defaults live in ONE place, the scene schema (:mod:`cortex_ti.scene.schema`); this
module loads a scene, applies command-line overrides (:mod:`cortex_ti.scene.overrides`),
validates it against the schema, fills in the defaults, checks the rules that tie keys
together (:mod:`cortex_ti.scene.rules`) and resolves its file paths. The result, a
:class:`Scene`, resolves its settings once into a typed :class:`RunSettings`.

Every problem is reported as a single :class:`~cortex_ti.errors.SceneError`
whose message names the offending dotted key, for example::

    scene 'x.yaml': viscosity.bulk must be a finite number >= 0, got nan
    scene 'x.yaml': unknown key 'viscosity.shaer' (did you mean 'viscosity.shear'?)
"""

from __future__ import annotations

import copy
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import yaml

from ..errors import SceneError
from ..physics.model import EFFECTS
from ..physics.user_patterns import add_pattern_folder
from .builtin import builtin_scene_names, builtin_scene_path
from .files import resolve_files
from .overrides import apply_override
from .rules import check_rules
from .schema import current_schema, fill_defaults, validate_schema
from .settings import RunSettings
from .yamltext import dump_yaml, load_yaml, yaml_problem

__all__ = ["Scene", "load_scene", "scene_from_dict", "scene_from_yaml"]


@dataclass(frozen=True)
class Scene:
    """A validated scene.

    Build one with :func:`load_scene` or :func:`scene_from_dict`; the
    constructor itself does not validate.

    Its validated content is :attr:`data` (a copy: a scene is immutable once validated).

    Attributes
    ----------
    source : str or None
        Absolute path of the YAML file the scene was read from, if any.  Not
        part of equality: two scenes with the same data are equal.

    Examples
    --------
    >>> scene = load_scene("sphere_y20_full", ["mesh.nodes=642"])
    >>> scene["viscosity.bulk"], scene.has("incompressibility"), scene.settings.mesh.nodes
    (1.0, True, 642)
    """

    _data: dict
    source: str | None = field(default=None, compare=False)

    @property
    def data(self) -> dict:
        """A copy of the validated scene: every default filled in, keys in schema order, numbers
        canonical (floats for ``number`` keys) and every file path (``mesh.file``, a field pattern's
        ``file``) resolved to an absolute path (``mesh.file`` may be None). Edit the copy and build
        a new scene from it with :func:`scene_from_dict`, which validates it again."""
        return copy.deepcopy(self._data)

    @property
    def name(self) -> str:
        """The scene's ``name``."""
        return self._data["name"]

    @property
    def effects(self) -> frozenset[str]:
        """The effects switched on."""
        return frozenset(self._data["effects"])

    def __getitem__(self, dotted: str) -> Any:
        """Value at a dotted key, e.g. ``scene["viscosity.shear"]``.

        List items are addressed by index (``scene["active_stress.0.type"]``).
        Mappings and lists are returned as copies.

        Raises
        ------
        KeyError
            If the key does not exist in the scene.
        """
        node: Any = self._data
        for part in str(dotted).split("."):
            if isinstance(node, dict) and part in node:
                node = node[part]
            elif isinstance(node, list) and part.isdigit() and int(part) < len(node):
                node = node[int(part)]
            else:
                raise KeyError(dotted)
        return copy.deepcopy(node) if isinstance(node, (dict, list)) else node

    def has(self, effect: str) -> bool:
        """Whether ``effect`` is switched on.

        Raises
        ------
        ValueError
            If ``effect`` is not in :data:`EFFECTS` (a typo would otherwise read as "off").
        """
        if effect not in EFFECTS:
            raise ValueError(f"unknown effect {effect!r}; known effects: {', '.join(EFFECTS)}")
        return effect in self._data["effects"]

    def with_overrides(self, overrides: Sequence[str]) -> Scene:
        """This scene with ``dotted.key=value`` assignments applied, validated again
        (:func:`scene_from_dict`)."""
        return scene_from_dict(self._data, overrides, self.source)

    def to_yaml(self) -> str:
        """Canonical YAML text of :attr:`data`.

        Stored in output files; :func:`scene_from_yaml` gives back an equal scene
        (floats are written with ``repr`` precision).
        """
        return dump_yaml(self._data)

    @cached_property
    def settings(self) -> RunSettings:
        """The scene's settings resolved once, typed (:class:`~cortex_ti.scene.settings.RunSettings`)."""
        return RunSettings.from_data(self._data)

    def __hash__(self) -> int:
        return hash(self.to_yaml())


def _label(source: str | None, data: Any) -> str:
    if source is not None:
        return f"scene '{source}'"
    if isinstance(data, dict) and isinstance(data.get("name"), str):
        return f"scene '{data['name']}'"
    return "scene"


def _build(data: Any, overrides: Sequence[str], source: str | None, label: str) -> Scene:
    if isinstance(overrides, str):
        overrides = [overrides]
    if not isinstance(data, dict):
        raise SceneError(f"{label} must be a mapping of keys (name, mesh, effects, ...), got {type(data).__name__}")
    raw = copy.deepcopy(data)
    base = Path(source).parent if source else Path.cwd()
    try:
        for assignment in overrides:
            apply_override(raw, assignment)
        validate_schema(raw)
        canonical = fill_defaults(current_schema(), raw, "")
        check_rules(canonical)
        resolve_files(canonical, base)
    except SceneError as exc:
        raise SceneError(f"{label}: {exc}") from None
    if source and any(p.get("type") == "python" for p in canonical.get("active_stress") or []):
        add_pattern_folder(Path(source).parent)  # a python pattern's module may sit beside its scene
    return Scene(canonical, source=source)


def scene_from_dict(data: dict, overrides: Sequence[str] = (), source: str | None = None) -> Scene:
    """Validate a scene mapping and return a :class:`Scene`.

    Parameters
    ----------
    data : dict
        Raw scene mapping (as read from YAML); not modified.
    overrides : sequence of str
        ``dotted.key=value`` assignments applied before validation
        (see :func:`apply_override`).
    source : str, optional
        Path of the file the mapping came from; a relative ``mesh.file`` or field
        pattern ``file`` resolves against its folder (against the current
        directory without one).

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        One message naming the offending key, prefixed with the scene's file or name.
    """
    if source is not None:
        source = os.path.abspath(source)
    return _build(data, overrides, source, _label(source, data))


def load_scene(path: str | os.PathLike, overrides: Sequence[str] = ()) -> Scene:
    """Read, override and validate a scene YAML file.

    Parameters
    ----------
    path : str or path-like
        The scene file.  A bare name that is not an existing file (no folder,
        no ``.yaml`` suffix, e.g. ``sphere_y20_full``) is looked up among the
        built-in scenes with :func:`builtin_scene_path`.
    overrides : sequence of str
        ``dotted.key=value`` assignments applied before validation.

    Returns
    -------
    Scene

    Raises
    ------
    SceneError
        Missing or unreadable file, invalid YAML, YAML that is not a mapping, or
        any invalid key or value (one message naming the key).
    """
    given = os.fspath(path)
    file = Path(given)
    if not file.exists() and os.sep not in given and "/" not in given and not file.suffix:
        try:
            file = builtin_scene_path(given)
        except SceneError:
            names = ", ".join(builtin_scene_names()) or "(none)"
            raise SceneError(
                f"scene file '{given}' not found, and it is not a built-in scene (available: {names})"
            ) from None
    label = f"scene '{given}'"
    if not file.exists():
        raise SceneError(f"scene file '{given}' not found")
    try:
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        reason = getattr(exc, "strerror", None) or str(exc)
        raise SceneError(f"cannot read scene file '{given}': {reason}") from None
    try:
        data = load_yaml(text)
    except yaml.YAMLError as exc:
        raise SceneError(f"{label} is not valid YAML: {yaml_problem(exc)}") from None
    if data is None:
        raise SceneError(f"{label} is empty")
    if not isinstance(data, dict):
        kind = {list: "a list", str: "a string"}.get(type(data), type(data).__name__)
        raise SceneError(f"{label} must be a YAML mapping of keys (name, mesh, effects, ...), got {kind}")
    return _build(data, overrides, os.path.abspath(file), label)


def scene_from_yaml(text: str) -> Scene:
    """The scene stored as YAML text (``Scene.to_yaml``, the ``scene`` attribute of a trajectory).

    A stored scene is complete (its defaults were filled in when it was written), so a
    ``numerics`` section without ``formulation`` was written before that key existed, when
    the paper's formulation was the only one: it reads back as ``formulation: paper``, not as
    today's default, so a resumed or re-analysed old run keeps the method it ran with."""
    try:
        data = load_yaml(text)
    except yaml.YAMLError as exc:
        raise SceneError(f"the stored scene is not valid YAML: {yaml_problem(exc)}") from None
    return scene_from_dict(_stored_legacy(data))


def _stored_legacy(data):
    """A stored scene mapping with the keys whose absence meant something else when it was written:
    ``numerics`` without ``formulation`` (but with ``fit``) is the paper's (:func:`scene_from_yaml`)."""
    numerics = data.get("numerics") if isinstance(data, dict) else None
    if isinstance(numerics, dict) and "fit" in numerics and "formulation" not in numerics:
        numerics["formulation"] = "paper"
    return data


def stored_scene_data(data: dict) -> dict:
    """A stored scene mapping as today's loader would have written it: the legacy keys of
    :func:`_stored_legacy`, then today's defaults for the keys added since (a ring's ``center``), so
    that a file from before a new key compares equal to today's scene where it kept its default. A
    mapping today's schema refuses is returned with the legacy keys only."""
    data = _stored_legacy(copy.deepcopy(data))
    try:
        return fill_defaults(current_schema(), data, "")
    except (SceneError, TypeError, KeyError, ValueError):
        return data
