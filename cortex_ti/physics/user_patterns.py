"""Active-stress patterns a user supplies: a per-node ``field`` read from a file, and a
``python`` function. Both register themselves in :data:`cortex_ti.physics.patterns.PATTERNS`.
"""

from __future__ import annotations

import importlib
import inspect
import os
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..errors import MeshError, SceneError
from .patterns import finite_number, register_pattern

__all__ = ["read_node_field", "field_pattern", "resolve_function", "python_pattern", "add_pattern_folder"]

#: Suffixes read with numpy; any other suffix is read with meshio (``point_data``).
_TEXT_DELIMITERS = {".txt": None, ".csv": ","}


def read_node_field(path, name: str | None = None) -> np.ndarray:
    """Read one number per node from a file: the values of a ``field`` pattern.

    Parameters
    ----------
    path : str or path-like
        ``.npy``: a 1-D array (``numpy.save``); ``.txt`` / ``.csv``: one number per line
        (``numpy.loadtxt``, ``#`` comments allowed); any other suffix: a mesh file meshio
        reads (``.vtu``, ``.vtk``, ``.ply``, ...), whose point data holds the values.
        A relative path is taken relative to the working directory (a scene makes its
        ``file`` absolute first, relative to the scene file's folder).
    name : str, optional
        Mesh files only: the point-data array to use.  Without it the file must hold
        exactly one point-data array.  An ``(N, 1)`` array counts as ``(N,)``.

    Returns
    -------
    ndarray, shape (n,), float64
        The values in file order (the count and finiteness are checked by the pattern).

    Raises
    ------
    SceneError
        Missing or unreadable file, a ``name`` for a numpy file, an unknown or ambiguous
        point-data array, or values that are not one number per node.
    """
    from ..surface.reading import read_meshio

    file = Path(os.fspath(path)).expanduser()
    label = f"field file '{file}'"
    if not file.is_file():
        raise SceneError(f"{label} {'is a folder, not a file' if file.is_dir() else 'does not exist'}")
    suffix = file.suffix.lower()
    if suffix == ".npy" or suffix in _TEXT_DELIMITERS:
        if name is not None:
            raise SceneError(
                f"{label}: 'name' ({name!r}) selects a point-data array of a mesh file, but a {suffix} "
                "file holds a single array: remove 'name'"
            )
        if suffix == ".npy":
            try:
                arr = np.load(file, allow_pickle=False)
            except (OSError, ValueError, EOFError) as exc:
                raise SceneError(f"cannot read {label} as a numpy array: {exc}") from None
            if not isinstance(arr, np.ndarray) or arr.dtype.kind not in "biuf":
                raise SceneError(f"{label} holds {getattr(arr, 'dtype', type(arr).__name__)} values, not numbers")
            if arr.ndim != 1:
                raise SceneError(f"{label} holds an array of shape {arr.shape}; need a 1-D array, one value per node")
        else:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # numpy warns about an empty file; reported below
                    arr = np.loadtxt(file, dtype=float, delimiter=_TEXT_DELIMITERS[suffix], ndmin=2)
            except (OSError, ValueError, UnicodeDecodeError) as exc:
                raise SceneError(f"cannot read {label} as one number per line: {exc}") from None
            if arr.size and arr.shape[1] != 1:
                raise SceneError(f"{label} has {arr.shape[1]} numbers per line; need one number per line")
            arr = arr.reshape(-1)
    else:
        try:
            mesh = read_meshio(file)
        except MeshError as exc:
            raise SceneError(str(exc)) from None
        data = mesh.point_data
        names = ", ".join(repr(k) for k in data) or "none"
        if name is None:
            if len(data) != 1:
                raise SceneError(
                    f"{label} has {len(data)} point-data arrays ({names}): give 'name' to choose one"
                    if data
                    else f"{label} has no point data (one value per node is needed)"
                )
            name = next(iter(data))
        elif name not in data:
            raise SceneError(f"{label} has no point-data array {name!r}; it has: {names}")
        arr = np.asarray(data[name])
        if arr.ndim == 2 and arr.shape[1] == 1:
            arr = arr[:, 0]
        if arr.ndim != 1 or arr.dtype.kind not in "biuf":
            raise SceneError(
                f"point-data array {name!r} of {label} has shape {arr.shape} ({arr.dtype}); need one number per node"
            )
    if arr.size == 0:
        raise SceneError(f"{label} holds no values")
    return arr.astype(np.float64)


