r"""The rates of a state as one vector, and the state Jacobian projected on one degree of harmonics.

:func:`state_rates` is what :func:`cortex_ti.dynamics.spectrum.state_jacobian` linearises (the whole
state: the shape's normal speed and the moving fields' values); :func:`degree_jacobian` projects that
linearisation on the degree-l harmonics of a uniform myosin sphere, at a few dozen solves instead of
``4 N``. Both are also reachable from :mod:`cortex_ti.dynamics.spectrum`, where they were first.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from ..solve.constrained import ConstrainedSolver
from ..surface.curved_transport import cell_quadrature, curved_mass, curved_mass_rate, curved_stiffness
from ..surface.transport import DENSITY, cotan_laplacian, dual_area_rates, dual_areas

__all__ = ["DegreeJacobian", "curved_degree_basis", "degree_basis", "degree_jacobian", "state_rates"]

# ---------------------------------------------------------------------------------------------
# the whole state: the shape and the fields it carries
# ---------------------------------------------------------------------------------------------


def _moving_fields(sim) -> list[str]:
    """The fields of ``sim``'s state that change in a step (carried, diluted, diffusing, turning over)."""
    return [name for name in sim.state0.fields if name in sim.transport]


def state_rates(sim, state, dt: float = 0.0) -> np.ndarray:
    r"""The rates of a state as one vector ``(n_f + 1) N``: the normal speed of the nodes
    ``n_i . w_i`` (``w`` the mesh velocity; ``v_n`` for every motion), then for each moving field the
    rate of its *values*, the continuous-time limit of a step of the schemes
    (:meth:`State.advanced <cortex_ti.dynamics.state.State.advanced>`):

    .. math:: \dot q = r_q - D M^{-1} K q - k (q - q_*), \qquad
              \dot c = (r_m - c \dot A) / A - D M^{-1} K c - k (c - c_*),

    ``r`` the transport rate of the stored quantity (a property's value, a density's content
    ``m = c A``), ``A`` the dual areas (``M = diag A``), ``K`` the cotangent stiffness and ``dot A``
    their exact rate under the mesh velocity. A density on the curved cells (``rayleigh_p2``) has
    the consistent mass ``M``, its rate ``dM/dt`` and the curved stiffness instead
    (:mod:`cortex_ti.surface.curved_transport`):
    ``dot c = M^-1 (r_m - dM/dt c - D K c) - k (c - c_*)``."""
    ev = sim.evaluate(state, dt)
    parts = [np.einsum("nc,nc->n", ev.rate, ev.normal)]
    points, faces = ev.points, sim.mesh.faces
    area = None
    for name in _moving_fields(sim):
        tr = ev.transport[name]
        values = np.asarray(ev.state.fields[name], dtype=float)
        rate = ev.field_rates.get(name)
        rate = np.zeros_like(values) if rate is None else np.asarray(rate, dtype=float)
        if tr.curved_density:
            parts.append(_curved_density_rate(values, rate, points, faces, ev.rate, tr))
            continue
        if tr.kind == DENSITY or tr.diffusion > 0.0:
            area = dual_areas(points, faces) if area is None else area
        if tr.kind == DENSITY:
            rate = (rate - values * dual_area_rates(points, faces, ev.rate)) / area
        if tr.diffusion > 0.0:
            rate = rate - tr.diffusion * (cotan_laplacian(points, faces) @ values) / area
        if tr.turnover > 0.0:
            rate = rate - tr.turnover * (values - tr.target)
        parts.append(rate)
    return np.concatenate(parts)


def _curved_density_rate(values, rate, points, faces, mesh_velocity, tr) -> np.ndarray:
    """``M^-1 (r - dM/dt c - D K c) - k (c - c_*)`` on the curved cells (:func:`state_rates`)."""
    quad = cell_quadrature(points, faces)
    rhs = rate - curved_mass_rate(points, faces, mesh_velocity, quad) @ values
    if tr.diffusion > 0.0:
        rhs = rhs - tr.diffusion * (curved_stiffness(points, faces, quad) @ values)
    out = spla.spsolve(curved_mass(points, faces, quad).tocsc(), rhs)
    if tr.turnover > 0.0:
        out = out - tr.turnover * (values - tr.target)
    return out


# ---------------------------------------------------------------------------------------------
# one degree at a time: the state Jacobian projected on the harmonics of degree l
# ---------------------------------------------------------------------------------------------


def degree_basis(points: np.ndarray, faces: np.ndarray, l: int) -> tuple[np.ndarray, np.ndarray]:
    """``(q, w)``: an orthonormal basis ``q`` (N, 2l + 1) of the degree-l harmonics at the nodes in
    the dual-area inner product (``q / w[:, None]`` are nodal values), and ``w = sqrt(dual areas)``."""
    from ..physics.spherical import direction_angles, real_sph_harm

    w = np.sqrt(dual_areas(points, faces))
    theta, phi = direction_angles(points)
    q, _ = np.linalg.qr(np.stack([real_sph_harm(l, m, theta, phi) for m in range(-l, l + 1)], 1) * w[:, None])
    return q, w


def curved_degree_basis(points: np.ndarray, faces: np.ndarray, l: int) -> tuple[np.ndarray, np.ndarray]:
    """``(basis, left)``: the degree-l harmonics' nodal values (N, 2l + 1), orthonormal in the curved
    cells' mass inner product ``c^T M c`` (the inner product of the quadratic Galerkin density,
    :mod:`cortex_ti.surface.curved_transport`), and ``left = M basis`` (``left^T basis = I``). The
    dual areas would weigh corners and midpoints unlike the quadratic cells do: projected with
    them, the curved operators' O(h^4) eigenvalues read as O(h^2) (docs/derivations/curved_transport.md)."""
    from ..physics.spherical import direction_angles, real_sph_harm

    theta, phi = direction_angles(points)
    raw = np.stack([real_sph_harm(l, m, theta, phi) for m in range(-l, l + 1)], 1)
    mass = curved_mass(points, faces)
    chol = np.linalg.cholesky(raw.T @ (mass @ raw))
    basis = np.linalg.solve(chol, raw.T).T  # raw L^-T
    return basis, mass @ basis


