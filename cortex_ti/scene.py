"""Scenes: self-contained YAML descriptions of one simulation.

A scene names the initial mesh, the viscous coefficients, the active-stress
pattern, the physical effects switched on, and the solver and time-stepping
settings.  The keys, their types and their defaults live in ONE place, the JSON
schema ``cortex_ti/schema/scene.schema.json`` (draft 2020-12); this module loads
a scene, applies command-line overrides, validates it against the schema, fills
in the defaults and then checks the rules that tie keys together (effects versus
coefficients, exactly one mesh source, ...).

Every problem is reported as a single :class:`~cortex_ti.errors.SceneError`
whose message names the offending dotted key, for example::

    scene 'x.yaml': viscosity.bulk must be a finite number >= 0, got nan
    scene 'x.yaml': unknown key 'viscosity.shaer' (did you mean 'viscosity.shear'?)

Examples
--------
>>> scene = load_scene(builtin_scene_path("sphere_y20_full"), ["mesh.nodes=642"])
>>> scene["viscosity.bulk"], scene.has("incompressibility")
(1.0, True)
"""

from __future__ import annotations

import copy
import difflib
import importlib.resources
import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterable, Iterator, Sequence

import jsonschema
import yaml

from .dynamics import SCHEMES
from .errors import SceneError

__all__ = [
    "EFFECTS",
    "VALID_NODE_COUNTS",
    "Scene",
    "load_scene",
    "scene_from_dict",
    "apply_override",
    "builtin_scene_path",
    "builtin_scene_names",
]

#: The vocabulary of physical effects a scene can switch on (name -> description).
EFFECTS: dict[str, str] = {
    "active_stress": "isotropic active tension zeta from the active_stress patterns",
    "shear_viscosity": "in-plane shear viscous stress, coefficient viscosity.shear (eta_s)",
    "bulk_viscosity": "in-plane bulk (area-change) viscous stress, coefficient viscosity.bulk (eta_b)",
    "bending_viscosity": "viscous bending moments, coefficients viscosity.bending and viscosity.bending_bulk (paper Eq. 45)",
    "normal_balance": "solve the normal force balance for the normal velocity",
    "fixed_normal_velocity": "impose zero normal velocity: tangential flow only, the shape stays fixed",
    "incompressibility": "conserve the enclosed volume with a pressure P = p_inside - p_outside",
    "shape_evolution": "move the nodes with the computed velocity and step in time (uses the time section)",
}

#: Icosphere node counts 10*4^k+2 accepted for mesh.nodes (k = 0..7).
VALID_NODE_COUNTS: tuple[int, ...] = tuple(10 * 4**k + 2 for k in range(8))

#: Effects that need the normal force balance.
_NEED_NORMAL_BALANCE = ("incompressibility", "bending_viscosity", "shape_evolution")


# --------------------------------------------------------------------------------------
# The schema
# --------------------------------------------------------------------------------------

def _load_schema() -> dict:
    text = (
        importlib.resources.files("cortex_ti")
        .joinpath("schema/scene.schema.json")
        .read_text(encoding="utf-8")
    )
    return json.loads(text)


SCHEMA: dict = _load_schema()
_VALIDATOR = jsonschema.Draft202012Validator(SCHEMA)


def _deref(schema: dict) -> dict:
    """Follow local ``$ref`` pointers (``#/...``) of the scene schema."""
    while "$ref" in schema:
        ref = schema["$ref"]
        if not ref.startswith("#/"):
            raise ValueError(f"only local $ref are supported in the scene schema, got {ref!r}")
        node: Any = SCHEMA
        for part in ref[2:].split("/"):
            node = node[part]
        schema = node
    return schema


_UNKNOWN = object()  # "instance not known": apply every conditional branch


