r"""The spectrum of the linearised normal dynamics: which normal modes of a shape grow.

The shape moves by normal advection, ``dX_i/dt = v_n,i(X) n_i(X)`` (paper Eq. 60). A normal
displacement ``s`` (one number per node) of the nodes evolves, to first order, with the
Jacobian

.. math:: J s = \frac{d v_n}{dX}[s\,n], \qquad v_{n,i} = n_i \cdot v_i .

A mode with ``Re lambda > 0`` grows whatever the time step; explicit Euler is stable for
``dt < 2 / |lambda|`` on the modes with ``lambda < 0``.

How ``J`` is built (no power iteration, no random start, so the answer is deterministic):
on a fixed shape the velocity is the solution of a linear system, the KKT conditions
``F(X, z) = 0`` of the formulation (the constrained least squares of the paper's strong form,
or the constrained stationary point of the Rayleighian, :mod:`cortex_ti.physics.galerkin`),
``z`` = velocity unknowns, pressure and multipliers. Hence

.. math:: \frac{dz}{dX} = -F_z^{-1} F_X ,

``F_z`` is the matrix the solver has just factorised and ``F_X`` is *local*: moving node j
changes the rows of the nodes whose geometry, fit or stencil sees node j, a few rings only.
``F_X`` is computed by central finite differences of ``F`` at fixed ``z``, perturbing at once
all nodes of one colour of a distance colouring (nodes far enough apart that their rings of
influence do not overlap), so its cost is a few hundred assemblies, not one solve per node;
each changed entry is attributed to the perturbed node whose ring it lies in (what falls
outside every ring is measured and reported as ``leak``). Then

* dense ``J`` (up to a few thousand nodes): one multi-right-hand-side solve with the
  factorisation, and all eigenvalues by LAPACK;
* larger meshes: ``J`` as a matrix-free operator (one back-substitution per product) for
  ARPACK (``scipy.sparse.linalg.eigs(which='LR')``).

The scalar rows of ``F`` (the pressure row of the least squares, the dense constraint rows)
are sums over nodes; the formulations return them per node so that each node's share can be
attributed like the rest.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.csgraph as csgraph
import scipy.sparse.linalg as spla

from ..solve.constrained import ConstrainedSolver
from .field_rates import (  # noqa: F401  (their first home was here)
    DegreeJacobian,
    _moving_fields,
    curved_degree_basis,
    degree_basis,
    degree_jacobian,
    state_rates,
)

__all__ = [
    "curved_degree_basis",
    "degree_basis",
    "degree_jacobian",
    "DegreeJacobian",
    "normal_spectrum",
    "state_jacobian",
    "state_rates",
    "state_spectrum",
    "StateJacobian",
    "StateSpectrum",
    "normal_jacobian",
    "Spectrum",
    "NormalJacobian",
    "distance_colouring",
    "translation_share",
]


def adjacency(ring: np.ndarray) -> sp.csr_matrix:
    """Node adjacency of a mesh from its padded one-ring array."""
    n = ring.shape[0]
    mask = ring >= 0
    rows = np.repeat(np.arange(n), mask.sum(1))
    adj = sp.csr_matrix((np.ones(rows.size), (rows, ring[mask])), shape=(n, n))
    return ((adj + adj.T) > 0).astype(np.float64).tocsr()


def distance_colouring(adj: sp.csr_matrix, separation: int) -> np.ndarray:
    """Greedy colouring such that two nodes of one colour are at least ``separation`` edges apart
    (deterministic: nodes in index order, smallest free colour)."""
    n = adj.shape[0]
    reach = sp.identity(n, format="csr")
    step = (adj + sp.identity(n)).tocsr()
    for _ in range(separation - 1):
        reach = (reach @ step).tocsr()
        reach.data[:] = 1.0
    colour = np.full(n, -1, dtype=np.int64)
    indptr, indices = reach.indptr, reach.indices
    for i in range(n):
        used = colour[indices[indptr[i] : indptr[i + 1]]]
        used = np.unique(used[used >= 0])
        c = 0
        for u in used:
            if u != c:
                break
            c += 1
        colour[i] = c
    return colour


def influence_radius(sim, stencils=None) -> int:
    """Graph radius within which moving one node changes the KKT conditions (see module doc):
    three stencil radii (the node's fit, the fits of its stencil nodes' normals, the transpose);
    ``stencils``: one body's (default the mesh's)."""
    return 3 * int(np.max((sim.stencils if stencils is None else stencils).level))


@dataclass
class NormalJacobian:
    """``J = d v_n / dX [s n]`` at one shape; build with :func:`normal_jacobian`."""

    n_nodes: int
    normal: np.ndarray  # (N, 3) at the base shape
    basis: np.ndarray  # (N, nb, 3)
    fx: sp.csr_matrix  # F_X on the unknowns, (n_unknowns, N)
    fs: np.ndarray  # F_X on the scalar rows, (q, N)
    dn: sp.csr_matrix  # (dn_i/dX [s n]) . v_i, (N, N)
    solver: ConstrainedSolver
    velocity: np.ndarray  # (N, 3) at the base shape
    leak: float  # relative size of the entries outside every ring (should be ~1e-12)
    seconds: dict = field(default_factory=dict)

    def _vn(self, x: np.ndarray) -> np.ndarray:
        nb = self.basis.shape[1]
        proj = np.einsum("nbc,nc->nb", self.basis, self.normal)  # (N, nb)
        if x.ndim == 1:
            return (x.reshape(-1, nb) * proj).sum(1)
        return (x.reshape(self.n_nodes, nb, -1) * proj[:, :, None]).sum(1)

    def matvec(self, s: np.ndarray) -> np.ndarray:
        dz = self.solver.kkt_solve(-(self.fx @ s), -(self.fs @ s))
        return self._vn(dz) + self.dn @ s

    def dense(self) -> np.ndarray:
        dz = self.solver.kkt_solve(-self.fx.toarray(), -self.fs)
        return self._vn(dz) + self.dn.toarray()

    def operator(self) -> spla.LinearOperator:
        return spla.LinearOperator((self.n_nodes, self.n_nodes), matvec=self.matvec, dtype=float)


class _Assembled:
    """The entries of ``F_X`` gathered colour by colour, each attributed to the perturbed node
    whose ring it lies in (what falls outside every ring is measured as the ``leak``)."""

    def __init__(self, n: int, nb: int):
        self.n, self.nb = n, nb
        self.x: list[tuple] = []  # (rows, owners, values) of F_X on the unknowns
        self.normal: list[tuple] = []  # the same for (dn_i/dX [s n]) . v_i
        self.fs = None
        self.leak2 = self.total2 = 0.0

    def add(self, owner: np.ndarray, dvec: np.ndarray, dsc: np.ndarray, dnv: np.ndarray) -> None:
        if self.fs is None:
            self.fs = np.zeros((dsc.shape[0], self.n))
        own = owner[np.arange(dvec.size) // self.nb]
        inside = own >= 0
        nz = inside & (dvec != 0.0)
        self.x.append((np.flatnonzero(nz), own[nz], dvec[nz]))
        self.leak2 += float(np.sum(dvec[~inside] ** 2)) + float(np.sum(dsc[:, owner < 0] ** 2))
        self.total2 += float(np.sum(dvec**2)) + float(np.sum(dsc**2))
        ins = owner >= 0
        np.add.at(self.fs, (slice(None), owner[ins]), dsc[:, ins])
        nzn = ins & (dnv != 0.0)
        self.normal.append((np.flatnonzero(nzn), owner[nzn], dnv[nzn]))

    @staticmethod
    def _matrix(parts, shape) -> sp.csr_matrix:
        rows, cols, vals = (np.concatenate(k) for k in zip(*parts, strict=False))
        return sp.csr_matrix((vals, (rows, cols)), shape=shape)

    def matrices(self) -> tuple[sp.csr_matrix, np.ndarray, sp.csr_matrix, float]:
        return (
            self._matrix(self.x, (self.n * self.nb, self.n)),
            self.fs,
            self._matrix(self.normal, (self.n, self.n)),
            float(np.sqrt(self.leak2 / max(self.total2, 1e-300))),
        )


class BodyJacobians:
    """``J`` of a mesh of several bodies (after a division): block diagonal, one
    :class:`NormalJacobian` per body (the bodies do not interact without a surrounding fluid, and
    each has its own volume constraint and rigid-motion gauge, :mod:`cortex_ti.simulation.bodies`)."""

    def __init__(self, n_nodes: int, nodes: list, blocks: list):
        self.n_nodes, self.nodes, self.blocks = n_nodes, nodes, blocks
        self.leak = max(b.leak for b in blocks)
        self.seconds = {k: sum(b.seconds[k] for b in blocks) for k in blocks[0].seconds}

    def matvec(self, s: np.ndarray) -> np.ndarray:
        out = np.zeros(self.n_nodes, dtype=np.result_type(s, float))
        for idx, b in zip(self.nodes, self.blocks, strict=True):
            out[idx] = b.matvec(np.asarray(s).reshape(-1)[idx])
        return out

    def dense(self) -> np.ndarray:
        out = np.zeros((self.n_nodes, self.n_nodes))
        for idx, b in zip(self.nodes, self.blocks, strict=True):
            out[np.ix_(idx, idx)] = b.dense()
        return out

    def operator(self) -> spla.LinearOperator:
        return spla.LinearOperator((self.n_nodes, self.n_nodes), matvec=self.matvec, dtype=float)


def normal_jacobian(
    sim, points: np.ndarray, dt: float = 0.0, eps: float | None = None, backend: str = "auto"
) -> NormalJacobian | BodyJacobians:
    """Linearise the normal dynamics of ``sim``'s formulation at the shape ``points``.

    ``dt > 0``: the velocity a step of that length is solved for (the semi-implicit tension),
    i.e. ``J`` of the step map's rate. ``eps``: finite-difference displacement (default
    1e-5 of the mean edge length; central differences, so the truncation error is ~1e-10).
    A mesh of several bodies (``sim.bodies``) is linearised body by body (:class:`BodyJacobians`).
    """
    x0 = np.asarray(points, dtype=float)
    if getattr(sim, "bodies", None) is not None:
        blocks = [
            _part_jacobian(sim, x0[b.nodes], dt, eps, backend, (b.topology, b.stencils, b.faces, b.nodes))
            for b in sim.bodies
        ]
        return BodyJacobians(x0.shape[0], [b.nodes for b in sim.bodies], blocks)
    return _part_jacobian(sim, x0, dt, eps, backend, None)


def _part_jacobian(sim, x0, dt, eps, backend, part) -> NormalJacobian:
    """:func:`normal_jacobian` of the whole mesh (``part`` None) or of one body (``part``: its
    topology, fit stencils, triangles and nodes in the whole mesh)."""
    from ..surface.geometry import compute_geometry

    t0 = time.perf_counter()
    if part is None:
        topology, stencils, faces, zeta = sim.topology, sim.stencils, None, None
        shape_geometry = sim.shape_geometry
    else:
        topology, stencils, faces, nodes = part
        zeta = np.asarray(sim.zeta)[nodes]

        def shape_geometry(pts):
            uses = sim.settings.numerics.uses_fit_residual
            return compute_geometry(pts, topology, stencils, residual=uses, operators=not sim.curved)

    solver = ConstrainedSolver(backend, reuse=False)
    geo = shape_geometry(x0)
    system = sim.system(geo, dt, zeta, None, faces)
    unknowns, pressure, _ = solver.solve(system, x0)
    multipliers = solver.last_solution
    velocity = system.velocity(unknowns)
    normal, basis = geo.normal.copy(), system.basis.copy()
    n = x0.shape[0]
    eps = 1e-5 * float(np.mean(geo.edge_length)) if eps is None else eps
    t1 = time.perf_counter()

    def parts(pts):
        """The optimality conditions at the base solution on the shape ``pts``, and its normals."""
        g = shape_geometry(pts)
        sysm = sim.system(g, dt, zeta, None, faces)
        if sysm.basis.shape != basis.shape:
            raise RuntimeError("the unknowns changed under a perturbation")
        vec, sc = sysm.kkt_parts(unknowns, pressure, multipliers)
        return vec, sc, g.normal

    adj = adjacency(topology.ring)
    radius = influence_radius(sim, stencils)
    colour = distance_colouring(adj, 2 * radius + 1)
    gathered = _Assembled(n, basis.shape[1])
    for c in range(int(colour.max()) + 1):
        src = np.flatnonzero(colour == c)
        dist, _, owner = csgraph.dijkstra(
            adj,
            directed=False,
            indices=src,
            unweighted=True,
            limit=radius + 0.5,
            min_only=True,
            return_predecessors=True,
        )
        d = np.zeros(n)
        d[src] = eps
        (vp, sp_, np_), (vm, sm_, nm_) = parts(x0 + d[:, None] * normal), parts(x0 - d[:, None] * normal)
        gathered.add(
            np.where(np.isfinite(dist), owner, -1),
            (vp - vm) / (2 * eps),
            (sp_ - sm_) / (2 * eps),
            np.einsum("nc,nc->n", (np_ - nm_) / (2 * eps), velocity),
        )
    fx, fs, dn, leak = gathered.matrices()
    t2 = time.perf_counter()
    return NormalJacobian(
        n_nodes=n,
        normal=normal,
        basis=basis,
        fx=fx,
        fs=fs,
        dn=dn,
        solver=solver,
        velocity=velocity,
        leak=leak,
        seconds={"solve": t1 - t0, "linearise": t2 - t1, "colours": int(colour.max()) + 1},
    )


@dataclass
class Spectrum:
    """Eigenvalues of the linearised normal dynamics, largest real part first."""

    eigenvalues: np.ndarray
    n_nodes: int
    method: str
    leak: float = 0.0
    seconds: dict = field(default_factory=dict)
    modes: np.ndarray | None = None

    @property
    def largest_real(self) -> float:
        return float(self.eigenvalues.real[0])

    def count_above(self, threshold: float = 1.0) -> int:
        return int(np.sum(self.eigenvalues.real > threshold))

    @property
    def stiffest(self) -> complex:
        """The eigenvalue of largest magnitude (what explicit Euler must resolve)."""
        return complex(self.eigenvalues[np.argmax(np.abs(self.eigenvalues))])


def _deterministic_start(n: int) -> np.ndarray:
    v = np.cos(0.7 * np.arange(n)) + 0.5 * np.sin(1.3 * np.arange(n) + 0.2)
    return v / np.linalg.norm(v)


def normal_spectrum(
    sim,
    points: np.ndarray | None = None,
    dt: float = 0.0,
    k: int = 12,
    dense: bool | None = None,
    modes: bool = False,
    tol: float = 1e-8,
    ncv: int | None = None,
    maxiter: int | None = None,
    which: str = "LR",
    jacobian: NormalJacobian | BodyJacobians | None = None,
) -> Spectrum:
    """Eigenvalues of ``J`` (largest real part first): all of them with ``dense`` (default up to
    3000 nodes), else ``k`` of them by ARPACK with a deterministic start vector: those of
    largest real part (``which='LR'``, the growing modes) or of largest magnitude
    (``which='LM'``, the stiffest mode, which sets the explicit step limit; ``'SR'``, the most
    negative real part). ``jacobian``: one :func:`normal_jacobian` already built at ``points``, ``dt``."""
    x = sim.mesh.points if points is None else points
    jac = normal_jacobian(sim, x, dt) if jacobian is None else jacobian
    n = jac.n_nodes
    dense = n <= 3000 if dense is None else dense
    t0 = time.perf_counter()
    vecs = None
    if dense:
        jd = jac.dense()
        if modes:
            w, vecs = np.linalg.eig(jd)
        else:
            w = np.linalg.eigvals(jd)
        method = "dense"
    else:
        op = jac.operator()
        res = spla.eigs(
            op,
            k=k,
            which=which,
            v0=_deterministic_start(n),
            tol=tol,
            ncv=ncv or max(2 * k + 1, 40),
            maxiter=maxiter or 20 * n,
            return_eigenvectors=modes,
        )
        w, vecs = res if modes else (res, None)
        method = f"arpack {which}"
    order = np.argsort(-w.real)
    seconds = dict(jac.seconds)
    seconds["eig"] = time.perf_counter() - t0
    return Spectrum(
        eigenvalues=w[order],
        n_nodes=n,
        method=method,
        leak=jac.leak,
        seconds=seconds,
        modes=None if vecs is None else vecs[:, order],
    )


def translation_share(s: np.ndarray, normal: np.ndarray, area: np.ndarray) -> tuple[float, np.ndarray]:
    """How much of a normal displacement ``s`` (one value per node; e.g. a mode of
    :func:`normal_spectrum`) is the normal part ``U . n`` of a rigid translation ``U``: the share
    of its area-weighted squared norm in that span (1: a pure translation, as the nodes see it),
    and the unit direction of ``U``."""
    w = np.sqrt(area)
    u, *_ = np.linalg.lstsq(w[:, None] * normal, w * s, rcond=None)
    rest = w * s - (w[:, None] * normal) @ u
    return 1.0 - float(rest @ rest) / float(np.sum(area * s * s)), u / np.linalg.norm(u)


@dataclass
class StateJacobian:
    """``d(rates)/d(state)`` of :func:`state_rates`, dense, in blocks of N: ``names[0] = 'normal'``
    (normal displacements of the nodes), then the moving fields' values."""

    matrix: np.ndarray
    names: tuple
    n_nodes: int
    normal: np.ndarray  # (N, 3) at the base state
    seconds: dict = field(default_factory=dict)

    def block(self, row: str, col: str) -> np.ndarray:
        """The (N, N) block ``d rate[row] / d col``."""
        i, j, n = self.names.index(row), self.names.index(col), self.n_nodes
        return self.matrix[i * n : (i + 1) * n, j * n : (j + 1) * n]


