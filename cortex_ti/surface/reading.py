"""Reading a user's surface mesh from any format meshio understands, then validating it."""

from __future__ import annotations

import contextlib
import io
import logging
import os
import warnings

import numpy as np

from ..errors import MeshError
from .mesh import Mesh
from .validation import validate_mesh

__all__ = ["read_meshio", "load_mesh"]

logger = logging.getLogger(__name__)


def read_meshio(path):
    """Read any file meshio understands and return the ``meshio.Mesh``, quietly.

    meshio prints diagnostics and may call ``sys.exit()`` on a failed read; both are caught
    here and turned into one :class:`MeshError` naming the file and meshio's reason.
    (Used by :func:`load_mesh` and by the ``field`` active-stress pattern.)
    """
    import meshio  # local import: only needed for files

    name = os.fspath(path)
    out, err = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = meshio.read(name)
    except (Exception, SystemExit) as exc:
        printed = " ".join((out.getvalue() + " " + err.getvalue()).replace("Error:", " ").split())
        reason = f"{type(exc).__name__}: {str(exc).strip()}" if isinstance(exc, Exception) else ""
        reason = "; ".join(r for r in (reason, printed) if r) or "meshio gave no reason"
        raise MeshError(
            f"cannot read mesh file '{name}': {reason} (is the file extension right and the file intact?)"
        ) from None
    if out.getvalue().strip() or err.getvalue().strip():
        logger.debug("meshio output while reading %s: %s", name, out.getvalue() + err.getvalue())
    return m


def load_mesh(path) -> Mesh:
    """Read a closed triangle surface from any file format meshio can read.

    Parameters
    ----------
    path : str or os.PathLike
        Mesh file (``.obj``, ``.ply``, ``.stl``, ``.vtu``, ``.off``, ``.msh``, ...).

    Returns
    -------
    Mesh
        The cleaned, validated, outward-oriented surface (see
        :func:`validate_mesh`; the file name is used in error messages).

    Raises
    ------
    MeshError
        If the file does not exist, cannot be read, contains cells other than
        triangles, contains no triangles, or fails :func:`validate_mesh`.
    """
    name = os.fspath(path)
    if not os.path.exists(name):
        raise MeshError(f"mesh file '{name}' does not exist")
    if os.path.isdir(name):
        raise MeshError(f"mesh file '{name}' is a directory, not a file")
    m = read_meshio(name)

    counts: dict[str, int] = {}
    triangles = []
    for block in m.cells:
        counts[block.type] = counts.get(block.type, 0) + len(block.data)
        if block.type == "triangle":
            triangles.append(np.asarray(block.data))
    other = {t: c for t, c in counts.items() if t != "triangle" and c > 0}
    if other:
        desc = ", ".join(f"{c} {t}" for t, c in other.items())
        raise MeshError(
            f"mesh '{name}' contains non-triangle cells ({desc}); cortex-ti needs a surface made only of triangles"
        )
    if not triangles or sum(len(t) for t in triangles) == 0:
        raise MeshError(f"mesh '{name}' contains no triangles")
    faces = np.concatenate(triangles, axis=0)
    return validate_mesh(m.points, faces, name=name)
