"""File paths in a scene (``mesh.file``, a field pattern's ``file``): which keys hold them and how
they resolve (relative to the scene file's folder, or to the working directory for overrides)."""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from ..errors import SceneError

__all__ = ["is_file_key", "resolve_files", "paths_from_cwd"]


def is_file_key(parts: Sequence[str]) -> bool:
    """Whether a dotted key (as parts) holds a file path: ``mesh.file`` or ``active_stress.<i>.file``
    (only the ``field`` pattern has a ``file``).  The one list of path keys."""
    parts = tuple(parts)
    return parts == ("mesh", "file") or (len(parts) == 3 and parts[0] == "active_stress" and parts[2] == "file")


def _file_keys(data: dict) -> Iterator[tuple[str, dict, str]]:
    """``(dotted key, mapping, key)`` of every file path in a scene mapping (see :func:`is_file_key`)."""
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


def paths_from_cwd(value: Any, parts: Sequence[str]) -> Any:
    """An override's value with every file path in it (at ``parts`` or nested, e.g.
    ``active_stress=[{type: field, file: f.npy}]``) made absolute against the working directory."""
    if isinstance(value, str) and value and is_file_key(parts):
        return str(_absolute(value, Path.cwd()))
    if isinstance(value, dict):
        return {k: paths_from_cwd(v, [*parts, str(k)]) for k, v in value.items()}
    if isinstance(value, list):
        return [paths_from_cwd(v, [*parts, str(i)]) for i, v in enumerate(value)]
    return value


def resolve_files(data: dict, base: Path) -> None:
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
