"""Shared fixtures of the numerical-core tests (test_geometry, test_solver, test_cli).

* ``taichi_runtime``: Taichi initialised once per session (per pytest-xdist worker; ``-n auto``
  in pyproject.toml, at most :data:`MAX_WORKERS` workers) with two CPU threads (kernels are
  compiled on first use, or loaded from Taichi's offline cache). Two threads in each of two
  workers on two cores measured faster (13 min 23 s) than one each (14 min 29 s, with
  ``--dist worksteal``).
* ``lab``: cached meshes, topologies, geometries and solves, so that the many
  assertions on one solution cost one solve.

Meshes used throughout:

``lab.icosphere(N, R)``
    the regular icosphere of :func:`cortex_ti.surface.mesh.icosphere`;
``lab.perturbed(N, seed, frac, on_sphere)``
    the same connectivity, every node moved by ``frac * e * (u0 n + u1 t1 + u2 t2)``
    with ``u ~ U(-1, 1)`` (fixed seed), ``e`` the mean edge length and ``(t1, t2, n)``
    an orthonormal frame at the node: an irregular mesh with obtuse triangles. With
    ``on_sphere=True`` the nodes are put back on the sphere afterwards, so the
    surface is still exactly the sphere and only the node spacing is irregular.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

# One BLAS (and OpenMP) thread per process, set before NumPy loads its OpenBLAS: each worker has a
# core of its own, and OpenBLAS's threads on an oversubscribed machine spin on the small dense
# matrices of the axisymmetric model (a (96, 48) product 0.085 ms on one thread, 8 ms on two when
# the cores were busy: the axisymmetric cut's test 16 -> 5.6 CPU s). Inherited by the commands the
# tests run. A value set outside the tests is kept.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

from cortex_ti import runtime  # noqa: E402

#: At most this many pytest-xdist workers for ``-n auto``: more would mostly add memory (each
#: worker holds Taichi and its meshes) and start-up, not speed, to a suite of ~1000 tests.
MAX_WORKERS = 4


def pytest_xdist_auto_num_workers(config):
    """``-n auto``: one worker per core, at most :data:`MAX_WORKERS`."""
    return max(1, min(MAX_WORKERS, os.cpu_count() or 1))


#: Files whose tests take longest, with their measured seconds (one worker, idle 2-core machine,
#: ``--durations=0`` of the whole suite, 2026-12-07): scheduled first, longest first, so that none
#: starts last and leaves one worker running alone at the end (the SLURM test mostly waits on the
#: cluster: started first, its waiting overlaps the other worker's work). Files not listed count by
#: their tests (a slow one ~3 s, another ~0.1 s).
LONG_FILES = {
    "tests/studies/test_slurm.py": 1000,  # 102 s, mostly waiting: first, so the waiting overlaps work
    "tests/repository/test_benchmarks.py": 198,
    "tests/repository/test_doc_examples.py": 133,
    "tests/studies/test_workflow.py": 100,
    "tests/repository/test_examples.py": 94,
    "tests/axisymmetric/test_axisymmetric_transport.py": 53,
    "tests/dynamics/test_implicit_tension.py": 35,  # 48 before shear_075 ran its scene's bdf2
    "tests/dynamics/test_state_spectrum.py": 25,  # 70 before the degree projection
}


def pytest_collection_modifyitems(session, config, items):
    """The files in order of their expected time, longest first (:data:`LONG_FILES`), each file's
    own order kept: the workers take files (``--dist loadfile``) in this order."""
    root = config.rootpath
    weight: dict = {}
    for item in items:
        slow = item.get_closest_marker("slow") or item.get_closest_marker("slurm")
        weight[item.path] = weight.get(item.path, 0.0) + (3.0 if slow else 0.1)
    for path in weight:
        rel = path.relative_to(root).as_posix() if path.is_relative_to(root) else str(path)
        weight[path] = LONG_FILES.get(rel, weight[path])
    items.sort(key=lambda item: -weight[item.path])


@pytest.fixture(scope="session")
def taichi_runtime():
    """Taichi on the CPU with two threads, once per session (per worker)."""
    return runtime.init(threads=2)


def mean_edge_length(points: np.ndarray, faces: np.ndarray) -> float:
    e = np.concatenate([points[faces[:, k]] - points[faces[:, (k + 1) % 3]] for k in range(3)])
    return float(np.linalg.norm(e, axis=1).mean())


def tangent_basis(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal tangent vectors (t1, t2) with t1 x t2 = n for unit normals ``(N, 3)``."""
    ref = np.array([0.3, 0.5, 0.8]) / np.linalg.norm([0.3, 0.5, 0.8])
    t1 = np.cross(normals, ref)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(normals, t1)
    return t1, t2