def _branches(schema: dict, instance: Any = _UNKNOWN) -> Iterator[dict]:
    """Yield ``schema`` and the subschemas that apply to ``instance``.

    Follows ``$ref``, ``allOf`` and ``if``/``then``/``else``.  With an unknown
    instance every ``then`` and ``else`` branch is yielded (the union view used
    to check override paths).
    """
    schema = _deref(schema)
    yield schema
    for sub in schema.get("allOf", ()):
        yield from _branches(sub, instance)
    if "if" in schema:
        if instance is _UNKNOWN:
            picks = [schema.get("then"), schema.get("else")]
        elif jsonschema.Draft202012Validator(schema["if"]).is_valid(instance):
            picks = [schema.get("then")]
        else:
            picks = [schema.get("else")]
        for sub in picks:
            if sub is not None:
                yield from _branches(sub, instance)


def _properties(schema: dict, instance: Any = _UNKNOWN) -> dict[str, dict]:
    """The object properties (name -> subschema) that apply to ``instance``, in schema order."""
    props: dict[str, dict] = {}
    for branch in _branches(schema, instance):
        for key, sub in branch.get("properties", {}).items():
            props.setdefault(key, sub)
    return props


def _keyword(schema: dict, keyword: str, instance: Any = _UNKNOWN) -> Any:
    """First value of ``keyword`` among the branches of ``schema`` (None if absent)."""
    for branch in _branches(schema, instance):
        if keyword in branch:
            return branch[keyword]
    return None


# --------------------------------------------------------------------------------------
# YAML
# --------------------------------------------------------------------------------------

class _Loader(yaml.SafeLoader):
    """Safe YAML loader that reads ``1e-3`` as a float and rejects duplicate keys.

    PyYAML follows YAML 1.1, where a float needs a dot (``1.0e-3``) and ``1e-3``
    is a string; scientists write ``1e-3``.
    """

    def construct_mapping(self, node, deep=False):  # noqa: D102 (PyYAML hook)
        if isinstance(node, yaml.MappingNode):
            self.flatten_mapping(node)
            seen = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                try:
                    duplicate = key in seen
                    seen.add(key)
                except TypeError:  # unhashable key: let PyYAML report it
                    continue
                if duplicate:
                    raise yaml.constructor.ConstructorError(
                        None, None, f"found duplicate key {key!r}", key_node.start_mark
                    )
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"""^(?:[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+)$""",
        re.X,
    ),
    list("-+0123456789"),
)


class _Dumper(yaml.SafeDumper):
    """Safe YAML dumper writing multi-line strings as literal blocks."""


def _represent_str(dumper: yaml.SafeDumper, value: str):
    style = "|" if "\n" in value else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


def _represent_list(dumper: yaml.SafeDumper, value: list):
    flat = all(isinstance(v, (str, int, float, bool)) or v is None for v in value)
    return dumper.represent_sequence("tag:yaml.org,2002:seq", value, flow_style=flat)


_Dumper.add_representer(str, _represent_str)
_Dumper.add_representer(list, _represent_list)


def _yaml_load(text: str) -> Any:
    return yaml.load(text, Loader=_Loader)  # noqa: S506 (_Loader derives from SafeLoader)


def _yaml_problem(exc: yaml.YAMLError) -> str:
    """One line describing a YAML syntax error, with its line and column."""
    problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
    mark = getattr(exc, "problem_mark", None)
    if mark is not None:
        return f"{problem} (line {mark.line + 1}, column {mark.column + 1})"
    return problem


# --------------------------------------------------------------------------------------
# Messages
# --------------------------------------------------------------------------------------

def _join(path: str, key: Any) -> str:
    return f"{path}.{key}" if path else str(key)


def _dotted(parts: Iterable[Any]) -> str:
    return ".".join(str(p) for p in parts)