_FIELD_SCHEMA = {
    "description": "A user-supplied per-node field: one value per node of the scene's mesh, in mesh order, "
    "read from a file and multiplied by scale. It exists only at the nodes, so the analytic "
    "sphere solutions (which integrate a pattern by quadrature) cannot use it.",
    "type": "object",
    "additionalProperties": False,
    "required": ["type", "file"],
    "properties": {
        "type": {"const": "field"},
        "file": {
            "description": "The values: .npy (a 1-D array), .txt or .csv (one number per "
            "line), or any mesh file meshio reads (its point data). Relative "
            "paths resolve against the scene file's folder (against the "
            "working directory for a scene without a file or in a --set "
            "override).",
            "type": "string",
            "minLength": 1,
        },
        "name": {
            "description": "Mesh files only: the point-data array to use; may be omitted when "
            "the file has exactly one.",
            "type": ["string", "null"],
            "minLength": 1,
            "default": None,
        },
        "scale": {"description": "Factor applied to the values.", "type": "number", "default": 1.0},
    },
}


@register_pattern("field", per_node=True, schema=_FIELD_SCHEMA)
def field_pattern(points, file, name=None, scale=1.0) -> np.ndarray:
    """A user's per-node field: ``zeta = scale * values``, the values read from ``file``
    (:func:`read_node_field`: ``.npy``, ``.txt``/``.csv`` or a mesh file's point data ``name``).

    The values belong to the nodes in mesh order (the order of the scene's mesh, i.e. of
    ``points``); the positions themselves are not used, so the pattern is defined only on
    that mesh (``per_node``: it cannot be integrated by quadrature).  There must be exactly
    one finite value per node.
    """
    values = read_node_field(file, name)
    n = len(points)
    if values.shape[0] != n:
        raise SceneError(
            f"field file '{file}' has {values.shape[0]} values but the mesh has {n} nodes "
            "(one value per node, in mesh order)"
        )
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise SceneError(
            f"field file '{file}' has {bad.size} non-finite value(s) (NaN or inf), the first at node {bad[0]}"
        )
    return finite_number(scale, "field scale") * values


#: Folders a ``python`` pattern's module is looked for in after ``sys.path``: the folders of the scene
#: files read (:func:`add_pattern_folder`, called by the scene loader; the last read first), then the
#: working directory. A module found is imported once (``sys.modules``), as any import.
_PATTERN_FOLDERS: list[str] = []


def add_pattern_folder(folder) -> None:
    """Let ``python`` patterns import modules from ``folder`` (a scene file's folder: the loader
    calls it for every scene file with a ``python`` pattern)."""
    folder = os.path.abspath(os.fspath(folder))
    if folder in _PATTERN_FOLDERS:
        _PATTERN_FOLDERS.remove(folder)
    _PATTERN_FOLDERS.insert(0, folder)  # the scene read last is searched first


def _import(module: str):
    """``importlib.import_module``; a module not found on ``sys.path`` is looked for in the scene files'
    folders and the working directory (as the patterns guide says), without keeping them on the path."""
    import sys

    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        top = module.split(".")[0]
        if exc.name not in (top, module):
            raise
        folders = [f for f in [*_PATTERN_FOLDERS, os.getcwd()] if f not in sys.path]
        if not folders:
            raise
        sys.path[:0] = folders
        try:
            return importlib.import_module(module)
        finally:
            for f in folders:
                if f in sys.path:
                    sys.path.remove(f)


def _where(exc: BaseException, prefer: str | None = None) -> str:
    """``file:line`` where ``exc`` was raised: the deepest frame in ``prefer`` (the pattern's file), or
    else the deepest of all (empty if there is no traceback)."""
    import traceback

    frames = traceback.extract_tb(exc.__traceback__)
    if prefer is not None:
        mine = [f for f in frames if os.path.abspath(f.filename) == os.path.abspath(prefer)]
        frames = mine or frames
    if isinstance(exc, SyntaxError) and exc.filename:
        return f"{exc.filename}:{exc.lineno}"
    return f"{frames[-1].filename}:{frames[-1].lineno}" if frames else ""


def _what(exc: BaseException) -> str:
    if isinstance(exc, SystemExit):
        return f"called sys.exit({exc.code!r})"
    return f"raised {type(exc).__name__}: {exc}" if str(exc) else f"raised {type(exc).__name__}"


def resolve_function(function) -> tuple[Callable, str]:
    """The callable of a ``python`` pattern and the name to use in messages.

    ``function`` is a callable (Python API only) or a string ``"package.module:func"``
    (``func`` may be dotted, ``module:Class.method``), imported with
    :func:`importlib.import_module`; the module must be importable: installed, on ``sys.path`` /
    ``PYTHONPATH``, beside the scene file, or in the working directory. Importing it runs the
    module's code.

    Raises
    ------
    SceneError
        A malformed target, a module that cannot be imported (whatever the reason, ``sys.exit``
        included: the message names the file and line), a missing attribute, or an attribute that
        is not callable; the message names the target.
    """
    if callable(function):
        return function, getattr(function, "__qualname__", repr(function))
    if not isinstance(function, str):
        raise SceneError(f"python pattern 'function' must be 'package.module:function' or a callable, got {function!r}")
    module, sep, attr = (part.strip() for part in function.partition(":"))
    if not sep or not module or not attr:
        raise SceneError(f"python pattern function {function!r} must look like 'package.module:function'")
    try:
        obj = _import(module)
    except (Exception, SystemExit) as exc:  # ImportError, or anything the module raised while being imported
        at = _where(exc) if not isinstance(exc, ModuleNotFoundError) else ""
        raise SceneError(
            f"python pattern function '{function}': cannot import module '{module}' "
            f"({type(exc).__name__}: {exc}{f', at {at}' if at else ''})"
        ) from exc
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise SceneError(
                f"python pattern function '{function}': module '{module}' has no attribute '{attr}'"
            ) from None
    if not callable(obj):
        raise SceneError(f"python pattern function '{function}' is a {type(obj).__name__}, not a callable")
    return obj, function


