"""The scene schema: loaded from ``scene.schema.json``, its vocabularies filled from the registries.

The JSON file (draft 2020-12) holds every key of a scene, its type, default and meaning. The
values of the keys that name a registered thing are not written in it but taken from the one
registry that defines them, when the schema is built: ``numerics.fit`` from
:data:`cortex_ti.surface.fits.FIT_SCHEMES`, ``numerics.formulation`` from
:data:`cortex_ti.physics.formulations.FORMULATIONS` (``numerics.pressure_weights`` from
:data:`cortex_ti.physics.formulations.PRESSURE_WEIGHTS`), ``time.scheme`` from
:data:`cortex_ti.dynamics.schemes.SCHEMES`, ``solver.backend`` from
:data:`cortex_ti.solve.factorizations.FACTORIZATIONS` (plus ``auto``), and the active-stress
pattern types with their parameters from :func:`cortex_ti.physics.patterns.pattern_schemas`.
:func:`full_schema` gives the complete schema (``cortex-ti schema`` prints it).

This module also validates a raw scene against it (:func:`validate_schema`, one message naming
the dotted key) and fills in the defaults (:func:`fill_defaults`).
"""

from __future__ import annotations

import copy
import difflib
import importlib.resources
import json
import math
from collections.abc import Iterable, Iterator
from typing import Any

import jsonschema

from ..dynamics.motion import MESH_MOTIONS
from ..dynamics.schemes import SCHEMES
from ..errors import SceneError
from ..physics.fields import FIELDS
from ..physics.formulations import ACTIVE_FORCES, FORMULATIONS, PRESSURE_WEIGHTS
from ..physics.model import FAR_FIELDS, FLUID_SOLVERS
from ..physics.patterns import pattern_schemas
from ..solve.factorizations import backend_names
from ..surface.fits import FIT_SCHEMES

__all__ = [
    "current_schema",
    "full_schema",
    "validate_schema",
    "fill_defaults",
    "deref",
    "properties",
    "keyword",
    "join_key",
    "dotted_key",
    "fmt_value",
    "unknown_key",
]


# --------------------------------------------------------------------------------------
# The schema
# --------------------------------------------------------------------------------------


def full_schema() -> dict:
    """The scene schema with the registries' vocabularies filled in (a new copy)."""
    schema = json.loads(
        importlib.resources.files("cortex_ti.scene").joinpath("scene.schema.json").read_text(encoding="utf-8")
    )
    props = schema["properties"]
    props["numerics"]["properties"]["fit"]["enum"] = list(FIT_SCHEMES)
    props["numerics"]["properties"]["formulation"]["enum"] = list(FORMULATIONS)
    props["numerics"]["properties"]["pressure_weights"]["enum"] = list(PRESSURE_WEIGHTS)
    props["numerics"]["properties"]["active_force"]["enum"] = list(ACTIVE_FORCES)
    props["time"]["properties"]["scheme"]["enum"] = list(SCHEMES)
    props["mesh"]["properties"]["motion"]["enum"] = list(MESH_MOTIONS)
    props["solver"]["properties"]["backend"]["enum"] = backend_names()
    props["fluid"]["properties"]["far_field"]["properties"]["type"]["enum"] = list(FAR_FIELDS)
    props["fluid"]["properties"]["solver"]["enum"] = list(FLUID_SOLVERS)
    fragments = pattern_schemas()
    schema["$defs"] = {"pattern": _pattern_schema(list(fragments)), **copy.deepcopy(fragments)}
    for name, spec in FIELDS.items():
        if spec.schema is not None:
            schema["$defs"][f"field_{name}"] = copy.deepcopy(dict(spec.schema))
            props["fields"]["properties"][name] = {"$ref": f"#/$defs/field_{name}"}
    return schema


def _pattern_schema(names: list[str]) -> dict:
    """One active-stress pattern: its ``type`` one of the registered patterns, its other keys
    checked by that pattern's own fragment (``$defs/<type>``)."""
    return {
        "description": "One active-stress pattern; the keys allowed depend on its type "
        "(cortex_ti.physics.patterns.pattern_schemas).",
        "type": "object",
        "required": ["type"],
        "properties": {"type": {"enum": names}},
        "allOf": [
            {"if": {"properties": {"type": {"const": name}}, "required": ["type"]}, "then": {"$ref": f"#/$defs/{name}"}}
            for name in names
        ],
    }


_BUILT: dict = {}


def current_schema() -> dict:
    """The schema for the registries as they are now (built again after a registration)."""
    key = (
        tuple(FIT_SCHEMES),
        tuple(FORMULATIONS),
        tuple(SCHEMES),
        tuple(MESH_MOTIONS),
        tuple(FIELDS),
        tuple(backend_names()),
        tuple((name, id(fragment)) for name, fragment in pattern_schemas().items()),
    )
    if _BUILT.get("key") != key:
        schema = full_schema()
        _BUILT.update(key=key, schema=schema, validator=jsonschema.Draft202012Validator(schema))
    return _BUILT["schema"]


def _validator() -> jsonschema.Draft202012Validator:
    current_schema()
    return _BUILT["validator"]


def deref(schema: dict) -> dict:
    """Follow local ``$ref`` pointers (``#/...``) of the scene schema."""
    while "$ref" in schema:
        ref = schema["$ref"]
        if not ref.startswith("#/"):
            raise ValueError(f"only local $ref are supported in the scene schema, got {ref!r}")
        node: Any = current_schema()
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
    schema = deref(schema)
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


def properties(schema: dict, instance: Any = _UNKNOWN) -> dict[str, dict]:
    """The object properties (name -> subschema) that apply to ``instance``, in schema order."""
    props: dict[str, dict] = {}
    for branch in _branches(schema, instance):
        for key, sub in branch.get("properties", {}).items():
            props.setdefault(key, sub)
    return props


