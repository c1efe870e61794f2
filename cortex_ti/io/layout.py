"""The layout of a trajectory file (:mod:`cortex_ti.io.trajectory` describes it): the per-frame variables
every file has and their attributes, the global attributes, the checks of what a writer's caller
declares (extra and per-node variables, triangles), a new file's dimensions and variables, the
values of one frame, and the scene comparison that decides whether a partial file can be resumed.
"""

from __future__ import annotations

import datetime as _dt
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..about import package_version
from .files import PARTIAL_SUFFIX

#: The per-frame variables every trajectory has: name -> (dims, attrs).
FRAME_VARIABLES: dict[str, tuple[tuple[str, ...], dict[str, str]]] = {
    "points": (("time", "node", "xyz"), {"units": "R0", "long_name": "node positions"}),
    "velocity": (("time", "node", "xyz"), {"units": "R0/t_a", "long_name": "cortex velocity at the nodes"}),
    "active_stress": (("time", "node"), {"units": "zeta_0", "long_name": "isotropic active tension zeta at the nodes"}),
    "pressure": (
        ("time",),
        {
            "units": "zeta_0/R0",
            "long_name": "pressure difference P = p_inside - p_outside (NaN without incompressibility)",
        },
    ),
}
_TIME_ATTRS = {"units": "t_a", "long_name": "time"}
_TRIANGLE_ATTRS = {"units": "1", "long_name": "node indices (0-based) of each triangle"}
_EXTRA_DIMS = ("time", "node", "xyz")
_RESERVED = {"time", "triangles", *FRAME_VARIABLES}
_TIME_CHUNK = 1024
#: Prefix of the stored values of the scene's ``field`` patterns: ``field_values_<i>`` (node), pattern i.
FIELD_PREFIX = "field_values_"
_REFERENCE_ATTRS = {"units": "R0", "long_name": "node positions right after the remeshing (the ALE reference)"}


#: Variables renamed since older files were written: old name -> the name a reader sees
RENAMED_VARIABLES = {"lsq_residual": "force_residual"}


def _same_scene_but_time(a, b) -> bool:
    """Scenes equal up to their ``time`` section (a run may be resumed with a new t_end or dt)."""
    return scene_difference(a, b) is None


def scene_difference(stored, new) -> str | None:
    """The first key (dotted) in which two scene YAML texts differ outside their ``time`` section,
    as ``"mesh.nodes is 642 in the file, 162 now"``; None if they agree there. The stored scene is
    read, as the new one, as today's loader would have written it
    (:func:`~cortex_ti.scene.loader.stored_scene_data`): a key added since it was written counts as
    its default."""
    import yaml

    try:
        da, db = yaml.safe_load(stored), yaml.safe_load(new)
    except Exception:
        return None if stored == new else "the stored scene cannot be read"
    if not isinstance(da, dict) or not isinstance(db, dict):
        return None if stored == new else "the stored scene is not a mapping"
    from ..scene.loader import stored_scene_data

    # both as today's loader writes them: a key added since the file was written (the ring's center, the
    # division section) compares at its default
    da, db = stored_scene_data(da), stored_scene_data(db)
    da.pop("time", None)
    db.pop("time", None)

    def first(a, b, key):
        if isinstance(a, dict) and isinstance(b, dict):
            for k in [*a, *(k for k in b if k not in a)]:
                found = first(a.get(k, "(not set)"), b.get(k, "(not set)"), f"{key}.{k}" if key else str(k))
                if found:
                    return found
            return None
        if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
            for i, (x, y) in enumerate(zip(a, b, strict=True)):
                found = first(x, y, f"{key}.{i}")
                if found:
                    return found
            return None
        if a == b:
            return None
        return f"{key} is {_short(a)} in the file, {_short(b)} now"

    return first(da, db, "")


def _short(value) -> str:
    text = value if isinstance(value, str) and value == "(not set)" else repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def partial_path(path: str | os.PathLike) -> Path:
    """The in-progress file of a trajectory: ``<path>.partial``."""
    return Path(os.fspath(path) + PARTIAL_SUFFIX)


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def _attr_value(name: str, value: Any) -> Any:
    """Convert a global attribute to a type netCDF4 can store."""
    if isinstance(value, (bool, np.bool_)):
        return np.int8(value)
    if isinstance(value, (str, int, float, np.integer, np.floating)):
        return value
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, (list, tuple, np.ndarray)):
        arr = np.asarray(value)
        if arr.dtype.kind in "iuf" and arr.ndim == 1:
            return arr
    raise TypeError(
        f"global attribute {name!r}: cannot store {type(value).__name__} in netCDF "
        "(use a string, a number or a 1-d list of numbers)"
    )