def _fmt(value: Any) -> str:
    """Short human form of a value: 1.0 -> '1', nan -> 'nan', 'x' -> "'x'"."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}" if math.isfinite(value) else str(value)
    if isinstance(value, str):
        return repr(value)
    return str(value)


def _unknown_key(dotted: str, siblings: Iterable[str]) -> str:
    """'unknown key X (did you mean Y?)', or the list of valid keys when nothing is close."""
    siblings = list(siblings)
    close = difflib.get_close_matches(dotted, siblings, n=1, cutoff=0.6)
    if close:
        return f"unknown key '{dotted}' (did you mean '{close[0]}'?)"
    if siblings:
        return f"unknown key '{dotted}' (valid keys here: {', '.join(siblings)})"
    return f"unknown key '{dotted}'"


def _bound_text(schema: dict) -> str:
    """' >= 0' / ' > 0' from a schema fragment's bounds ('' when unbounded)."""
    parts = []
    for keyword, op in (("minimum", ">="), ("exclusiveMinimum", ">"),
                        ("maximum", "<="), ("exclusiveMaximum", "<")):
        if keyword in schema:
            parts.append(f"{op} {_fmt(schema[keyword])}")
    return (" " + " and ".join(parts)) if parts else ""


def _kind(schema: dict) -> str:
    types = schema.get("type", "number")
    types = [types] if isinstance(types, str) else list(types)
    return "an integer" if "integer" in types else "a finite number"


_PRIORITY = {"additionalProperties": 0, "required": 1, "type": 2, "enum": 3, "const": 3}


def _schema_message(err: jsonschema.ValidationError) -> str:
    """Turn one jsonschema error into a message naming the dotted key."""
    path = _dotted(err.absolute_path)
    where = path or "the scene"
    v = err.validator
    if v == "additionalProperties":
        allowed = list(err.schema.get("properties", {}))
        extras = [k for k in err.instance if k not in allowed]
        return _unknown_key(_join(path, extras[0]), [_join(path, a) for a in allowed])
    if v == "required":
        missing = [k for k in err.validator_value if k not in err.instance]
        key = _join(path, missing[0] if missing else "?")
        if key == "mesh":
            return "mesh is required (give mesh.nodes or mesh.file)"
        if key.endswith(".type") and path.startswith("active_stress"):
            return f"{key} is required (one of: {', '.join(_pattern_types())})"
        return f"{key} is required"
    if v in ("minimum", "exclusiveMinimum", "maximum", "exclusiveMaximum"):
        return f"{where} must be {_kind(err.schema)}{_bound_text(err.schema)}, got {_fmt(err.instance)}"
    if v == "enum":
        options = ", ".join(str(o) for o in err.validator_value)
        return f"{where} must be one of: {options}; got {_fmt(err.instance)}"
    if v == "const":
        return f"{where} must be {_fmt(err.validator_value)}, got {_fmt(err.instance)}"
    if v in ("minItems", "maxItems"):
        lo, hi = err.schema.get("minItems"), err.schema.get("maxItems")
        n = f"{lo}" if lo == hi else f"at least {lo}" if v == "minItems" else f"at most {hi}"
        return f"{where} must have {n} item{'s' if (lo or hi) != 1 else ''}, got {_fmt(err.instance)}"
    if v == "minLength":
        return f"{where} must not be empty"
    if v == "pattern":
        example = (err.schema.get("examples") or [None])[0]
        like = f"look like {_fmt(example)}" if example else f"match {err.validator_value!r}"
        return f"{where} must {like}, got {_fmt(err.instance)}"
    return f"{where}: {err.message}"


def _pattern_types() -> list[str]:
    return list(_deref({"$ref": "#/$defs/pattern"})["properties"]["type"]["enum"])


# --------------------------------------------------------------------------------------
# Validation steps
# --------------------------------------------------------------------------------------

def _validate_schema(data: dict) -> None:
    errors = list(_VALIDATOR.iter_errors(data))
    if not errors:
        return
    best = min(
        errors,
        key=lambda e: (
            len(e.absolute_path),
            _PRIORITY.get(e.validator, 5),
            [str(p) for p in e.absolute_path],
        ),
    )
    raise SceneError(_schema_message(best))


