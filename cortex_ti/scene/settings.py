"""One typed resolution of a scene's settings: :class:`RunSettings`.

A :class:`~cortex_ti.scene.loader.Scene` is the validated YAML (what the user wrote, with the
schema's defaults filled in); :class:`RunSettings` is what a run does with it, resolved once:
numbers as floats, the solver backend ``auto`` as the backend that runs, the time scheme's
treatment of the tension (``time.implicit_tension: auto``) as a bool for that scheme, a null
fit-residual weight as 0. Everything downstream (the simulation, ``cortex-ti check``, the run
summaries, the workflow's sweep tables) reads these, never the raw strings.

Sections follow the scene's (``mesh``, ``viscosity``, ``numerics``, ``solver``, ``time``), each a
frozen dataclass.
"""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass

import numpy as np

from ..dynamics.schemes import SCHEMES
from ..physics.fluids_fast import DIRECT_BACKEND, FMM_BACKEND
from ..physics.formulations import FORMULATIONS
from ..physics.model import Fluid, Physics, resolve_fluid_solver
from ..physics.patterns import pattern_axis
from ..solve.dense import DENSE_BACKEND
from ..solve.factorizations import choose_factorization
from ..surface.remesh import H_MIN_DIVISOR, RemeshOptions
from .rules import solver_rtol, step_control_nodes

__all__ = [
    "RunSettings",
    "MeshSettings",
    "RemeshSettings",
    "ViscositySettings",
    "NumericsSettings",
    "SolverSettings",
    "TimeSettings",
    "AxisymmetricSettings",
    "RigiditySettings",
    "BUDGET_H_MAX",
]

#: with a node budget (mesh.remesh.size: budget) and no mesh.remesh.h_max, the largest target edge
#: length is this many times the initial mesh's mean edge length
BUDGET_H_MAX = 3.0


@dataclass(frozen=True)
class RemeshSettings:
    """Remeshing in a run (``mesh.remesh``): below ``min_angle`` (deg), or where the mesh is
    ``coarser`` than its size field by that factor (None: never), the surface is remeshed with
    ``options`` (:class:`cortex_ti.surface.remesh.RemeshOptions`). ``size``: ``budget`` (the node
    count ``options.nodes``; None there: the initial mesh's) or ``curvature``."""

    min_angle: float
    options: RemeshOptions
    size: str = "budget"
    coarser: float | None = None
    settle_steps: int = 0  # pseudo-steps settling the new mesh into its discrete equilibrium (0: off)
    settle_dt: float = 1e-3  # their length (t_a)
    mirror: bool = False  # remesh one half and reflect it (the pattern axis' plane through the centroid)

    def sized(self, mean_edge: float, n_nodes: int) -> RemeshOptions:
        """:attr:`options` with the size defaults of a run resolved against its initial mesh (mean
        edge length ``mean_edge``, ``n_nodes`` nodes), where the scene leaves them null: ``h_min`` =
        ``mean_edge`` / :data:`~cortex_ti.surface.remesh.H_MIN_DIVISOR`; with ``size: budget`` the
        node budget is the initial mesh's and ``h_max`` = :data:`BUDGET_H_MAX` ``mean_edge`` (the
        run keeps its node count, the flat parts may coarsen 3-fold); with ``size: curvature`` no
        budget and ``h_max`` = ``mean_edge``."""
        o = self.options
        h_min = o.h_min or mean_edge / H_MIN_DIVISOR
        if self.size == "budget":
            h_max = o.h_max or BUDGET_H_MAX * mean_edge
            return dataclasses.replace(o, h_min=h_min, h_max=h_max, nodes=o.nodes or int(n_nodes))
        return dataclasses.replace(o, h_min=h_min, h_max=o.h_max or mean_edge, nodes=None)


@dataclass(frozen=True)
class MeshSettings:
    """The initial surface: an icosphere of ``nodes`` nodes and ``radius``, or a user's ``file``;
    then the affine ``transform`` and the simple ``shear`` x -> x + shear z."""

    nodes: int | None
    file: str | None
    radius: float
    shear: float
    transform: tuple[tuple[float, float, float], ...] | None
    motion: str = "normal"  # how the nodes move (cortex_ti.dynamics.motion.MESH_MOTIONS)
    ale_time: float = 0.05  # relaxation time of the ALE mesh velocity (motion: ale)
    relax_start: bool = False  # mend the triangles the initial shear/transform distorts (icosphere; default: with ale)
    remesh: RemeshSettings | None = None  # None: never remeshed

    def initial_map(self) -> np.ndarray | None:
        """The 3x3 matrix of ``transform`` followed by ``shear`` (None for the identity)."""
        matrix = np.eye(3) if self.transform is None else np.asarray(self.transform, dtype=float)
        if self.shear:
            shear = np.eye(3)
            shear[0, 2] = self.shear
            matrix = shear @ matrix
        return None if np.array_equal(matrix, np.eye(3)) else matrix


