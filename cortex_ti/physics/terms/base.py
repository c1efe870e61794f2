r"""How a physical term contributes to each discretisation of the force balance.

A term is one class registered with :func:`register`. Its ``effect`` names the scene effect
that switches it on (``None``: always on), one of :data:`cortex_ti.physics.model.EFFECTS`; its
``applies(ctx)`` says whether it has anything to add on this solve. What it adds to each
formulation of :data:`cortex_ti.physics.formulations.FORMULATIONS` is a method named after
that formulation, taking that formulation's context:

``paper(ctx: PaperContext)``
    The paper's strong form (:mod:`cortex_ti.physics.assembly`). The unknowns are the nodal
    velocities; at node ``i`` the force balance has ``R`` rows: the two tangential components
    (along ``e_xi``, ``e_eta``) and, when the normal balance is solved, the normal one. Every
    row is linear in the fitted velocity derivatives ``V_k = [A_v, B_v, C_v, D_v, E_v]``
    (3-vectors, paper Eq. 18), in the derivatives of the normal speed ``v_n`` and in the
    node's own velocity, so the term only writes *weights*:

    ``W[i, r, k]``   3-vector multiplying ``V_k`` in row ``r``
    ``W0[i, r]``     3-vector multiplying ``v_i``
    ``Wn[i, r, k]``  scalar multiplying the k-th fitted derivative of ``v_n = n . v``
    ``Wn0[i, r]``    scalar multiplying ``v_n`` at node ``i``
    ``rhs[i, r]``    the velocity-independent right-hand side

    and the assembly turns them into matrix entries through the fit operator once for all
    terms; a pressure (``ctx.pressure``) and dense constraint rows (``ctx.constraints``) are
    collected apart.

``rayleigh_p1(ctx: P1Context)``
    The stationary point of the discrete Rayleighian on the flat triangles
    (:mod:`cortex_ti.physics.galerkin`), piecewise-linear velocities. The term adds to the
    dissipation (a positive semidefinite quadratic form keeps the formulation stable), to the
    power of the forces or to the constraints, again as coefficients the assembly turns into
    one matrix: the in-plane viscosities ``shear``, ``bulk`` of ``A_T [eta_s |U~_T|^2 +
    eta_b/2 (tr U_T)^2]``, a tensor ``B^cd`` (:meth:`P1Context.add_normal_form`) of
    ``1/2 int B^cd d_c v_n d_d v_n dA`` (clipped to its positive semidefinite part per
    triangle), a nodal drag ``normal_drag`` of ``1/2 sum_k A_k beta_k v_n,k^2``, raw per-triangle
    9x9 blocks (:meth:`P1Context.add_blocks`), a dense (3N, 3N) block (:meth:`P1Context.add_dense`,
    the fluids'), per-triangle forces
    (:meth:`P1Context.add_triangle_force`, the power ``f . v``) and constraint rows with their
    multipliers.

``rayleigh_p2(ctx: P2Context)``
    The same Rayleighian on curved six-node cells with quadratic velocities
    (:mod:`cortex_ti.physics.galerkin_p2`): the term declares, the formulation integrates. It adds
    the viscosities ``shear``, ``bulk``, a nodal tension whose power ``int zeta tr u dA`` is
    added (:meth:`P2Context.add_tension`), normal forms ``1/2 int [B : grad v_n grad v_n + beta_0
    v_n^2] dA`` given at the quadrature points (:meth:`P2Context.add_normal_form`, optionally
    centred on a rate) and constraint rows on the cells' nodes.

A term that exists for one formulation only sets the other's method to ``None``; one whose
contribution is the same in every formulation (the gauge rows) binds one function to both
names. A term that says nothing about a formulation is refused when that formulation
assembles (:func:`terms_for`). Adding a formulation adds a method name here.

Nothing here imports Taichi: the registry is read by light layers; the kernels of a term load
when it is applied.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ...errors import SolverError
from ..model import Physics

if TYPE_CHECKING:  # the geometry module starts Taichi; only its type is needed here
    from ...surface.geometry import Geometry

__all__ = [
    "ROW_ETA",
    "ROW_NORMAL",
    "ROW_XI",
    "TERMS",
    "Constraint",
    "Context",
    "P1Context",
    "P2Context",
    "PaperContext",
    "Term",
    "check_inputs",
    "effects_without_terms",
    "register",
    "terms_for",
    "velocity_basis",
]

#: Row indices within a node (formulation ``paper``)
ROW_XI, ROW_ETA, ROW_NORMAL = 0, 1, 2


@dataclass
class Constraint:
    """Dense constraint rows ``sum_i c[j, i] . v_i = 0`` (one Lagrange multiplier each).

    ``force_rows`` (``rayleigh_p1`` only): the rows along which the multipliers push, if not
    ``rows`` themselves (a Petrov-Galerkin constraint). ``pressure``: its multiplier is the
    pressure difference ``P``."""

    name: str
    rows: np.ndarray  # (m, N, 3)
    force_rows: np.ndarray | None = None
    pressure: bool = False


def constraint_names(constraints: list[Constraint]) -> list[str]:
    """One name per row: ``name[k]`` for a constraint of several rows, ``name`` for one row."""
    return [f"{c.name}[{k}]" if c.rows.shape[0] > 1 else c.name for c in constraints for k in range(c.rows.shape[0])]


@dataclass
class Context:
    """What every formulation gives its terms: the shape, the physics, the active tension and
    the step of the semi-implicit tension (0: explicit)."""

    geometry: Geometry
    physics: Physics
    zeta: np.ndarray
    implicit_dt: float = 0.0
    constraints: list = field(default_factory=list)
    implicit_rate: np.ndarray | None = None  # (N, 3) nodes' rate the semi-implicit tension is centred on

    #: the formulation whose terms' method of this name is called
    formulation = ""


@dataclass
class PaperContext(Context):
    """The weights of the paper's strong form (module docstring)."""

    W: np.ndarray = field(init=False)
    W0: np.ndarray = field(init=False)
    Wn: np.ndarray = field(init=False)
    Wn0: np.ndarray = field(init=False)
    rhs: np.ndarray = field(init=False)
    pressure: bool = False

    formulation = "paper"

    def __post_init__(self):
        n, r = self.geometry.n_nodes, self.physics.rows_per_node
        self.W = np.zeros((n, r, 5, 3))
        self.W0 = np.zeros((n, r, 3))
        self.Wn = np.zeros((n, r, 5))
        self.Wn0 = np.zeros((n, r))
        self.rhs = np.zeros((n, r))
        self._zeta_fit = None

    @property
    def zeta_fit(self) -> np.ndarray:
        """Fitted derivatives of the active tension (computed once, when a term asks)."""
        if self._zeta_fit is None:
            self._zeta_fit = self.geometry.fit_scalar(self.zeta)
        return self._zeta_fit