def _fill(schema: dict, value: Any, path: str) -> Any:
    """Return a canonical copy of a schema-valid ``value``.

    Fills defaults, orders mapping keys as in the schema, coerces ints to floats
    for ``number`` keys (and integral floats to ints for ``integer`` keys) and
    rejects non-finite numbers (NaN and +-inf pass JSON-schema bounds checks).
    """
    if isinstance(value, dict):
        props = _properties(schema, value)
        out: dict = {}
        for key, sub in props.items():
            if key in value:
                out[key] = _fill(sub, value[key], _join(path, key))
            else:
                fragment = _deref(sub)
                if "default" in fragment:
                    out[key] = _fill(sub, copy.deepcopy(fragment["default"]), _join(path, key))
        for key, item in value.items():  # not reachable for schema-valid data
            out.setdefault(key, copy.deepcopy(item))
        return out
    if isinstance(value, list):
        items = _keyword(schema, "items", value)
        if items is None:
            return copy.deepcopy(value)
        return [_fill(items, item, _join(path, i)) for i, item in enumerate(value)]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        frag = next(
            (b for b in _branches(schema, value) if "type" in b), _deref(schema)
        )
        if isinstance(value, float) and not math.isfinite(value):
            raise SceneError(
                f"{path} must be {_kind(frag)}{_bound_text(frag)}, got {_fmt(value)}"
            )
        types = frag.get("type", [])
        types = [types] if isinstance(types, str) else list(types)
        if "integer" in types and isinstance(value, float) and value.is_integer():
            return int(value)
        if "number" in types and "integer" not in types and isinstance(value, int):
            return float(value)
        return value
    return copy.deepcopy(value)


def _check_rules(data: dict) -> None:
    """Cross-key rules that JSON schema does not express."""
    # --- mesh: exactly one source, a valid icosphere size
    mesh = data["mesh"]
    nodes, file = mesh.get("nodes"), mesh.get("file")
    if nodes is not None and file is not None:
        raise SceneError(
            f"mesh.nodes = {nodes} and mesh.file = '{file}' are both set: give exactly one of them"
        )
    if nodes is None and file is None:
        raise SceneError(
            "mesh needs exactly one of mesh.nodes (icosphere node count) or mesh.file (a mesh file)"
        )
    if nodes is not None and nodes not in VALID_NODE_COUNTS:
        valid = ", ".join(str(n) for n in VALID_NODE_COUNTS)
        raise SceneError(
            f"mesh.nodes = {nodes} is not an icosphere node count 10*4^k+2; valid values: {valid}"
        )

    # --- effects vocabulary
    effects = data["effects"]
    known = ", ".join(EFFECTS)
    seen: set[str] = set()
    for i, name in enumerate(effects):
        if name not in EFFECTS:
            close = difflib.get_close_matches(name, list(EFFECTS), n=1, cutoff=0.6)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise SceneError(f"effects.{i}: unknown effect '{name}'{hint}; known effects: {known}")
        if name in seen:
            raise SceneError(f"effects lists '{name}' twice")
        seen.add(name)

    # --- effect combinations
    if ("normal_balance" in seen) == ("fixed_normal_velocity" in seen):
        got = "both" if "normal_balance" in seen else "neither"
        raise SceneError(
            "effects must contain exactly one of 'normal_balance' and "
            f"'fixed_normal_velocity', got {got}"
        )
    for name in _NEED_NORMAL_BALANCE:
        if name in seen and "normal_balance" not in seen:
            raise SceneError(
                f"the effect '{name}' requires 'normal_balance' in effects "
                "(it cannot be combined with 'fixed_normal_velocity')"
            )
    if "shear_viscosity" not in seen:
        raise SceneError(
            "effects must contain 'shear_viscosity': without shear viscosity every area-preserving "
            "flow costs nothing and the force balance does not determine the velocity"
        )

    # --- effects agree with coefficients
    visc = data["viscosity"]
    for effect, key in (("shear_viscosity", "shear"), ("bulk_viscosity", "bulk")):
        value = visc[key]
        if value > 0 and effect not in seen:
            raise SceneError(
                f"viscosity.{key} = {_fmt(value)} but the effect '{effect}' is off: "
                f"add it to effects or set viscosity.{key}: 0"
            )
        if value == 0 and effect in seen:
            raise SceneError(
                f"the effect '{effect}' is on but viscosity.{key} = 0: "
                f"set viscosity.{key} > 0 or remove '{effect}' from effects"
            )
    bending = {k: visc[k] for k in ("bending", "bending_bulk")}
    if any(v > 0 for v in bending.values()) and "bending_viscosity" not in seen:
        named = " and ".join(f"viscosity.{k} = {_fmt(v)}" for k, v in bending.items() if v > 0)
        zero = ", ".join(f"viscosity.{k}: 0" for k, v in bending.items() if v > 0)
        raise SceneError(
            f"{named} but the effect 'bending_viscosity' is off: add it to effects or set {zero}"
        )
    if all(v == 0 for v in bending.values()) and "bending_viscosity" in seen:
        raise SceneError(
            "the effect 'bending_viscosity' is on but viscosity.bending = 0 and "
            "viscosity.bending_bulk = 0: set one of them > 0 or remove 'bending_viscosity' from effects"
        )
    time = data.get("time") or {}
    scheme = SCHEMES.get(time.get("scheme", "euler"))
    if time.get("implicit_tension") is True and scheme is not None and not scheme.first_order:
        raise SceneError(
            f"time.implicit_tension = true is a first-order treatment of the tension and would spoil the "
            f"second-order scheme time.scheme = {time['scheme']}: use euler or adaptive_euler, or set "
            "time.implicit_tension: auto"
        )
    patterns = data["active_stress"]
    if patterns and "active_stress" not in seen:
        raise SceneError(
            f"active_stress has {len(patterns)} pattern(s) but the effect 'active_stress' is off: "
            "add it to effects or set active_stress: []"
        )
    if not patterns and "active_stress" in seen:
        raise SceneError(
            "the effect 'active_stress' is on but the active_stress list is empty: "
            "add a pattern or remove 'active_stress' from effects"
        )

    # --- pattern details
    for i, pattern in enumerate(patterns):
        if pattern["type"] == "harmonics":
            for j, term in enumerate(pattern["terms"]):
                if abs(term["m"]) > term["l"]:
                    raise SceneError(
                        f"active_stress.{i}.terms.{j}.m = {term['m']} but |m| must be <= l = {term['l']}"
                    )
        elif pattern["type"] == "ring":
            if not any(pattern["axis"]):
                raise SceneError(f"active_stress.{i}.axis must not be all zero, got {pattern['axis']}")