@dataclass
class DegreeJacobian:
    r"""The state Jacobian of a uniform myosin cortex projected on the harmonics of degree ``l``
    (:func:`degree_jacobian`): ``matrix`` (2 (2l+1) square) in the closed form's state order
    (myosin ``c_lm``, then normal displacement ``u_lm``, m = -l..l; as
    :func:`cortex_ti.analysis.myosin_stability.mode_matrix`), at the scene's activity ``activity``
    and turnover ``turnover``; ``passive`` the myosin-myosin block without activity (diffusion and
    turnover alone: at zero activity the uniform tension drives no flow).

    At the uniform state the tension is ``zeta0`` whatever the law's slope, so only the myosin
    columns depend on the activity ``A = c0 zeta'(c0)``, and linearly; the turnover adds ``-k`` to
    the myosin-myosin block (the basis is orthonormal). :meth:`at` gives the matrix at any
    ``(A, k)`` from one projection."""

    l: int
    matrix: np.ndarray
    passive: np.ndarray
    activity: float
    turnover: float

    def at(self, activity: float | None = None, turnover: float | None = None) -> np.ndarray:
        """The projected matrix at the activity ``activity`` and turnover ``turnover`` (default: the scene's)."""
        m = self.matrix.shape[0] // 2
        G = self.matrix.copy()
        if activity is not None:
            if self.activity == 0.0:
                raise ValueError("the projection was taken at zero activity: it cannot be scaled")
            p = np.zeros((2 * m, m))
            p[:m] = self.passive
            G[:, :m] = p + (float(activity) / self.activity) * (self.matrix[:, :m] - p)
        if turnover is not None:
            G[:m, :m] -= (float(turnover) - self.turnover) * np.eye(m)
        return G

    def rates(self, activity: float | None = None, turnover: float | None = None) -> np.ndarray:
        """Eigenvalues of :meth:`at`, largest real part first."""
        ev = np.linalg.eigvals(self.at(activity, turnover))
        return ev[np.argsort(-ev.real, kind="stable")]


def degree_jacobian(sim, l: int, eps: float = 1e-6, field_name: str = "myosin") -> DegreeJacobian:
    r"""The state Jacobian of ``sim``'s initial (uniform) state projected on the degree-l harmonics:
    ``J v`` by central differences of :func:`state_rates` for the ``2 (2l + 1)`` vectors ``v``
    (myosin ``Y_lm``, normal displacement ``Y_lm``; a direct solve per evaluation), projected back
    with the dual areas (a density on the curved cells: in their mass, :func:`curved_degree_basis`). Its
    eigenvalues are a Galerkin projection of :func:`~cortex_ti.dynamics.spectrum.state_spectrum`'s, at
    ``4 (2l + 1)`` solves instead of ``4 N``; on the icosphere degrees 1 and 2 mix only with degrees
    >= 4 (resp. 5), which moves them at second order in the mixing (docs/derivations/myosin_rates_3d.md)."""
    from ..analysis.myosin_stability import activity as law_activity
    from .state import State

    state = sim.state0
    pts, faces = state.points, sim.mesh.faces
    spec = sim.settings.field(field_name)
    if spec is None:
        raise ValueError(f"the scene has no field {field_name!r}")
    curved = sim.transport[field_name].curved_density
    if curved:
        basis, left = curved_degree_basis(pts, faces, l)
    else:
        q, w = degree_basis(pts, faces, l)
        basis, left = q / w[:, None], q * w[:, None]
    n = state.n_nodes
    saved = sim.solver
    sim.solver = ConstrainedSolver("auto", reuse=False)
    try:
        normal = sim.evaluate(state).normal
        c0 = np.asarray(state.fields[field_name], dtype=float)
        cols = []
        for block in (field_name, "normal"):
            for k in range(basis.shape[1]):
                out = []
                for sign in (1.0, -1.0):
                    if block == "normal":
                        s = State(pts + sign * eps * basis[:, k, None] * normal, state.fields, state.faces)
                    else:
                        s = State(pts, {**state.fields, field_name: c0 + sign * eps * basis[:, k]}, state.faces)
                    out.append(state_rates(sim, s))
                cols.append((out[0] - out[1]) / (2 * eps))
    finally:
        sim.solver = saved
    Jv = np.stack(cols, 1)  # rows: normal speeds, then the myosin rates (state_rates' order)
    row = _moving_fields(sim).index(field_name) + 1
    G = np.vstack([left.T @ Jv[row * n : (row + 1) * n], left.T @ Jv[:n]])  # rows (c, u), columns (c, u)
    D, k = float(spec["diffusion"]), float(spec["turnover"])
    if curved:  # left^T M^-1 = basis^T
        passive = -D * (basis.T @ (curved_stiffness(pts, faces) @ basis)) - k * (left.T @ basis)
    else:
        passive = left.T @ ((-D * (cotan_laplacian(pts, faces) @ basis)) / dual_areas(pts, faces)[:, None] - k * basis)
    t = spec["tension"]
    return DegreeJacobian(int(l), G, passive, law_activity(t["law"], t["zeta0"], t["gamma"]), k)