def _plus(total: np.ndarray | None, part: np.ndarray) -> np.ndarray:
    """``total + part``, ``part`` itself for the first one (no rounding against a zero start)."""
    return part if total is None else total + part


@dataclass
class P1Context(Context):
    """The coefficients of the discrete Rayleighian on the flat triangles (module docstring).

    ``faces`` (T, 3); ``area`` (T,), ``tnormal`` (T, 3) and ``grads`` (T, 3, 3) (corner, xyz) the
    triangles' areas, unit normals and the in-plane gradients of their barycentric functions;
    ``pressure_weights`` and ``active_force`` the scene's ``numerics.pressure_weights`` and
    ``numerics.active_force``."""

    faces: np.ndarray = None
    area: np.ndarray = None
    tnormal: np.ndarray = None
    grads: np.ndarray = None
    pressure_weights: str = "petrov"
    active_force: str = "balanced"
    implicit_weight: float = 1.0  # numerics.implicit_tension_weight: the factor on the semi-implicit tension's drag
    shear: float = 0.0  # eta_s of A_T eta_s |U~_T|^2
    bulk: float = 0.0  # eta_b of A_T eta_b / 2 (tr U_T)^2
    normal_form: np.ndarray | None = None  # B^cd (N, 2, 2) of 1/2 int B^cd d_c v_n d_d v_n dA
    normal_drag: np.ndarray | None = None  # beta (N,) of 1/2 sum_k A_k beta_k v_n,k^2
    blocks: np.ndarray | None = None  # (T, 9, 9) second derivatives of further dissipation
    triangle_force: np.ndarray | None = None  # (T, 9): the power sum_T f_T . (v_a, v_b, v_c)
    node_force: np.ndarray | None = None  # (N, 3): the power sum_k f_k . v_k
    dense: np.ndarray | None = None  # (3N, 3N) a dense symmetric dissipation (the fluids'), added to the sparse one
    fluid_operator: object | None = None  # the fluids matrix-free (physics/fluids_fast.py): a coupled Krylov solve

    formulation = "rayleigh_p1"

    def add_normal_form(self, bform: np.ndarray) -> None:
        self.normal_form = _plus(self.normal_form, bform)

    def add_normal_drag(self, beta: np.ndarray) -> None:
        self.normal_drag = _plus(self.normal_drag, beta)

    def add_blocks(self, blocks: np.ndarray) -> None:
        self.blocks = _plus(self.blocks, blocks)

    def add_triangle_force(self, force: np.ndarray) -> None:
        self.triangle_force = _plus(self.triangle_force, force)

    def add_node_force(self, force: np.ndarray) -> None:
        self.node_force = _plus(self.node_force, force)

    def add_dense(self, block: np.ndarray) -> None:
        """A dense symmetric positive semidefinite (3N, 3N) dissipation: the system is then solved
        densely (:mod:`cortex_ti.solve.dense`)."""
        self.dense = _plus(self.dense, block)

    def add_fluid_operator(self, op) -> None:
        """The fluids matrix-free (:class:`~cortex_ti.physics.fluids_fast.FmmFluid`): the system is
        then solved by the coupled GMRES of :mod:`cortex_ti.solve.fluid_krylov`."""
        if self.fluid_operator is not None:
            raise ValueError("one matrix-free fluid operator per system")
        self.fluid_operator = op