def _is_file_key(parts: Sequence[str]) -> bool:
    """Whether a dotted key (as parts) holds a file path: ``mesh.file`` or ``active_stress.<i>.file``
    (only the ``field`` pattern has a ``file``).  The one list of path keys."""
    parts = tuple(parts)
    return parts == ("mesh", "file") or (len(parts) == 3 and parts[0] == "active_stress" and parts[2] == "file")


def _file_keys(data: dict) -> Iterator[tuple[str, dict, str]]:
    """``(dotted key, mapping, key)`` of every file path in a scene mapping (see :func:`_is_file_key`)."""
    if isinstance(data.get("mesh"), dict):
        yield "mesh.file", data["mesh"], "file"
    for i, pattern in enumerate(data.get("active_stress") or []):
        if isinstance(pattern, dict) and "file" in pattern:
            yield f"active_stress.{i}.file", pattern, "file"


def _absolute(file: str, base: Path) -> Path:
    """The rule for every path in a scene: ``~`` expanded, a relative path taken relative to ``base``
    (the scene file's folder, or the working directory for a scene without a file and for
    command-line overrides)."""
    path = Path(file).expanduser()
    if not path.is_absolute():
        path = base / path
    return Path(os.path.abspath(path))


def _paths_from_cwd(value: Any, parts: Sequence[str]) -> Any:
    """An override's value with every file path in it (at ``parts`` or nested, e.g.
    ``active_stress=[{type: field, file: f.npy}]``) made absolute against the working directory."""
    if isinstance(value, str) and value and _is_file_key(parts):
        return str(_absolute(value, Path.cwd()))
    if isinstance(value, dict):
        return {k: _paths_from_cwd(v, [*parts, str(k)]) for k, v in value.items()}
    if isinstance(value, list):
        return [_paths_from_cwd(v, [*parts, str(i)]) for i, v in enumerate(value)]
    return value


