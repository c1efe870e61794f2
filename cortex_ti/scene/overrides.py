"""Command-line overrides ``--set dotted.key=value`` applied to a raw scene, checked against the schema."""

from __future__ import annotations

import copy
from typing import Any

import yaml

from ..errors import SceneError
from .files import paths_from_cwd
from .schema import (
    current_schema,
    dotted_key,
    fmt_value,
    join_key,
    keyword,
    properties,
    unknown_key,
)
from .yamltext import load_yaml, yaml_problem

__all__ = ["apply_override"]


# --------------------------------------------------------------------------------------
# Overrides
# --------------------------------------------------------------------------------------

_EXCLUSIVE = {("mesh", "file"): "nodes", ("mesh", "nodes"): "file"}


def apply_override(data: dict, assignment: str) -> None:
    """Apply one ``dotted.key=value`` assignment to a raw scene mapping, in place.

    Parameters
    ----------
    data : dict
        Raw (not yet validated) scene mapping; modified in place.
    assignment : str
        ``key=value``.  The key is a dotted path of schema keys, with integer
        indices into lists (``active_stress.0.sigma``); the value is parsed as
        YAML (``viscosity.bulk=0``, ``effects=[a, b]``, ``mesh.file=cell.obj``).

    Notes
    -----
    * The path is checked against the schema, not against ``data``: a key whose
      parent section is missing from ``data`` (``time.dt`` on a scene without a
      ``time`` section) creates the section.
    * ``mesh.file`` and ``mesh.nodes`` exclude each other: setting one to a
      non-null value removes the other, so switching mesh source is one override.
    * A relative file path given in an override (``mesh.file``, a field pattern's
      ``active_stress.<i>.file``, also inside a mapping or list value such as
      ``active_stress=[{type: field, file: f.npy}]``) resolves against the current
      working directory (as any command-line path does), not against the scene
      file's folder; it is made absolute here.
    * Values are not validated here; validation happens afterwards, in
      :func:`scene_from_dict`.

    Raises
    ------
    SceneError
        Malformed assignment, unparsable value, or a path unknown to the schema
        (with the nearest valid key suggested).
    """
    if not isinstance(assignment, str) or "=" not in assignment:
        raise SceneError(f"override {assignment!r} must look like key=value, e.g. viscosity.bulk=0")
    key, _, text = assignment.partition("=")
    key = key.strip()
    parts = key.split(".")
    if not key or any(not p.strip() for p in parts):
        raise SceneError(f"override {assignment!r}: '{key}' is not a dotted key like viscosity.bulk")
    parts = [p.strip() for p in parts]
    try:
        value = load_yaml(text)
    except yaml.YAMLError as exc:
        raise SceneError(
            f"override {assignment!r}: cannot parse the value {text!r} as YAML: {yaml_problem(exc)}"
        ) from None

    work = copy.deepcopy(data)  # a failed override leaves ``data`` untouched
    _assign(work, parts, value, assignment)
    data.clear()
    data.update(work)


def _assign(data: dict, parts: list[str], value: Any, assignment: str) -> None:
    """Set ``data[parts...] = value``, checking the path against the schema."""
    key = ".".join(parts)
    value = paths_from_cwd(value, parts)
    schema: dict = current_schema()
    node: Any = data
    for depth, part in enumerate(parts):
        here = dotted_key(parts[:depth])
        dotted = join_key(here, part)
        last = depth == len(parts) - 1
        if isinstance(node, list):
            if not node:
                raise SceneError(
                    f"override {assignment!r}: {here} is empty; set the whole list instead, e.g. {here}=[...]"
                )
            if not (part.lstrip("-").isdigit() and 0 <= int(part) < len(node)):
                raise SceneError(
                    f"override {assignment!r}: {here} has {len(node)} item(s); "
                    f"'{part}' is not an index 0..{len(node) - 1}"
                )
            index = int(part)
            items = keyword(schema, "items", node) or {}
            if last:
                node[index] = value
                return
            schema, node = items, node[index]
            continue
        if not isinstance(node, dict):
            raise SceneError(
                f"override {assignment!r}: cannot set {key} because {here} is {fmt_value(node)}, not a mapping"
            )
        props = properties(schema, node)
        if part not in props:
            raise SceneError(f"override {assignment!r}: " + unknown_key(dotted, [join_key(here, p) for p in props]))
        if last:
            node[part] = value
            other = _EXCLUSIVE.get(tuple(parts))
            if other is not None and value is not None:
                node.pop(other, None)
            return
        child = node.get(part)
        if child is None:
            child = [] if keyword(props[part], "type") == "array" else {}
            node[part] = child
        schema, node = props[part], child
