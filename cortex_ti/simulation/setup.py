"""Set-up of a run from its settings: the initial mesh, the initial shape and the active tension.

The active tension is evaluated on the mesh before ``mesh.transform`` / ``mesh.shear`` deform it
(paper Sec. 4.4: the stress is assigned on the undeformed sphere), and is afterwards carried
by the nodes.
"""

from __future__ import annotations

import numpy as np

from ..errors import CortexError, SceneError
from ..physics.fields import scene_fields
from ..physics.patterns import evaluate_active_stress
from ..scene.rules import FLUIDS_MAX_NODES, fluids_size_message
from ..scene.settings import RunSettings
from ..surface.mesh import Mesh, affine, icosphere
from ..surface.reading import load_mesh

__all__ = [
    "initial_mesh",
    "active_tension",
    "initial_fields",
    "initial_shape",
    "relaxed_start",
    "SceneSetup",
    "field_moves",
]

#: The relaxation of a distorted start (``mesh.relax_start``): explicit steps of the conformal
#: distortion's gradient flow (:func:`cortex_ti.dynamics.motion.ale_velocity`) and their length in
#: units of the flow's relaxation time. 0.2 is stable on every icosphere up to 2562 nodes (0.4 folds
#: triangles at 2562: the distortion does not see an inverted triangle); 1500 steps bring the
#: smallest angle of the shear_075 start from 31.7 to 39.2 deg at 2562 nodes.
RELAX_STEPS, RELAX_STEP = 1500, 0.2


def initial_mesh(settings: RunSettings) -> Mesh:
    """The icosphere or the user's mesh the settings name (before the initial deformation); with
    ``mesh.relax_start`` the icosphere's nodes moved along it so that the initial map's image has
    mended triangles (:func:`relaxed_start`)."""
    if settings.mesh.file:
        mesh = load_mesh(settings.mesh.file)
        if settings.numerics.formulation_entry.curved:
            return split_for_curved_cells(mesh, settings.numerics.fit)
        return mesh
    sphere = icosphere(int(settings.mesh.nodes), settings.mesh.radius)
    matrix = settings.mesh.initial_map()
    if settings.mesh.relax_start and matrix is not None:
        return relaxed_start(sphere, matrix, settings.mesh.radius)
    return sphere


def split_for_curved_cells(mesh: Mesh, fit: str) -> Mesh:
    """A user's mesh made into curved six-node cells: every triangle split into four, the new nodes
    placed on the surface the ``fit`` describes (:func:`cortex_ti.surface.curved.split_mesh`)."""
    from ..surface.curved import split_mesh
    from ..surface.fits import StencilChooser
    from ..surface.geometry import compute_geometry
    from ..surface.topology import build_topology

    topo = build_topology(mesh)
    geometry = compute_geometry(mesh.points, topo, StencilChooser(topo, fit))
    points, faces = split_mesh(mesh.points, mesh.faces, geometry)
    return Mesh(points=points, faces=faces)


def relaxed_start(sphere: Mesh, matrix: np.ndarray, radius: float) -> Mesh:
    """The sphere ``sphere`` (radius ``radius``) with its nodes moved along it so that the triangles
    of its image under ``matrix`` (a shear, an affine transform) come close to the shapes they had on
    the sphere: the image's nodes follow the tangential gradient flow of the conformal distortion
    against the sphere's own triangles, on the image (an ellipsoid, the nodes put back on it after
    each step), and are pulled back by ``matrix^-1``. The sphere and the ellipsoid are conformally
    equivalent, so the flow's target exists; it mends the triangles the map sheared, which the ALE
    of a run (relaxing toward the triangles at t = 0) would otherwise keep. The fields are then
    assigned at the moved nodes, i.e. at their material points on the undeformed sphere."""
    from ..dynamics.motion import MotionContext, ale_velocity

    inverse = np.linalg.inv(matrix)
    reference = MotionContext(sphere.faces, sphere.points, ale_time=1.0)
    u = sphere.points.copy()
    for _ in range(RELAX_STEPS):
        x = u @ matrix.T
        normal = u @ inverse  # the ellipsoid's normal at x: grad |matrix^-1 x|^2 = matrix^-T u
        normal /= np.linalg.norm(normal, axis=1)[:, None]
        x = x + RELAX_STEP * ale_velocity(np.zeros_like(x), normal, x, reference)
        u = x @ inverse.T
        u *= radius / np.linalg.norm(u, axis=1)[:, None]
    p = u[sphere.faces]
    if np.any(np.einsum("tc,tc->t", np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]), p.sum(1)) <= 0.0):
        raise CortexError("mesh.relax_start folded a triangle of the start: report this with the scene")
    return Mesh(u, sphere.faces)


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


#: relative asymmetry of a field's initial values about the mirror plane that ``mesh.remesh.mirror`` refuses
MIRROR_TOLERANCE = 1e-9