@dataclass
class Solved:
    """One solve of the force balance and everything needed to check it."""

    velocity: np.ndarray
    pressure: float
    info: object
    geometry: object
    system: object
    x: np.ndarray


class Lab:
    """Session cache of meshes, topologies, geometries and solutions."""

    def __init__(self):
        self._cache: dict = {}

    def memo(self, key, make):
        if key not in self._cache:
            self._cache[key] = make()
        return self._cache[key]

    # ---- meshes ---------------------------------------------------------------------------
    def icosphere(self, n: int, radius: float = 1.0):
        from cortex_ti.surface.mesh import icosphere

        return self.memo(("ico", n, radius), lambda: icosphere(n, radius))

    def perturbed(self, n: int, seed: int = 0, frac: float = 0.2, on_sphere: bool = False):
        def make():
            from cortex_ti.surface.validation import validate_mesh

            base = self.icosphere(n)
            p = base.points.copy()
            e = mean_edge_length(p, base.faces)
            normal = p / np.linalg.norm(p, axis=1, keepdims=True)
            t1, t2 = tangent_basis(normal)
            u = np.random.default_rng(seed).uniform(-1.0, 1.0, (len(p), 3))
            p = p + frac * e * (u[:, :1] * normal + u[:, 1:2] * t1 + u[:, 2:3] * t2)
            if on_sphere:
                p /= np.linalg.norm(p, axis=1, keepdims=True)
            mesh = validate_mesh(p, base.faces)
            assert mesh.n_nodes == n and np.array_equal(mesh.faces, base.faces)
            return mesh

        return self.memo(("pert", n, seed, frac, on_sphere), make)

    # ---- derived --------------------------------------------------------------------------
    def topology(self, mesh):
        from cortex_ti.surface.topology import build_topology

        return self.memo(("topo", id(mesh)), lambda: build_topology(mesh))

    def geometry(self, mesh, scheme: str, points: np.ndarray | None = None, topo=None):
        """Geometry of ``mesh`` (or of ``points`` on its connectivity); cached for the mesh itself."""
        from cortex_ti.surface.fits import StencilChooser
        from cortex_ti.surface.geometry import compute_geometry

        topo = topo if topo is not None else self.topology(mesh)

        def make():
            return compute_geometry(mesh.points if points is None else points, topo, StencilChooser(topo, scheme))

        if points is None and topo is self.topology(mesh):
            return self.memo(("geom", id(mesh), scheme), make)
        return make()

    def solve(self, geometry, physics, zeta, backend: str = "superlu") -> Solved:
        from cortex_ti.physics.assembly import assemble
        from cortex_ti.solve.constrained import ConstrainedSolver

        system = assemble(geometry, physics, zeta)
        x, pressure, info = ConstrainedSolver(backend).solve(system, geometry.points)
        return Solved(system.velocity(x), pressure, info, geometry, system, x)

    def cached_solve(self, key, make_geometry, physics, zeta) -> Solved:
        return self.memo(("solve",) + tuple(key), lambda: self.solve(make_geometry(), physics, zeta))


@pytest.fixture(scope="session")
def lab(taichi_runtime) -> Lab:
    return Lab()