def _global_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """The caller's attributes plus effects/scene derived from a Scene, version and time."""
    from ..scene import Scene

    out: dict[str, Any] = {}
    attrs = dict(attrs)
    scene = attrs.get("scene")
    if isinstance(scene, Scene):
        attrs["scene"] = scene.to_yaml()
        attrs.setdefault("effects", list(scene.data["effects"]))
    effects = attrs.get("effects")
    if effects is not None and not isinstance(effects, str):
        attrs["effects"] = ",".join(effects)
    missing = [k for k in ("effects", "scene") if k not in attrs]
    if missing:
        raise ValueError(
            f"TrajectoryWriter attrs must contain {' and '.join(missing)} "
            "(or 'scene' as a Scene, from which effects are derived)"
        )
    attrs.pop("cortex_ti_version", None)  # always this package's version
    out["effects"] = _attr_value("effects", attrs.pop("effects"))
    out["scene"] = _attr_value("scene", attrs.pop("scene"))
    out["cortex_ti_version"] = package_version()
    out["created"] = _attr_value("created", attrs.pop("created", _now()))
    for key, value in attrs.items():
        out[key] = _attr_value(key, value)
    return out


def _declared(extra_vars: Mapping, allowed=_EXTRA_DIMS) -> dict[str, tuple[tuple[str, ...], dict[str, str]]]:
    """The caller's extra per-frame variables, checked: ``name -> (dims, attrs)``."""
    out = {}
    for name, spec in extra_vars.items():
        try:
            dims, attrs = spec
        except (TypeError, ValueError):
            raise ValueError(f"extra_vars[{name!r}] must be (dims, attrs)") from None
        dims = tuple(dims)
        if name in _RESERVED:
            raise ValueError(f"extra variable {name!r} clashes with a standard variable")
        if not dims or dims[0] != "time" or any(d not in allowed for d in dims) or len(set(dims)) != len(dims):
            raise ValueError(
                f"extra variable {name!r}: dims must start with 'time' and use "
                f"{tuple(allowed)} without repeats, got {dims}"
            )
        attrs = dict(attrs)
        missing = [k for k in ("units", "long_name") if not isinstance(attrs.get(k), str)]
        if missing:
            raise ValueError(f"extra variable {name!r}: attrs must give {' and '.join(missing)}")
        out[name] = (dims, attrs)
    return out


def _node_variables(node_vars: Mapping, n_nodes: int) -> dict:
    """Per-node constants written once (e.g. a ``field`` pattern's values): ``name -> (values, attrs)``."""
    out = {}
    for name, (values, attrs) in node_vars.items():
        if name in _RESERVED:
            raise ValueError(f"node variable {name!r} clashes with a standard variable")
        out[name] = (_array(name, values, (n_nodes,)), dict(attrs))
    return out


def _triangles(triangles, n_nodes: int) -> np.ndarray:
    """The triangles as int32, checked against the node count."""
    tri = np.asarray(triangles)
    if tri.ndim != 2 or tri.shape[1] != 3 or tri.shape[0] == 0:
        raise ValueError(f"triangles must have shape (n_faces, 3), got {tri.shape}")
    if tri.dtype.kind not in "iu":
        raise ValueError(f"triangles must be integer node indices, got dtype {tri.dtype}")
    if tri.min() < 0 or tri.max() >= n_nodes:
        raise ValueError(f"triangles index nodes outside 0..{n_nodes - 1}")
    return tri.astype(np.int32)


def _layout(nc, sizes: dict, triangles: np.ndarray, variables: Mapping, attrs: Mapping) -> None:
    """Dimensions, variables (chunked one frame per chunk), triangles and attributes of a new file."""
    nc.dimensions = {
        "time": None,
        "node": sizes["node"],
        "xyz": 3,
        "face": len(triangles),
        "corner": 3,
        **{k: v for k, v in sizes.items() if k not in ("time", "node", "xyz")},
    }
    t = nc.create_variable("time", ("time",), "f8", chunks=(_TIME_CHUNK,))
    t.attrs.update(_TIME_ATTRS)
    for name, (dims, var_attrs) in variables.items():
        chunks = tuple(1 if d == "time" else sizes[d] for d in dims)
        var = nc.create_variable(name, dims, "f8", chunks=(_TIME_CHUNK,) if chunks == (1,) else chunks)
        var.attrs.update(var_attrs)
    tri = nc.create_variable("triangles", ("face", "corner"), "i4", data=triangles)
    tri.attrs.update(_TRIANGLE_ATTRS)
    nc.attrs.update(attrs)


def _array(name: str, value, shape: tuple[int, ...]) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {arr.shape}")
    return arr


def _frame_values(sizes: dict, declared: Mapping, points, velocity, active_stress, pressure, extra) -> dict:
    """One frame's values by variable, each checked against its shape; the extras exactly those declared."""
    n = sizes["node"]
    values = {
        "points": _array("points", points, (n, 3)),
        "velocity": _array("velocity", velocity, (n, 3)),
        "active_stress": _array("active_stress", active_stress, (n,)),
        "pressure": _array("pressure", pressure, ()),
    }
    unknown = sorted(set(extra) - set(declared))
    missing = sorted(set(declared) - set(extra))
    if unknown or missing:
        problems = ([f"undeclared extra variables {unknown}"] if unknown else []) + (
            [f"missing extra variables {missing}"] if missing else []
        )
        raise ValueError("append(): " + "; ".join(problems))
    for name, (dims, _) in declared.items():
        values[name] = _array(name, extra[name], tuple(sizes[d] for d in dims[1:]))
    return values