def check_mirror_symmetric(mesh: Mesh, settings: RunSettings, values: dict[str, np.ndarray]) -> None:
    """``mesh.remesh.mirror`` keeps the plane through the area centroid perpendicular to the pattern's axis a
    plane of symmetry, so it refuses a start that is not symmetric about it: a field (the active tension,
    the myosin) whose initial values at the nodes' mirror images differ from those at the nodes (by more
    than :data:`MIRROR_TOLERANCE` of its largest value), random noise that is not mirrored, or an initial
    map (``mesh.shear``, ``mesh.transform``) that does not commute with the reflection."""
    from ..surface.measures import area_centroid

    rem = settings.mesh.remesh
    if rem is None or not rem.mirror:
        return
    axis = np.asarray(settings.pattern_axis, dtype=float)
    reflect = np.eye(3) - 2.0 * np.outer(axis, axis)
    centre = area_centroid(mesh.points, mesh.faces)
    said = "mesh.remesh.mirror = true keeps the plane perpendicular to the pattern axis a plane of symmetry"
    matrix = settings.mesh.initial_map()
    if matrix is not None and not np.allclose(matrix @ reflect, reflect @ matrix, rtol=0.0, atol=1e-12):
        raise SceneError(f"{said}, but mesh.shear / mesh.transform deform the start asymmetrically: set mirror: false")
    for spec in scene_fields(settings):
        noise = (settings.field(spec.name) or {}).get("noise") or {}
        if noise.get("amplitude", 0) > 0 and not noise.get("symmetric", False):
            raise SceneError(
                f"{said}, but fields.{spec.name}.noise is not mirrored: set its symmetric: true or mirror: false"
            )
    image = Mesh(centre + (mesh.points - centre) @ reflect, mesh.faces)
    mirrored = initial_fields(image, settings)
    for name, v in values.items():
        scale = max(float(np.abs(v).max()), 1e-300)
        gap = float(np.abs(mirrored[name] - v).max())
        if gap > MIRROR_TOLERANCE * scale:
            raise SceneError(
                f"{said}, but the initial {name} is not symmetric about it ({gap:.2g} between a node and its mirror "
                "image): set mesh.remesh.mirror: false"
            )


def field_moves(spec, settings: RunSettings) -> bool:
    """Whether a field changes in a step (carried, diluted, diffusing or turning over)."""
    return (
        spec.carried(settings)
        or spec.kind == "density"
        or spec.diffusion(settings) > 0
        or spec.turnover(settings)[0] > 0
    )


class SceneSetup:
    """Everything a run sets up from its scene before the first solve, without Taichi: the mesh and
    its topology, the fields and patterns (field files read, python patterns imported and called)
    on the undeformed mesh, the initial shape, each moving field's transport, the mesh motion, its
    ALE reference, and the remeshing's extra. :class:`~cortex_ti.simulation.core.Simulation` is
    built on it, and ``cortex-ti check`` builds only it, so both refuse the same input.

    Its attributes are those of a simulation that the set-up checks read (``settings``, ``scene``,
    ``mesh``, ``state0``, ``fields``, ``motion_context``, ``zeta``)."""

    def __init__(self, scene, mesh: Mesh | None = None):
        from ..dynamics.motion import MESH_MOTIONS, MotionContext
        from ..dynamics.state import FieldTransport, State
        from ..surface.curved_transport import CURVED, FLAT
        from ..surface.remesh import REMESH_EXTRA_HINT, remesh_available
        from ..surface.topology import build_topology

        self.scene = scene
        self.settings = settings = scene.settings
        self.undeformed = mesh or initial_mesh(settings)
        fluid = settings.fluid
        # a mesh file's size (an icosphere's is checked by the scene rules)
        if fluid is not None and fluid.solver == "dense" and self.undeformed.n_nodes > FLUIDS_MAX_NODES:
            raise SceneError(fluids_size_message(self.undeformed.n_nodes))
        self.topology = build_topology(self.undeformed)
        # the fields are assigned on the undeformed mesh, then the mesh is deformed
        values = initial_fields(self.undeformed, settings)
        check_mirror_symmetric(self.undeformed, settings, values)
        self.mesh = initial_shape(self.undeformed, settings)
        self.state0 = State(self.mesh.points, values, self.mesh.faces)
        self.fields = scene_fields(settings)
        # a density's content on the formulation's cells: the curved cells' consistent mass on rayleigh_p2
        cells = CURVED if settings.numerics.formulation_entry.curved else FLAT
        self.transport = {
            spec.name: FieldTransport(spec.kind, spec.diffusion(settings), *spec.turnover(settings), cells=cells)
            for spec in self.fields
            if field_moves(spec, settings)
        }
        self.motion = MESH_MOTIONS[settings.mesh.motion]
        self.motion_context = MotionContext(self.mesh.faces, self.mesh.points, settings.mesh.ale_time)
        if settings.mesh.remesh is not None and not remesh_available():
            raise CortexError(f"scene '{settings.name}': mesh.remesh.min_angle is set but {REMESH_EXTRA_HINT}")

    @property
    def zeta(self) -> np.ndarray:
        """The active tension of the initial state."""
        from ..physics.fields import tension_of

        return tension_of(self.state0.fields, self.mesh.n_nodes, self.settings)