def keyword(schema: dict, keyword: str, instance: Any = _UNKNOWN) -> Any:
    """First value of ``keyword`` among the branches of ``schema`` (None if absent)."""
    for branch in _branches(schema, instance):
        if keyword in branch:
            return branch[keyword]
    return None


# --------------------------------------------------------------------------------------
# Messages
# --------------------------------------------------------------------------------------


def join_key(path: str, key: Any) -> str:
    return f"{path}.{key}" if path else str(key)


def dotted_key(parts: Iterable[Any]) -> str:
    return ".".join(str(p) for p in parts)


def fmt_value(value: Any) -> str:
    """Short human form of a value: 1.0 -> '1', nan -> 'nan', 'x' -> "'x'"."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:g}" if math.isfinite(value) else str(value)
    if isinstance(value, str):
        return repr(value)
    return str(value)


def unknown_key(dotted: str, siblings: Iterable[str]) -> str:
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
    for keyword, op in (("minimum", ">="), ("exclusiveMinimum", ">"), ("maximum", "<="), ("exclusiveMaximum", "<")):
        if keyword in schema:
            parts.append(f"{op} {fmt_value(schema[keyword])}")
    return (" " + " and ".join(parts)) if parts else ""


def _kind(schema: dict) -> str:
    types = schema.get("type", "number")
    types = [types] if isinstance(types, str) else list(types)
    return "an integer" if "integer" in types else "a finite number"


_PRIORITY = {"additionalProperties": 0, "required": 1, "type": 2, "enum": 3, "const": 3}


def _schema_message(err: jsonschema.ValidationError) -> str:
    """Turn one jsonschema error into a message naming the dotted key."""
    path = dotted_key(err.absolute_path)
    where = path or "the scene"
    v = err.validator
    if v == "additionalProperties":
        allowed = list(err.schema.get("properties", {}))
        extras = [k for k in err.instance if k not in allowed]
        return unknown_key(join_key(path, extras[0]), [join_key(path, a) for a in allowed])
    if v == "required":
        missing = [k for k in err.validator_value if k not in err.instance]
        key = join_key(path, missing[0] if missing else "?")
        if key == "mesh":
            return "mesh is required (give mesh.nodes or mesh.file)"
        if key.endswith(".type") and path.startswith("active_stress"):
            return f"{key} is required (one of: {', '.join(_pattern_types())})"
        return f"{key} is required"
    if v in ("minimum", "exclusiveMinimum", "maximum", "exclusiveMaximum"):
        return f"{where} must be {_kind(err.schema)}{_bound_text(err.schema)}, got {fmt_value(err.instance)}"
    if v == "enum":
        options = ", ".join(str(o) for o in err.validator_value)
        return f"{where} must be one of: {options}; got {fmt_value(err.instance)}"
    if v == "const":
        return f"{where} must be {fmt_value(err.validator_value)}, got {fmt_value(err.instance)}"
    if v in ("minItems", "maxItems"):
        lo, hi = err.schema.get("minItems"), err.schema.get("maxItems")
        n = f"{lo}" if lo == hi else f"at least {lo}" if v == "minItems" else f"at most {hi}"
        return f"{where} must have {n} item{'s' if (lo or hi) != 1 else ''}, got {fmt_value(err.instance)}"
    if v == "minLength":
        return f"{where} must not be empty"
    if v == "pattern":
        example = (err.schema.get("examples") or [None])[0]
        like = f"look like {fmt_value(example)}" if example else f"match {err.validator_value!r}"
        return f"{where} must {like}, got {fmt_value(err.instance)}"
    return f"{where}: {err.message}"


def _pattern_types() -> list[str]:
    return list(pattern_schemas())


# --------------------------------------------------------------------------------------
# Validation steps
# --------------------------------------------------------------------------------------


def validate_schema(data: dict) -> None:
    errors = list(_validator().iter_errors(data))
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


def fill_defaults(schema: dict, value: Any, path: str) -> Any:
    """Return a canonical copy of a schema-valid ``value``.

    Fills defaults, orders mapping keys as in the schema, coerces ints to floats
    for ``number`` keys (and integral floats to ints for ``integer`` keys) and
    rejects non-finite numbers (NaN and +-inf pass JSON-schema bounds checks).
    """
    if isinstance(value, dict):
        props = properties(schema, value)
        out: dict = {}
        for key, sub in props.items():
            if key in value:
                out[key] = fill_defaults(sub, value[key], join_key(path, key))
            else:
                fragment = deref(sub)
                if "default" in fragment:
                    out[key] = fill_defaults(sub, copy.deepcopy(fragment["default"]), join_key(path, key))
        for key, item in value.items():  # not reachable for schema-valid data
            out.setdefault(key, copy.deepcopy(item))
        return out
    if isinstance(value, list):
        items = keyword(schema, "items", value)
        if items is None:
            return copy.deepcopy(value)
        return [fill_defaults(items, item, join_key(path, i)) for i, item in enumerate(value)]
    if isinstance(value, bool) or value is None or isinstance(value, str):
        return value
    if isinstance(value, (int, float)):
        frag = next((b for b in _branches(schema, value) if "type" in b), deref(schema))
        if isinstance(value, float) and not math.isfinite(value):
            raise SceneError(f"{path} must be {_kind(frag)}{_bound_text(frag)}, got {fmt_value(value)}")
        types = frag.get("type", [])
        types = [types] if isinstance(types, str) else list(types)
        if "integer" in types and isinstance(value, float) and value.is_integer():
            return int(value)
        if "number" in types and "integer" not in types and isinstance(value, int):
            return float(value)
        return value
    return copy.deepcopy(value)