def state_jacobian(sim, state=None, dt: float = 0.0, eps: float | None = None, backend: str = "auto") -> StateJacobian:
    r"""Linearise the whole state's dynamics of ``sim`` (positions and the fields it carries) at
    ``state`` (default: the initial state; an (N, 3) array: the initial fields on that shape).

    The state is perturbed one node and one component at a time, by a normal displacement
    ``eps`` of the node or by ``eps`` times the field's scale in its value, and the rates of
    :func:`state_rates` are differenced centrally (truncation ~eps^2; each evaluation is a direct
    solve, no reuse of an earlier factorisation, so the rounding is ~1e-14 / eps). A tangential
    displacement of a node needs no column of its own: under the normal motion it is a relabelling,
    and a carried field's perturbation already covers the slide of its values along the surface.
    Cost: ``2 (n_f + 1) N`` solves (a minute at 642 nodes with one field)."""
    from .state import State

    if state is None:
        state = sim.state0
    elif not isinstance(state, State):
        state = sim.state_at(np.asarray(state, dtype=float))
    t0 = time.perf_counter()
    saved = sim.solver
    sim.solver = ConstrainedSolver(backend, reuse=False)
    try:
        ev = sim.evaluate(state, dt)
        normal = ev.normal.copy()
        n = state.n_nodes
        eps = 1e-5 * float(np.mean(ev.edge_length)) if eps is None else eps
        names = ("normal", *_moving_fields(sim))
        jac = np.zeros((len(names) * n, len(names) * n))
        for b, name in enumerate(names):
            if name == "normal":
                scale = eps
            else:
                scale = eps * max(1.0, float(np.max(np.abs(state.fields[name]))))
            for j in range(n):

                def shifted(sign, name=name, j=j, scale=scale):
                    if name == "normal":
                        pts = state.points.copy()
                        pts[j] += sign * scale * normal[j]
                        return State(pts, state.fields, state.faces)
                    fields = dict(state.fields)
                    vals = np.array(fields[name], dtype=float)
                    vals[j] += sign * scale
                    fields[name] = vals
                    return State(state.points, fields, state.faces)

                plus, minus = state_rates(sim, shifted(1.0), dt), state_rates(sim, shifted(-1.0), dt)
                jac[:, b * n + j] = (plus - minus) / (2.0 * scale)
    finally:
        sim.solver = saved
    return StateJacobian(jac, names, n, normal, {"linearise": time.perf_counter() - t0})


