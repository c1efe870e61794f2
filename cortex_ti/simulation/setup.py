"""Set-up of a run from its settings: the initial mesh, the initial shape and the active tension.

The active tension is evaluated on the mesh before ``mesh.transform`` / ``mesh.shear`` deform it
(paper Sec. 4.4: the stress is assigned on the undeformed sphere), and is afterwards carried
by the nodes.
"""

from __future__ import annotations

import numpy as np

from ..errors import CortexError
from ..physics.fields import scene_fields
from ..physics.patterns import evaluate_active_stress
from ..scene.settings import RunSettings
from ..surface.mesh import Mesh, affine, icosphere
from ..surface.reading import load_mesh

__all__ = ["initial_mesh", "active_tension", "initial_fields", "initial_shape"]


def initial_mesh(settings: RunSettings) -> Mesh:
    """The icosphere or the user's mesh the settings name (before the initial deformation)."""
    if settings.mesh.file:
        return load_mesh(settings.mesh.file)
    return icosphere(int(settings.mesh.nodes), settings.mesh.radius)


def active_tension(mesh: Mesh, settings: RunSettings) -> np.ndarray:
    """The active tension at the nodes of the undeformed ``mesh`` (zeros without active stress).

    Reads field files and runs python patterns, so ``cortex-ti check`` calls it too."""
    if not settings.has("active_stress"):
        return np.zeros(mesh.n_nodes)
    return evaluate_active_stress(mesh.points, list(settings.patterns))


def initial_fields(mesh: Mesh, settings: RunSettings) -> dict[str, np.ndarray]:
    """The scene's nodal fields (:data:`cortex_ti.physics.fields.FIELDS`) on the undeformed ``mesh``.

    Reads field files and runs python patterns, so ``cortex-ti check`` calls it too."""
    return {spec.name: np.asarray(spec.initial(settings, mesh.points), dtype=float) for spec in scene_fields(settings)}


def initial_shape(mesh: Mesh, settings: RunSettings) -> Mesh:
    """The mesh deformed by the settings' initial affine map and shear (itself if there is none)."""
    matrix = settings.mesh.initial_map()
    if matrix is None:
        return mesh
    if not np.all(np.isfinite(matrix)) or abs(np.linalg.det(matrix)) < 1e-12:
        raise CortexError(f"scene '{settings.name}': mesh.transform/mesh.shear give a singular or non-finite map")
    return affine(mesh, matrix)