@dataclass(frozen=True)
class ViscositySettings:
    """Viscous coefficients (units of eta_s)."""

    shear: float
    bulk: float
    bending: float
    bending_bulk: float


@dataclass(frozen=True)
class RigiditySettings:
    """Helfrich bending rigidity kappa (eta_s R0^2 / t_a) and spontaneous curvature c0 (1/R0); kappa is
    0 without the effect ``bending_rigidity``."""

    bending: float = 0.0
    spontaneous_curvature: float = 0.0


@dataclass(frozen=True)
class NumericsSettings:
    """The discretisation: the formulation (:data:`cortex_ti.physics.formulations.FORMULATIONS`),
    the fit scheme, and the keys of one formulation: the weight of the fit-residual rows
    (``paper``; 0: off) and how the pressure enters (``rayleigh_p1``)."""

    formulation: str
    fit: str
    fit_residual_weight: float
    pressure_weights: str
    active_force: str = "balanced"
    implicit_tension_weight: float = 1.0  # rayleigh_p1: the factor on the semi-implicit tension's drag

    @property
    def formulation_entry(self):
        """The formulation's registry entry (builds the system of a shape)."""
        return FORMULATIONS[self.formulation]

    @property
    def uses_fit_residual(self) -> bool:
        """Whether the geometry must carry the fit residuals (the fit-residual rows are on)."""
        return self.formulation_entry.uses_fit_residual(self)


@dataclass(frozen=True)
class SolverSettings:
    """The factorisation that runs (``auto`` resolved), reuse across solves, GMRES tolerance."""

    backend: str
    reuse: bool
    rtol: float
    refine: bool


@dataclass(frozen=True)
class TimeSettings:
    """Time stepping (only used with the ``shape_evolution`` effect)."""

    dt: float
    t_end: float
    scheme: str
    save_every: float
    save_times: tuple[float, ...]  # extra frame times
    steady_tol: float
    tol: float
    dt_max: float
    implicit_tension: bool  # the semi-implicit tension, resolved for the scheme (False for a static scene)
    stop_neck: float | None = None  # stop when the neck radius falls to this (R0); None: never
    dt_max_set: bool = False  # whether the scene set time.dt_max (else dt_max is the scheme's default)

    @property
    def scheme_class(self):
        """The scheme's class in :data:`cortex_ti.dynamics.schemes.SCHEMES`."""
        return SCHEMES[self.scheme]

    def describe(self) -> str:
        """One line: how the run steps (for ``cortex-ti check`` and logs)."""
        return (
            f"{self.scheme} from dt = {self.dt:g} to t = {self.t_end:g}, "
            f"{'semi-implicit' if self.implicit_tension else 'explicit'} tension"
        )


@dataclass(frozen=True)
class AxisymmetricSettings:
    """The spectral meridian solver of ``model: axisymmetric`` (:mod:`cortex_ti.axisymmetric`)."""

    n: int  # collocation points on the half meridian (whole meridian without symmetry)
    rtol: float  # Radau tolerance on the node positions
    surface_points: int  # meridian points of the written surface of revolution
    azimuthal_points: int  # points around the axis
    neck_resolution: float = 0.0  # > 0: points placed by arc length and curvature (R0), 0: normal motion
    stop_neck: float = 0.05  # the run stops when the neck radius falls to this (R0)
    points: str = "normal"  # "normal": meridian points move with v_n n; "arclength": equally spaced;
    # "adaptive": equidistributing curvature, the label's stretch rate and the tension's gradient
    bending_form: str = "dissipation"  # the bending viscosity's normal force: Eq. 45 ("paper") or "dissipation"
    # (the scene's "auto" resolved: numerics.formulation's form)


def _bending_form(setting: str, formulation: str) -> str:
    """``axisymmetric.bending_form`` resolved: ``auto`` is the form ``numerics.formulation`` discretises."""
    return FORMULATIONS[formulation].bending_form if setting == "auto" else setting


def _division_neck(data: dict) -> float | None:
    """``division.neck_radius`` (None: no division; a scene without the ``division`` block has none)."""
    value = (data.get("division") or {}).get("neck_radius")
    return None if value is None else float(value)


def _division_weight(data: dict) -> float | None:
    """``division.implicit_tension_weight`` (None: the numerics' weight after a cut too)."""
    value = (data.get("division") or {}).get("implicit_tension_weight")
    return None if value is None else float(value)