_PYTHON_SCHEMA = {
    "description": "A user's Python function zeta = func(points, **params), points the (N, 3) node positions "
    "of the initial shape, returning N finite numbers. The module is imported with importlib: "
    "a scene with this pattern runs the user's code (on run and on check). The module must be "
    "importable: installed, on PYTHONPATH, in the scene file's folder or in the working directory.",
    "type": "object",
    "additionalProperties": False,
    "required": ["type", "function"],
    "properties": {
        "type": {"const": "python"},
        "function": {
            "description": "Import target 'package.module:function' (the function may be "
            "dotted, 'module:Class.method').",
            "type": "string",
            "pattern": "^\\s*[A-Za-z_][A-Za-z0-9_]*(\\.[A-Za-z_][A-Za-z0-9_]*)*\\s*:\\s*[A-Za-z_][A-Za-z0-9_]*(\\.[A-Za-z_][A-Za-z0-9_]*)*\\s*$",  # noqa: E501 (one regular expression)
            "examples": ["mypackage.patterns:blob"],
        },
        "params": {
            "description": "Keyword arguments passed to the function (any YAML values).",
            "type": "object",
            "default": {},
        },
    },
}


@register_pattern("python", schema=_PYTHON_SCHEMA)
def python_pattern(points, function, params=None) -> np.ndarray:
    """A user's function: ``zeta = func(points, **params)``, ``func`` from :func:`resolve_function`.

    ``points`` is an ``(N, 3)`` float64 copy of the positions (the function cannot change the
    mesh); the result must be ``N`` finite numbers.  Unlike the ``field`` pattern it is a
    function of position, so the sphere quadrature (mean tension, analytic sphere solutions)
    can use it.  The keyword names in ``params`` are checked against the function's signature
    before the call; an exception raised inside the function (``sys.exit`` included) becomes a
    :class:`~cortex_ti.errors.SceneError` naming the pattern, its file and line, chained to the
    original (whose traceback the command line shows with ``--debug``).

    A callable as ``function`` works wherever a pattern list is used directly
    (:func:`evaluate_active_stress`, :func:`integrate_patterns`, :mod:`cortex_ti.truth.analytic`), not
    in a :class:`~cortex_ti.scene.Scene`: a scene is stored as YAML text with every trajectory,
    so its ``function`` must be the ``"module:func"`` string.
    """
    func, target = resolve_function(function)
    params = {} if params is None else params
    if not isinstance(params, dict):
        raise SceneError(f"python pattern '{target}': params must be a mapping of keyword arguments, got {params!r}")
    pts = np.array(points, dtype=np.float64)  # a copy
    try:
        sig = inspect.signature(func)
    except (TypeError, ValueError):  # no signature available (some builtins): just call it
        sig = None
    if sig is not None:
        try:
            sig.bind(pts, **params)
        except TypeError as exc:
            kw = "".join(f", {k}=..." for k in params)
            raise SceneError(f"python pattern '{target}' cannot be called as {target}(points{kw}): {exc}") from None
    try:
        out = func(pts, **params)
    except (Exception, SystemExit) as exc:
        try:
            mine = inspect.getsourcefile(func)
        except TypeError:
            mine = None
        at = _where(exc, mine)
        raise SceneError(f"python pattern '{target}' {_what(exc)}{f' (at {at})' if at else ''}") from exc
    try:
        val = np.asarray(out, dtype=np.float64)
    except (TypeError, ValueError):
        raise SceneError(f"python pattern '{target}' returned {type(out).__name__}, not an array of numbers") from None
    if val.shape != (len(pts),):
        raise SceneError(
            f"python pattern '{target}' returned an array of shape {val.shape}; need ({len(pts)},), one value per point"
        )
    bad = np.flatnonzero(~np.isfinite(val))
    if bad.size:
        raise SceneError(
            f"python pattern '{target}' returned {bad.size} non-finite value(s) (NaN or inf), the first "
            f"at point {bad[0]}"
        )
    return val
