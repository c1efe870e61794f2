r"""The force balance as the stationary point of the Rayleighian on curved quadratic cells
(formulation ``rayleigh_p2``): symmetric positive semidefinite by construction, third order.

The functional is ``rayleigh_p1``'s (:mod:`cortex_ti.physics.galerkin`),

.. math::
    \mathcal R[v] = \int \big[\eta_s\,|\tilde u|^2 + \tfrac{\eta_b}{2}(\mathrm{tr}\,u)^2\big]\,dA
      + \int \zeta\,\mathrm{tr}\,u\,dA - P\,\dot V[v] + \mathcal R_b[v],

discretised in another space: the surface is made of curved six-node cells
(:mod:`cortex_ti.surface.curved`: a mesh in the 1-to-4 split layout, every four flat triangles one
quadratic cell) and the velocity is quadratic on them, three Cartesian unknowns per node. Every
integral is taken with a Gauss rule on the curved cells.

**Why the normal velocity goes through the smooth normal.** The rate of strain of a surface
velocity ``v = v_t + v_n n`` is ``u = sym(P grad v_t P) + v_n C`` (conventions: ``C`` the
curvature tensor): the normal speed enters *without a derivative*, multiplied by the curvature.
On a sphere at t = 0 the bulk viscosity makes ``tr u`` follow the tension, so ``v_n`` is read off
``tr u / C``, and any error of the discrete curvature that ``u`` feels goes straight into
``v_n``, with no gain from Galerkin orthogonality. Interpolating the Cartesian velocity on the
cells makes that curvature the derivative of the interpolated normal field, one order worse
than the field itself: quadratic cells then converge at second order only (measured: 2.0e-2
and 5.2e-3 at 2562 and 10242 nodes on ``furrow_p8_a1``, worse than ``rayleigh_p1``'s 1.5e-2 and
3.9e-3; an established library's order-2 elements show the same, docs/validation/curved.md).
Here each node's velocity is split along its smooth normal ``n_i`` (the fitted surface's), and
the velocity field is

.. math:: v(x) = \sum_i N_i(x)\,P_i v_i + \Big(\sum_i N_i(x)\,n_i\cdot v_i\Big)\,n(x),

``P_i = I - n_i n_i^T`` and ``n(x)``, ``C(x)`` the smooth normal and curvature interpolated from
the nodes. Its rate of strain is ``u = sym(P sum_i (P_i v_i) grad N_i^T P) + v_n C``, with the
curvature that of the fitted surface instead of a derivative of the discretisation: the
t = 0 ring flows converge at third order (validation page). Whatever ``n`` and ``C``, ``u`` is
linear in the unknowns and the dissipation a sum of squares: the matrix is symmetric positive
semidefinite, so no mode can grow spuriously, as with ``rayleigh_p1``.

The terms of :mod:`cortex_ti.physics.terms` declare what they add in their ``rayleigh_p2``
method (:class:`~cortex_ti.physics.terms.P2Context`); this module integrates it: the viscosities
as ``int [2 eta_s u:u + (eta_b - eta_s) (tr u)^2] / 2 dA``, the tension's power ``int zeta tr u dA``
(``zeta`` interpolated quadratically from the cells' nodes), the normal forms
``1/2 int [B : grad v_n grad v_n + beta_0 v_n^2] dA`` (bending viscosity, the semi-implicit
tension; ``B`` clipped to its positive semidefinite part at each quadrature point), and the
constraint rows. The solution is the velocity at every node of the mesh.

**The corner-midpoint mode: the midpoints fitted through midpoints.** Moving the cells' corners
against their edge midpoints (a mesh-scale scallop, corners in and midpoints out) is hardly restored:
a corner's shape function integrates to about zero over its cells, so neither the pressure nor the
tension's normal force at a corner sees it (its rate stays ~60-80 / t_a from 642 to 10242 nodes
where a mesh-scale mode's should grow like h^-2). With the fits on all the nodes of the two-ring, the
same offset bends the midpoints' fitted surface by ~eps / h^2, and with it the smooth flow: the O(h^3)
error of a solve excites the mode, whose pull is an O(h^2) error of the smooth normal speed, which
the furrow's slow late phase integrates into its shape (docs/validation/curved.md, "The late-furrow
drift"). So with the quartic fit each midpoint's surface is fitted through midpoints only, the 16
nearest of its three-ring (:func:`cortex_ti.surface.curved.midpoint_mask`, ``StencilChooser(...,
apart=...)``; the corners keep their two-ring): a corner offset no longer moves it, the mode stays
weakly restored through the corners' own fits but pulls on little, and the late furrow converges at
third order. The price, a wider stencil for three quarters of the nodes, shows at 642 nodes only
(the t = 0 ring flows 1.1-1.5x less accurate there, the same at 2562 and 10242).

**The active force** (``numerics.active_force``): ``balanced``, the power ``int zeta tr u dA`` less each
node's own tangential part (:mod:`cortex_ti.physics.terms.active`), or ``gradient``, minus the exact
gradient of ``int zeta dA`` over the curved cells through the nodes
(:meth:`~cortex_ti.surface.curved.CurvedSurface.energy_gradient`, added here to the force).

**The rigid motions.** A rigid motion is not strain-free in this space (the normal speed goes along
the fitted normals, which a translation does not follow: a strain of O(h^3)). Under the mean-velocity
gauge that does not matter (the gauge's rows fix the rigid part), but under the centroid gauge the
flow would differ from that gauge's by more than a rigid motion. So the matrix becomes ``K (I - R Pi)``
there, ``R`` (3M, 6) the rigid motions at the nodes and ``Pi = (G R)^-1 G`` with ``G`` the mean-velocity
gauge's rows (:func:`rigid_projection`): ``K (I - R Pi) R = 0`` exactly, and since its difference from
the symmetric ``(I - R Pi)^T K (I - R Pi)`` (the dissipation of the non-rigid part) lies along the rows
``G`` along which the multipliers push, both give the same velocity: the mean-velocity gauge's plus
a rigid motion. The rank-6 part goes to the solver as ``EnergySystem.low_rank``; the semi-implicit
tension's centre is the non-rigid part of the last rate, in both gauges.
"""