def _resolve_files(data: dict, base: Path) -> None:
    """Make every file path of the scene (mesh.file, the field patterns' file) absolute, relative
    to ``base``, and check that the files exist."""
    for key, node, name in _file_keys(data):
        file = node.get(name)
        if file is None:
            continue
        path = _absolute(file, base)
        if not path.is_file():
            what = "is a folder, not a file" if path.is_dir() else "does not exist"
            relative = not Path(file).expanduser().is_absolute()
            hint = f" (the relative path '{file}' resolves against '{base}')" if relative else ""
            raise SceneError(f"{key}: '{path}' {what}{hint}")
        node[name] = str(path)


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
        raise SceneError(
            f"override {assignment!r} must look like key=value, e.g. viscosity.bulk=0"
        )
    key, _, text = assignment.partition("=")
    key = key.strip()
    parts = key.split(".")
    if not key or any(not p.strip() for p in parts):
        raise SceneError(f"override {assignment!r}: '{key}' is not a dotted key like viscosity.bulk")
    parts = [p.strip() for p in parts]
    try:
        value = _yaml_load(text)
    except yaml.YAMLError as exc:
        raise SceneError(
            f"override {assignment!r}: cannot parse the value {text!r} as YAML: {_yaml_problem(exc)}"
        ) from None

    work = copy.deepcopy(data)  # a failed override leaves ``data`` untouched
    _assign(work, parts, value, assignment)
    data.clear()
    data.update(work)


def _assign(data: dict, parts: list[str], value: Any, assignment: str) -> None:
    """Set ``data[parts...] = value``, checking the path against the schema."""
    key = ".".join(parts)
    value = _paths_from_cwd(value, parts)
    schema: dict = SCHEMA
    node: Any = data
    for depth, part in enumerate(parts):
        here = _dotted(parts[:depth])
        dotted = _join(here, part)
        last = depth == len(parts) - 1
        if isinstance(node, list):
            if not node:
                raise SceneError(
                    f"override {assignment!r}: {here} is empty; set the whole list "
                    f"instead, e.g. {here}=[...]"
                )
            if not (part.lstrip("-").isdigit() and 0 <= int(part) < len(node)):
                raise SceneError(
                    f"override {assignment!r}: {here} has {len(node)} item(s); "
                    f"'{part}' is not an index 0..{len(node) - 1}"
                )
            index = int(part)
            items = _keyword(schema, "items", node) or {}
            if last:
                node[index] = value
                return
            schema, node = items, node[index]
            continue
        if not isinstance(node, dict):
            raise SceneError(
                f"override {assignment!r}: cannot set {key} because {here} is "
                f"{_fmt(node)}, not a mapping"
            )
        props = _properties(schema, node)
        if part not in props:
            raise SceneError(
                f"override {assignment!r}: "
                + _unknown_key(dotted, [_join(here, p) for p in props])
            )
        if last:
            node[part] = value
            other = _EXCLUSIVE.get(tuple(parts))
            if other is not None and value is not None:
                node.pop(other, None)
            return
        child = node.get(part)
        if child is None:
            child = [] if _keyword(props[part], "type") == "array" else {}
            node[part] = child
        schema, node = props[part], child