@dataclass(frozen=True)
class RunSettings:
    """Everything a run needs from its scene, resolved once (see the module docstring)."""

    name: str
    model: str  # "3d" or "axisymmetric"
    translation: str  # how the free rigid translation is fixed: "mean_velocity" or "centroid"
    tension_transport: str  # "nodes" (glued to the mesh nodes, the paper's) or "material" (carried by v)
    fields: tuple  # (name, settings mapping) of each field the scene names (treat as read-only)
    effects: frozenset
    mesh: MeshSettings
    viscosity: ViscositySettings
    patterns: tuple  # the active_stress patterns (mappings; treat as read-only)
    numerics: NumericsSettings
    solver: SolverSettings
    time: TimeSettings
    axisymmetric: AxisymmetricSettings
    rigidity: RigiditySettings = RigiditySettings()
    fluid: Fluid | None = None  # the fluids (cortex_ti.physics.model.Fluid) with the effect fluids; None without
    division_neck: float | None = None  # division.neck_radius: cut the surface in two at this neck (R0); None: never
    division_ring: str = "keep"  # division.ring: "keep" the patterns' extra tension at the cut, or "dissolve" it
    division_weight: float | None = None  # division.implicit_tension_weight: the daughters' (None: the numerics')

    @classmethod
    def from_data(cls, data: dict) -> RunSettings:
        """The settings of a validated scene's data (:attr:`cortex_ti.scene.Scene.data`)."""
        effects = frozenset(data["effects"])
        mesh, visc, num, sol, tim = (data[k] for k in ("mesh", "viscosity", "numerics", "solver", "time"))
        dynamic = "shape_evolution" in effects
        scheme = SCHEMES[tim["scheme"]]
        tol, dt_max = scheme.resolve_step_control(tim["tol"], tim["dt_max"], step_control_nodes(data))
        implicit = (
            dynamic
            and "normal_balance" in effects
            and scheme.implicit_tension(tim["implicit_tension"], num["formulation"])
        )
        transform = mesh["transform"]
        ax = data["axisymmetric"]
        return cls(
            name=data["name"],
            model=data["model"],
            translation=data["translation"],
            tension_transport=data["tension_transport"],
            fields=tuple((k, copy.deepcopy(v)) for k, v in data["fields"].items()),
            effects=effects,
            mesh=MeshSettings(
                nodes=mesh["nodes"],
                file=mesh["file"],
                radius=float(mesh["radius"]),
                shear=float(mesh["shear"]),
                motion=mesh["motion"],
                ale_time=float(mesh["ale_time"]),
                relax_start=(
                    mesh["motion"] == "ale" and mesh["file"] is None
                    if mesh["relax_start"] is None
                    else bool(mesh["relax_start"])
                ),
                remesh=_remesh_settings(mesh.get("remesh") or {}),
                transform=None if transform is None else tuple(tuple(map(float, r)) for r in transform),
            ),
            viscosity=ViscositySettings(*(float(visc[k]) for k in ("shear", "bulk", "bending", "bending_bulk"))),
            patterns=tuple(copy.deepcopy(data["active_stress"])) if "active_stress" in effects else (),
            numerics=NumericsSettings(
                formulation=num["formulation"],
                fit=num["fit"],
                fit_residual_weight=float(num["fit_residual_weight"] or 0.0),
                pressure_weights=num["pressure_weights"],
                active_force=num["active_force"],
                implicit_tension_weight=float(num["implicit_tension_weight"]),
            ),
            solver=SolverSettings(
                backend=choose_factorization(sol["backend"]).name,
                reuse=bool(sol["reuse"]),
                rtol=solver_rtol(data),
                refine=bool(sol["refine"]),
            ),
            time=TimeSettings(
                dt=float(tim["dt"]),
                t_end=float(tim["t_end"]),
                scheme=tim["scheme"],
                save_every=float(tim["save_every"]),
                save_times=tuple(sorted(float(x) for x in tim["save_times"])),
                steady_tol=float(tim["steady_tol"]),
                stop_neck=None if tim["stop_neck"] is None else float(tim["stop_neck"]),
                tol=tol,
                dt_max=dt_max,
                dt_max_set=tim["dt_max"] is not None,
                implicit_tension=bool(implicit),
            ),
            axisymmetric=AxisymmetricSettings(
                n=int(ax["n"]),
                rtol=float(ax["rtol"]),
                surface_points=int(ax["surface_points"]),
                azimuthal_points=int(ax["azimuthal_points"]),
                neck_resolution=float(ax["neck_resolution"]),
                stop_neck=float(ax["stop_neck"]),
                points=ax["points"],
                bending_form=_bending_form(ax["bending_form"], num["formulation"]),
            ),
            rigidity=RigiditySettings(
                float(data["rigidity"]["bending"]) if "bending_rigidity" in effects else 0.0,
                float(data["rigidity"]["spontaneous_curvature"]),
            ),
            fluid=_fluid_settings(data["fluid"], mesh["nodes"] if mesh["file"] is None else None)
            if "fluids" in effects
            else None,
            division_neck=_division_neck(data),
            division_ring=(data.get("division") or {}).get("ring", "keep"),
            division_weight=_division_weight(data),
        )

    @property
    def solver_name(self) -> str:
        """The solve that runs, as the outputs record it: with the effect ``fluids`` the dense Cholesky
        (:data:`cortex_ti.solve.dense.DENSE_BACKEND`) or the matrix-free coupled GMRES
        (:data:`cortex_ti.physics.fluids_fast.FMM_BACKEND`) of ``fluid.solver``, else the sparse backend."""
        if self.fluid is None:
            return self.solver.backend
        return {"fmm": FMM_BACKEND, "direct": DIRECT_BACKEND}.get(self.fluid.solver, DENSE_BACKEND)

    def has(self, effect: str) -> bool:
        """Whether ``effect`` is switched on."""
        return effect in self.effects

    @property
    def dynamic(self) -> bool:
        """Whether the shape evolves in time (the ``shape_evolution`` effect)."""
        return "shape_evolution" in self.effects

    def field(self, name: str):
        """The settings of the field ``name`` (None if the scene does not name it)."""
        return dict(self.fields).get(name)

    @property
    def tension_carried(self) -> bool:
        """Whether the prescribed tension moves with the material (``tension_transport: material``, or
        nodes that are material points, ``mesh.motion: lagrangian``) rather than staying on nodes
        that move normally."""
        return self.tension_transport == "material" or self.mesh.motion == "lagrangian"

    @property
    def physics(self) -> Physics:
        """What the force-balance terms read: the effects and the viscous coefficients."""
        v = self.viscosity
        return Physics(
            effects=self.effects,
            eta_s=v.shear,
            eta_b=v.bulk,
            eta_bar=v.bending,
            eta_bar_b=v.bending_bulk,
            translation=self.translation,
            material_nodes=self.mesh.motion == "lagrangian",
            kappa=self.rigidity.bending,
            c0=self.rigidity.spontaneous_curvature if self.rigidity.bending > 0 else 0.0,
            fluid=self.fluid,
        )

    @property
    def pattern_axis(self) -> np.ndarray:
        """The unit axis of the active-stress pattern (+z without one)."""
        return pattern_axis(self.patterns)

    def describe_numerics(self) -> str:
        """One line on the discretisation (for ``cortex-ti check`` and logs)."""
        held = "; the centroid held (translation: centroid)" if self.translation == "centroid" else ""
        if self.model == "axisymmetric":
            a = self.axisymmetric
            return f"axisymmetric model: {a.n} meridian points, Radau rtol {a.rtol:g}{held}"
        num = self.numerics
        if num.formulation == "paper":
            w = num.fit_residual_weight
            return f"formulation paper, {num.fit} fit; fit-residual rows {'off' if not w else f'at {w:g}'}{held}"
        fl = self.fluid
        fluids = (
            ""
            if fl is None
            else f"; fluids mu_in = {fl.inner:g}, mu_out = {fl.outer:g}, far field {fl.far_field} "
            f"({fl.solver}, no gauge)"
        )
        return (
            f"formulation {num.formulation}, {num.fit} fit (normals, curvature); pressure {num.pressure_weights}, "
            f"active force {num.active_force}{held}{fluids}"
        )