from __future__ import annotations

import numpy as np

from ..solve.system import EnergySystem
from ..surface.curved import curved_surface
from ..surface.geometry import Geometry
from .galerkin import block_pattern, energy_system
from .model import Physics
from .terms import P2Context, terms_for
from .terms.base import check_inputs, velocity_basis

__all__ = ["assemble_p2", "cell_blocks", "rigid_projection"]


def cell_blocks(ctx: P2Context) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per curved cell the (18, 18) second derivative of the dissipation, the (18,) force and the (18,)
    rate of the area (the strains at the quadrature points from one Taichi kernel,
    :mod:`.galerkin_p2_kernel`, contracted over the points by one batched matrix product; the normal
    forms summed, then clipped to their positive semidefinite part at each quadrature point; a centred
    form's force from its own clipped tensor, as in ``rayleigh_p1``)."""
    from .galerkin_p2_kernel import cell_strain_kernel, centred_force_kernel, finish_blocks_kernel  # starts Taichi

    surf = ctx.surface
    ncell, nq = surf.weight.shape
    cells = surf.cells.astype(np.int32)
    zeta_q = np.zeros((ncell, nq)) if ctx.tension is None else surf.at_quadrature(ctx.tension)
    form = np.zeros((ncell, nq, 3, 3))
    beta0 = np.zeros((ncell, nq))
    for b, b0, _ in ctx.normal_forms:
        form = form + b
        if b0 is not None:
            beta0 = beta0 + b0
    force = np.empty((ncell, 18))
    area_rate = np.empty((ncell, 18))
    pair = np.empty((ncell, 6, 6))
    blocks = np.empty((ncell, 18, 18))
    zeta_q, form = np.ascontiguousarray(zeta_q), np.ascontiguousarray(form)
    common = (surf.weight, surf.grads, surf.qnormal)
    # in chunks of cells whose strains stay in the cache (at 10242 nodes all of them would be 2 x 36 MB)
    for lo in range(0, ncell, CHUNK):
        hi = min(lo + CHUNK, ncell)
        strain = _scratch("strain", (CHUNK, 18, nq, 7))[: hi - lo]
        weighted = _scratch("weighted", (CHUNK, 18, nq, 7))[: hi - lo]
        part = slice(lo, hi)
        cell_strain_kernel(
            *(a[part] for a in common),
            surf.qcurvature[part],
            surf.normal,
            cells[part],
            surf.shape,
            float(ctx.shear),
            float(ctx.bulk),
            zeta_q[part],
            form[part],
            beta0[part],
            strain,
            weighted,
            pair[part],
            force[part],
            area_rate[part],
        )
        # sum_q w [2 eta_s U_ic : U_jd + (eta_b - eta_s) tr U_ic tr U_jd]
        np.matmul(
            strain.reshape(hi - lo, 18, -1), weighted.reshape(hi - lo, 18, -1).transpose(0, 2, 1), out=blocks[part]
        )
    # made exactly symmetric, plus sum_q w (g_i . B g_j + beta_0 N_i N_j) n_ic n_jd
    finish_blocks_kernel(blocks, pair, surf.normal, cells)
    for b, b0, centre in ctx.normal_forms:
        if centre is None:
            continue
        part = np.empty((ncell, 18))
        b0 = np.zeros((ncell, nq)) if b0 is None else np.ascontiguousarray(b0, dtype=float)
        centred_force_kernel(
            *common, surf.normal, cells, surf.shape, np.ascontiguousarray(b), b0, np.ascontiguousarray(centre), part
        )
        force += part
    return blocks, force, area_rate


_SCRATCH: dict = {}
#: cells per call of the strain kernel: 2 x 3.6 MB of strains with 7 quadrature points
CHUNK = 512


def _scratch(name: str, shape: tuple) -> np.ndarray:
    """A work array of the strain kernel, kept between calls of the same shape (a fresh one per chunk
    would fault its pages in again)."""
    buf = _SCRATCH.get(name)
    if buf is None or buf.shape != shape:
        buf = _SCRATCH[name] = np.empty(shape)
    return buf


def assemble_p2(
    geometry: Geometry,
    physics: Physics,
    zeta: np.ndarray,
    faces: np.ndarray,
    implicit_dt: float = 0.0,
    implicit_rate: np.ndarray | None = None,
    active_force: str = "balanced",
    pressure_weights: str = "petrov",
    implicit_weight: float = 1.0,
) -> EnergySystem:
    """The Rayleighian system of the effects in ``physics`` on the curved cells of ``geometry``
    (module docstring); ``implicit_dt > 0``: the semi-implicit tension of a step of that length,
    centred on the nodes' rate ``implicit_rate`` (N, 3) when given; ``pressure_weights``: ``petrov``, the
    pressure pushing along the smooth normal speed's rows, or ``exact``, along the exact rate of the
    curved cells' volume it holds (:mod:`cortex_ti.physics.terms.constraints`); ``implicit_weight`` the
    factor on the semi-implicit tension's drag (:mod:`cortex_ti.physics.terms.implicit_tension`). Its
    unknowns are the velocities of all the mesh's nodes (the cells' corners and midpoints)."""
    zeta = check_inputs(physics, zeta, implicit_dt)
    faces = np.asarray(faces)
    surf = curved_surface(geometry, faces)
    rigid = rigid_projection(surf) if physics.normal_balance else None
    if rigid is not None and implicit_rate is not None:
        # the semi-implicit tension is centred on the rate's non-rigid part (in either gauge)
        r = np.asarray(implicit_rate, dtype=float).ravel()
        implicit_rate = (r - rigid[0] @ (rigid[1] @ r)).reshape(-1, 3)
    ctx = P2Context(
        geometry,
        physics,
        zeta,
        implicit_dt=float(implicit_dt),
        implicit_rate=implicit_rate,
        surface=surf,
        active_force=active_force,
        pressure_weights=pressure_weights,
        implicit_weight=float(implicit_weight),
    )
    terms = terms_for(ctx)
    for term in terms:
        term.rayleigh_p2(ctx)
    m = surf.n_nodes
    blocks, force, area_rate = cell_blocks(ctx)
    pattern = block_pattern(surf.cells, m)
    kmat = pattern.matrix(blocks)
    f = np.bincount(pattern.dof.ravel(), weights=force.ravel(), minlength=3 * m)
    for smat, centre in ctx.matrices:
        kmat = (kmat + smat).tocsr()
        if centre is not None:
            f = f + smat @ np.asarray(centre, dtype=float).ravel()
    if ctx.balanced_tension is not None:
        # remove the tangential part of each node's own tension times the area's rate there
        rate = np.bincount(pattern.dof.ravel(), weights=area_rate.ravel(), minlength=3 * m).reshape(m, 3)
        nrm = surf.normal
        tangential = rate - np.einsum("nc,nc->n", rate, nrm)[:, None] * nrm
        f = f + (ctx.balanced_tension[:, None] * tangential).ravel()
    if ctx.energy_tension is not None:
        f = f - surf.energy_gradient(ctx.energy_tension).ravel()
    if ctx.node_force is not None:
        f = f + ctx.node_force.ravel()
    # Cartesian unknowns, or the tangent frames of the fitted normals (the curved cells' nodes are the
    # geometry's, and so are their normals) when v_n is held at 0
    system = energy_system(kmat, f, ctx.constraints, velocity_basis(geometry, physics), terms)
    if rigid is not None and physics.centroid_gauge:
        # the dissipation of the non-rigid part v - R Pi v (module docstring): K + U V^T, U = -K R, V = Pi^T
        system.low_rank = (-(kmat @ rigid[0]), rigid[1].T.copy())
    return system


def rigid_projection(surf) -> tuple[np.ndarray, np.ndarray]:
    """``(R, Pi)``: the six rigid motions at the nodes (3M, 6), translations ``e_k`` and rotations
    ``e_k x (x - x_c)`` about the area centroid, and the projection ``Pi = (G R)^-1 G`` (6, 3M) with
    ``G`` the rows of zero total velocity and angular momentum on the curved cells: ``Pi R = I``,
    ``Pi v = 0`` for every velocity of the mean-velocity gauge."""
    rows = surf.rigid_motion_rows(False).reshape(6, -1)
    mass = surf.node_integral()
    centre = surf.node_integral(surf.qpoint).sum(0) / mass.sum()
    x = surf.nodes - centre
    eye = np.eye(3)
    rmodes = np.stack([np.tile(eye[k], (len(x), 1)) for k in range(3)] + [np.cross(eye[k], x) for k in range(3)])
    rmat = rmodes.reshape(6, -1).T
    return rmat, np.linalg.solve(rows @ rmat, rows)