@dataclass
class StateSpectrum(Spectrum):
    """Eigenvalues of the whole state's linearised dynamics; ``names`` the blocks of N of a mode."""

    names: tuple = ("normal",)

    def share(self, k: int, name: str) -> float:
        """The part of mode ``k``'s squared norm in block ``name`` (needs ``modes``)."""
        v = self.modes[:, k]
        n, i = self.n_nodes, self.names.index(name)
        part = v[i * n : (i + 1) * n]
        return float(np.vdot(part, part).real / np.vdot(v, v).real)


def state_spectrum(sim, state=None, dt: float = 0.0, modes: bool = False, jacobian: StateJacobian | None = None):
    """All eigenvalues (largest real part first) of :func:`state_jacobian`: the growing modes of
    the shape and of the fields it carries together; with ``modes`` their eigenvectors
    (blocks of N: the normal displacement, then each field)."""
    jac = jacobian or state_jacobian(sim, state, dt)
    t0 = time.perf_counter()
    if modes:
        w, vecs = np.linalg.eig(jac.matrix)
    else:
        w, vecs = np.linalg.eigvals(jac.matrix), None
    order = np.argsort(-w.real)
    seconds = dict(jac.seconds, eig=time.perf_counter() - t0)
    return StateSpectrum(
        eigenvalues=w[order],
        n_nodes=jac.n_nodes,
        method="dense, whole state",
        seconds=seconds,
        modes=None if vecs is None else vecs[:, order],
        names=jac.names,
    )