@dataclass
class P2Context(Context):
    """What the terms declare to the Rayleighian on curved cells (module docstring). ``surface`` is
    the :class:`~cortex_ti.surface.curved.CurvedSurface` of the shape, whose nodes are the mesh's
    (``zeta`` is the tension at every one of them)."""

    surface: object = None
    shear: float = 0.0
    bulk: float = 0.0
    tension: np.ndarray | None = None  # (M,) whose power int zeta tr u dA is added
    #: (M,): with numerics.active_force balanced, the tension whose nodal force loses the tangential part
    #: ``zeta_i P_i int tr u_i dA`` of its node's own value
    balanced_tension: np.ndarray | None = None
    active_force: str = "balanced"
    #: numerics.pressure_weights: ``petrov`` (the pressure pushes along the smooth normal speed's rows) or
    #: ``exact`` (along the volume rows it holds: then the dynamics is a constrained gradient flow)
    pressure_weights: str = "petrov"
    implicit_weight: float = 1.0  # numerics.implicit_tension_weight: the factor on the semi-implicit tension's drag
    #: (M,): a tension whose force is the exact gradient ``-dE_h/dx`` of ``E_h = int zeta dA`` over the
    #: curved cells (:meth:`~cortex_ti.surface.curved.CurvedSurface.energy_gradient`), numerics.active_force
    #: gradient
    energy_tension: np.ndarray | None = None
    normal_forms: list = field(default_factory=list)  # (B (T, Q, 3, 3), beta0 (T, Q) or None, centre (M, 3) or None)
    node_force: np.ndarray | None = None  # (M, 3)
    #: (matrix (3M, 3M) on the nodes' Cartesian velocities, centre (M, 3) or None): ``1/2 (v - r)^T S (v - r)``
    #: added to the dissipation (a semi-implicit stiffness)
    matrices: list = field(default_factory=list)

    formulation = "rayleigh_p2"

    def add_tension(self, zeta_nodes: np.ndarray) -> None:
        self.tension = _plus(self.tension, zeta_nodes)

    def add_energy_tension(self, zeta_nodes: np.ndarray) -> None:
        self.energy_tension = _plus(self.energy_tension, zeta_nodes)

    def add_normal_form(self, bform: np.ndarray, beta0: np.ndarray | None = None, centre: np.ndarray | None = None):
        """``1/2 int [B : grad (v_n - r_n) grad (v_n - r_n) + beta0 (v_n - r_n)^2] dA`` with ``B`` an
        ambient tangential tensor at the quadrature points, ``r`` the nodal vectors ``centre`` (M, 3)
        (none: ``r = 0``)."""
        self.normal_forms.append((bform, beta0, centre))

    def add_node_force(self, force: np.ndarray) -> None:
        self.node_force = _plus(self.node_force, force)

    def add_matrix(self, matrix, centre: np.ndarray | None = None) -> None:
        """``1/2 (v - r)^T S (v - r)`` with ``S`` (3M, 3M, node-major) symmetric positive semidefinite and
        ``r`` the nodal vectors ``centre`` (M, 3) (none: ``r = 0``)."""
        self.matrices.append((matrix, centre))