def _fluid_settings(data: dict, nodes: int | None) -> Fluid:
    """``fluid`` resolved (the effect ``fluids`` on): floats, tuples, the far field's type and values,
    the solve (``auto`` by the icosphere's node count ``nodes``; None: a mesh file, dense)."""
    far = data["far_field"]
    return Fluid(
        solver=resolve_fluid_solver(data["solver"], nodes, float(data["inner"]), float(data["outer"])),
        inner=float(data["inner"]),
        outer=float(data["outer"]),
        body_force=tuple(float(b) for b in data["body_force"]),
        far_field=far["type"],
        velocity=tuple(float(u) for u in far["velocity"]),
        rate=float(far["rate"]),
    )


def _remesh_settings(data: dict) -> RemeshSettings | None:
    """``mesh.remesh`` resolved: None while its ``min_angle`` is null (off)."""
    if data.get("min_angle") is None:
        return None

    def opt(key):
        return None if data.get(key) is None else float(data[key])

    options = RemeshOptions(
        edge_angle=float(data["edge_angle"]),
        h_min=opt("h_min"),
        h_max=opt("h_max"),
        hausd=opt("hausd"),
        hgrad=float(data["hgrad"]),
        quality=float(data["quality"]),
        nodes=None if data.get("nodes") is None else int(data["nodes"]),
        min_angle=float(data["min_angle"]),
    )
    return RemeshSettings(
        min_angle=float(data["min_angle"]),
        options=options,
        size=str(data["size"]),
        coarser=opt("coarser"),
        settle_steps=int(data["settle_steps"]),
        settle_dt=float(data["settle_dt"]),
        mirror=bool(data.get("mirror", False)),
    )