# --------------------------------------------------------------------------------------
# The Scene
# --------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Scene:
    """A validated scene.

    Build one with :func:`load_scene` or :func:`scene_from_dict`; the
    constructor itself does not validate.

    Attributes
    ----------
    data : dict
        The validated scene with every default filled in, keys in schema order,
        numbers canonical (floats for ``number`` keys) and every file path
        (``mesh.file``, a field pattern's ``file``) resolved to an absolute path
        (``mesh.file`` may be None).  Treat it as read-only.
    source : str or None
        Absolute path of the YAML file the scene was read from, if any.  Not
        part of equality: two scenes with the same data are equal.
    """

    data: dict
    source: str | None = field(default=None, compare=False)

    @property
    def name(self) -> str:
        """The scene's ``name``."""
        return self.data["name"]

    @property
    def effects(self) -> frozenset[str]:
        """The effects switched on."""
        return frozenset(self.data["effects"])

    def __getitem__(self, dotted: str) -> Any:
        """Value at a dotted key, e.g. ``scene["viscosity.shear"]``.

        List items are addressed by index (``scene["active_stress.0.type"]``).
        Mappings and lists are returned as copies.

        Raises
        ------
        KeyError
            If the key does not exist in the scene.
        """
        node: Any = self.data
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
        return effect in self.data["effects"]

    def to_yaml(self) -> str:
        """Canonical YAML text of :attr:`data`.

        Stored in output files; ``scene_from_dict(yaml.safe_load(text))`` gives
        back an equal scene (floats are written with ``repr`` precision).
        """
        return yaml.dump(
            self.data,
            Dumper=_Dumper,
            sort_keys=False,
            default_flow_style=False,
            allow_unicode=True,
            width=100,
        )

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
        raise SceneError(
            f"{label} must be a mapping of keys (name, mesh, effects, ...), "
            f"got {type(data).__name__}"
        )
    raw = copy.deepcopy(data)
    base = Path(source).parent if source else Path.cwd()
    try:
        for assignment in overrides:
            apply_override(raw, assignment)
        _validate_schema(raw)
        canonical = _fill(SCHEMA, raw, "")
        _check_rules(canonical)
        _resolve_files(canonical, base)
    except SceneError as exc:
        raise SceneError(f"{label}: {exc}") from None
    return Scene(data=canonical, source=source)


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
                f"scene file '{given}' not found, and it is not a built-in scene "
                f"(available: {names})"
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
        data = _yaml_load(text)
    except yaml.YAMLError as exc:
        raise SceneError(f"{label} is not valid YAML: {_yaml_problem(exc)}") from None
    if data is None:
        raise SceneError(f"{label} is empty")
    if not isinstance(data, dict):
        kind = {list: "a list", str: "a string"}.get(type(data), type(data).__name__)
        raise SceneError(
            f"{label} must be a YAML mapping of keys (name, mesh, effects, ...), got {kind}"
        )
    return _build(data, overrides, os.path.abspath(file), label)


# --------------------------------------------------------------------------------------
# Built-in scenes
# --------------------------------------------------------------------------------------

def _builtin_dir() -> Path:
    # The package is installed editable: cortex_ti/ sits next to config/ in the repository.
    return Path(__file__).resolve().parent.parent / "config" / "scenes"


def builtin_scene_names() -> list[str]:
    """Names of the scenes shipped in ``config/scenes`` (sorted)."""
    folder = _builtin_dir()
    return sorted(p.stem for p in folder.glob("*.yaml")) if folder.is_dir() else []


def builtin_scene_path(name: str) -> Path:
    """Path of the built-in scene ``config/scenes/<name>.yaml`` of the repository.

    Parameters
    ----------
    name : str
        Scene name, with or without the ``.yaml`` suffix.

    Raises
    ------
    SceneError
        If there is no such scene (the message lists the available ones).
    """
    stem = name[:-5] if name.endswith(".yaml") else name
    folder = _builtin_dir()
    path = folder / f"{stem}.yaml"
    if "/" not in stem and os.sep not in stem and path.is_file():
        return path
    if not folder.is_dir():
        raise SceneError(
            f"no built-in scene '{stem}': the folder '{folder}' does not exist "
            "(cortex_ti must be installed editable from its repository)"
        )
    names = ", ".join(builtin_scene_names()) or "(none)"
    raise SceneError(f"no built-in scene '{stem}'; available scenes: {names}")