class Term:
    """A physical contribution to the force balance (module docstring): ``effect``, ``name``,
    ``applies`` and one method per formulation."""

    effect: str | None = None
    name: str = "term"

    def applies(self, ctx: Context) -> bool:
        """Whether the term has anything to add on this solve (beyond its effect being on)."""
        return True


TERMS: list[type[Term]] = []


def register(cls: type[Term]) -> type[Term]:
    TERMS.append(cls)
    return cls


def terms_for(ctx: Context) -> list[Term]:
    """The terms that add to ``ctx``'s formulation on this solve, in registration order: those
    whose effect is on, that apply and that contribute to the formulation. A term that says
    nothing about the formulation, or an effect switched on that no term of the formulation
    implements, is one :class:`~cortex_ti.errors.SolverError`."""
    form, effects = ctx.formulation, ctx.physics.effects
    missing = effects_without_terms(effects, form)
    if missing:
        raise SolverError(f"formulation {form!r} has no term for the effect(s) {', '.join(missing)}")
    on = (cls() for cls in TERMS if cls.effect is None or cls.effect in effects)
    return [term for term in on if getattr(term, form) is not None and term.applies(ctx)]


def effects_without_terms(effects, formulation: str) -> list[str]:
    """The effects among ``effects`` that have terms, none of them in ``formulation`` (sorted): a
    scene asking for one under that formulation would lose physics silently. A term of one of
    ``effects`` that says nothing about the formulation (neither a method nor ``None``) is one
    :class:`~cortex_ti.errors.SolverError`."""
    implemented, with_terms = set(), set()
    for cls in TERMS:
        with_terms.add(cls.effect)
        if not (cls.effect is None or cls.effect in effects):
            continue
        if not hasattr(cls, formulation):
            raise SolverError(
                f"the term {cls.__name__} ({cls.name}) does not say what it adds to formulation "
                f"{formulation!r}: give it a method {formulation}(ctx), or {formulation} = None if it "
                "has no part there"
            )
        if getattr(cls, formulation) is not None:
            implemented.add(cls.effect)
    return sorted(e for e in effects if e in with_terms and e not in implemented)


def velocity_basis(geometry: Geometry, physics: Physics) -> np.ndarray:
    """Cartesian unit vectors, or the tangent frame when v_n is fixed to zero."""
    if physics.normal_balance:
        return np.broadcast_to(np.eye(3), (geometry.n_nodes, 3, 3)).copy()
    return geometry.tangent_frame()


def check_inputs(physics: Physics, zeta, implicit_dt: float) -> np.ndarray:
    """What every formulation needs before it assembles: shear viscosity (else the force balance
    has no unique solution), a finite active tension (returned as a contiguous float64 array)
    and a finite step >= 0; one :class:`~cortex_ti.errors.SolverError` naming what is wrong."""
    if not (physics.eta_s > 0 and "shear_viscosity" in physics.effects):
        raise SolverError(
            "the force balance needs shear viscosity (effect 'shear_viscosity' with "
            "viscosity.shear > 0): without it every area-preserving flow is a solution"
        )
    zeta = np.ascontiguousarray(zeta, dtype=np.float64)
    if not np.all(np.isfinite(zeta)):
        bad = np.flatnonzero(~np.isfinite(zeta))
        raise SolverError(
            f"the active tension is not finite at {bad.size} node(s) (first: node {bad[0]}, value {zeta[bad[0]]})"
        )
    if not (np.isfinite(implicit_dt) and implicit_dt >= 0.0):
        raise SolverError(f"implicit_dt must be a finite step >= 0, got {implicit_dt}")
    return zeta
