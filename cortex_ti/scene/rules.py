"""Cross-key rules of a scene that JSON schema does not express (effects versus coefficients,
exactly one mesh source, a time scheme and its tension treatment, ...)."""

from __future__ import annotations

import difflib
import math

from ..dynamics.schemes import SCHEMES
from ..errors import SceneError
from ..physics.formulations import FORMULATIONS
from ..physics.model import EFFECTS
from ..physics.patterns import EQUATOR
from ..surface.mesh import icosphere_sizes
from ..surface.remesh import H_MIN_DIVISOR
from .rules_fluids import FLUIDS_MAX_NODES, check_fluids, fluids_size_message
from .schema import current_schema, fmt_value

__all__ = ["check_rules", "FLUIDS_MAX_NODES", "VALID_NODE_COUNTS", "fluids_size_message"]

#: Icosphere node counts 10*4^k+2 accepted for mesh.nodes (k = 0..7).
VALID_NODE_COUNTS: tuple[int, ...] = tuple(icosphere_sizes(7))

#: division.neck_radius must be at least this many smallest target edge lengths h_min of the remeshing
#: (a circle of that radius has about 4 pi = 12.6 edges of h_min around it)
DIVISION_MIN_EDGES = 2.0

#: Effects that need the normal force balance.
_NEED_NORMAL_BALANCE = ("incompressibility", "bending_viscosity", "bending_rigidity", "shape_evolution", "fluids")


#: The smallest neck radius a meridian of ``n`` points is cut at is ``AXISYMMETRIC_NECK_RESOLUTION / n^2``
#: (R0): the symmetric ring 1 + 20 exp(-10 x^4) with kappa = 0.01 on adaptive points stops (singular
#: force balance) at a neck of 1.6e-3 with n = 48 and 8.3e-4 with n = 64, about 3.5 / n^2
#: (docs/validation/division_axisymmetric.md); the floor keeps a factor of about 3 above it.
AXISYMMETRIC_NECK_RESOLUTION = 10.0


def axisymmetric_neck_floor(n: int) -> float:
    """The smallest ``division.neck_radius`` (R0) the axisymmetric model resolves with ``n`` points."""
    return AXISYMMETRIC_NECK_RESOLUTION / float(n) ** 2


def check_rules(data: dict) -> None:
    """Cross-key rules that JSON schema does not express, on a schema-valid scene with its
    defaults filled in; each rule raises one :class:`SceneError` naming the keys involved."""
    _check_mesh_source(data["mesh"])
    effects = _check_effect_names(data["effects"])
    _check_effect_combinations(effects)
    _check_coefficients(data["viscosity"], effects)
    _check_rigidity(data, effects)
    _check_time(data.get("time") or {})
    _check_step_count(data)
    _check_stop_neck(data)
    _check_division(data)
    _check_mirror(data)
    _check_multistep(data)
    _check_patterns(data["active_stress"], effects, bool(data["fields"]))
    _check_formulation_keys(data["numerics"])
    _check_translation(data["translation"], effects)
    _check_motion(data)
    _check_remesh(data)
    _check_curved(data)
    check_fluids(data, effects)
    if data["model"] == "axisymmetric":
        _check_axisymmetric(data)
        _check_axisymmetric_division(data)


def _check_rigidity(data: dict, seen: set[str]) -> None:
    """The effect ``bending_rigidity`` is on exactly when ``rigidity.bending > 0``, and only the
    axisymmetric model and the 3D formulation ``rayleigh_p2`` carry it (the flat triangles have no
    bending force measured to converge)."""
    rig = data.get("rigidity") or {}
    kappa, c0 = rig.get("bending", 0.0), rig.get("spontaneous_curvature", 0.0)
    on = "bending_rigidity" in seen
    if kappa > 0 and not on:
        raise SceneError(
            f"rigidity.bending = {fmt_value(kappa)} but the effect 'bending_rigidity' is off: add it to effects "
            "or set rigidity.bending: 0"
        )
    if c0 != 0 and not on:
        raise SceneError(
            f"rigidity.spontaneous_curvature = {fmt_value(c0)} needs the effect 'bending_rigidity' "
            "(and rigidity.bending > 0): add it or remove the key"
        )
    if on and kappa == 0:
        raise SceneError(
            "the effect 'bending_rigidity' is on but rigidity.bending = 0: set it > 0 or remove "
            "'bending_rigidity' from effects"
        )
    formulation = data["numerics"]["formulation"]
    if on and data["model"] != "axisymmetric" and formulation != "rayleigh_p2":
        raise SceneError(
            f"the effect 'bending_rigidity' is not carried by numerics.formulation = {formulation} (no bending force "
            "on flat triangles converges, docs/validation/bending_rigidity.md): set numerics.formulation: rayleigh_p2 "
            "or model: axisymmetric"
        )


def step_control_nodes(data: dict) -> int | None:
    """The node count a scheme's default ``time.tol`` follows (:meth:`~cortex_ti.dynamics.schemes.BDF2.
    default_tol_for`): the mesh's, or the remeshing's budget ``mesh.remesh.nodes`` when that is larger
    (after the first remeshing the mesh is the budget's, its error that of its node count; a tolerance
    for the coarser start let a 10242-node budget's step move a node half its edge); None for a mesh
    file without a budget."""
    mesh = data.get("mesh") or {}
    nodes = mesh.get("nodes") if mesh.get("file") is None else None
    budget = (mesh.get("remesh") or {}).get("nodes")
    if budget is not None and (nodes is None or budget > nodes):
        return int(budget)
    return nodes


#: ``solver.rtol`` when unset: the GMRES tolerance of a solve's relative residual
DEFAULT_RTOL = 1e-10
#: a formulation with ``rtol_from_step`` under a multistep scheme: ``solver.rtol = time.tol / RTOL_PER_TOL``
RTOL_PER_TOL = 100.0


def solver_rtol(data: dict) -> float:
    """``solver.rtol``, or when unset: 1e-10, except for a formulation whose GMRES tolerance follows
    the step's (:attr:`~cortex_ti.physics.formulations.Formulation.rtol_from_step`, ``rayleigh_p2``) in a
    3D run that evolves its shape with ``bdf2`` / ``bdf3``: ``time.tol / 100``, never below 1e-10. A
    step's displacement error is ``time.tol``; a solve's velocity error ``rtol`` relative, times the
    step's ``dt |v|`` (< 0.01 R0 on the furrows), so a hundredth of the tolerance keeps the solves' share
    of the error small (measured on the 2562-node furrow, ``bdf3``: the nodes move 7e-4 of ``time.tol`` x
    steps from the exact solves' run, the radii 0.2 % of the time error; docs/validation/curved_cost.md,
    "The solve's tolerance")."""
    rtol = (data.get("solver") or {}).get("rtol")
    if rtol is not None:
        return float(rtol)
    time = data.get("time") or {}
    scheme = SCHEMES.get(time.get("scheme", "euler"))
    formulation = FORMULATIONS.get((data.get("numerics") or {}).get("formulation"))
    evolves = data.get("model", "3d") == "3d" and "shape_evolution" in (data.get("effects") or ())
    if scheme is None or not scheme.dense or not evolves or formulation is None or not formulation.rtol_from_step:
        return DEFAULT_RTOL
    tol, _ = scheme.resolve_step_control(time.get("tol"), time.get("dt_max"), step_control_nodes(data))
    return max(tol / RTOL_PER_TOL, DEFAULT_RTOL)


def _check_formulation_keys(numerics: dict) -> None:
    """A key that only one formulation reads (:attr:`Formulation.keys`) is not set to anything but
    its default under another formulation: it would be silently ignored."""
    chosen = numerics["formulation"]
    defaults = current_schema()["properties"]["numerics"]["properties"]
    for name, form in FORMULATIONS.items():
        if name == chosen:
            continue
        for key in form.keys:
            if key in FORMULATIONS[chosen].keys:
                continue
            value = numerics.get(key)
            if value not in (None, defaults[key]["default"]):
                raise SceneError(
                    f"numerics.{key} = {fmt_value(value)} applies to numerics.formulation = "
                    f"{' or '.join(n for n, f in FORMULATIONS.items() if key in f.keys)} only, not {chosen}: remove "
                    f"it or set numerics.formulation: {name}"
                )


def _check_translation(translation: str, seen: set[str]) -> None:
    """Holding the centroid needs the normal velocity: with it fixed (a tangential flow) the
    centroid cannot move and its rows would be empty."""
    if translation == "centroid" and "normal_balance" not in seen:
        raise SceneError(
            "translation = centroid needs the normal force balance (effect 'normal_balance'): a "
            "tangential flow cannot move the centroid; use translation: mean_velocity"
        )


def _check_motion(data: dict) -> None:
    """A tension glued to nodes that move by a mesh rule (``ale``) would move by that rule, not by
    any physics: such a tension must be carried by the material."""
    motion = data["mesh"]["motion"]
    if data["fields"] and "active_stress" not in data["effects"]:
        raise SceneError(
            f"fields.{next(iter(data['fields']))} makes an active tension, which needs the effect "
            "'active_stress' (add it to effects; active_stress: [] adds no prescribed pattern)"
        )
    if data["fields"] and data["model"] == "axisymmetric":
        other = [name for name in data["fields"] if name != "myosin"]
        if other:
            raise SceneError(f"model = axisymmetric carries only fields.myosin, not fields.{other[0]}: use model: 3d")
    if motion == "ale" and data["tension_transport"] == "nodes" and data["active_stress"]:
        raise SceneError(
            "mesh.motion = ale moves the nodes tangentially by a mesh rule, so a tension glued to them "
            "(tension_transport = nodes) would move by that rule: set tension_transport: material"
        )


def _check_curved(data: dict) -> None:
    """A formulation on curved cells (``rayleigh_p2``) needs a mesh of at least one split: an icosphere
    of 42 nodes or more, or a mesh file (split when the run starts); its pressure is ``petrov`` or
    ``exact``. Its remeshing remeshes the corner mesh (:mod:`cortex_ti.surface.curved_remesh`)."""
    formulation = data["numerics"]["formulation"]
    if data["model"] != "3d" or not FORMULATIONS[formulation].curved:
        return
    mesh = data["mesh"]
    if mesh.get("file") is None and mesh["nodes"] < 42:
        raise SceneError(
            f"mesh.nodes = {fmt_value(mesh['nodes'])} with numerics.formulation = {formulation}: its curved cells are "
            "made of four triangles of the icosphere one level finer, so it needs at least 42 nodes"
        )
    if data["numerics"]["pressure_weights"] == "area":
        raise SceneError(
            f"numerics.pressure_weights = area with numerics.formulation = {formulation}: its pressure pushes along "
            "the smooth normal speed's rows (petrov) or the exact volume rows (exact); 'area' is rayleigh_p1's"
        )


def _check_remesh(data: dict) -> None:
    """Remeshing (``mesh.remesh.min_angle`` set) needs a 3D run that moves its shape, a repair goal
    above the trigger and consistent length bounds."""
    rem = data["mesh"].get("remesh") or {}
    trigger = rem.get("min_angle")
    if trigger is None:
        return
    if data["model"] != "3d":
        raise SceneError(
            f"mesh.remesh.min_angle = {fmt_value(trigger)}: model = {data['model']} has no triangle mesh to "
            "remesh (it places its own points; see axisymmetric.neck_resolution): remove mesh.remesh"
        )
    if "shape_evolution" not in data["effects"]:
        raise SceneError(
            f"mesh.remesh.min_angle = {fmt_value(trigger)} needs a moving shape (effect 'shape_evolution'): "
            "a static scene solves once on its mesh"
        )
    if rem["quality"] <= trigger:
        raise SceneError(
            f"mesh.remesh.quality = {fmt_value(rem['quality'])} must be above mesh.remesh.min_angle = "
            f"{fmt_value(trigger)}: a remeshed surface would trigger the next remeshing at once"
        )
    if rem.get("nodes") is not None and rem["size"] != "budget":
        raise SceneError(
            f"mesh.remesh.nodes = {fmt_value(rem['nodes'])} is a node budget: it needs mesh.remesh.size = budget "
            f"(not {rem['size']})"
        )
    if rem.get("h_max") is not None and rem.get("h_min") is not None and rem["h_max"] <= rem["h_min"]:
        raise SceneError(
            f"mesh.remesh.h_max = {fmt_value(rem['h_max'])} must be larger than mesh.remesh.h_min = "
            f"{fmt_value(rem['h_min'])}"
        )


def _check_mesh_source(mesh: dict) -> None:
    """Exactly one mesh source, and a valid icosphere size."""
    nodes, file = mesh.get("nodes"), mesh.get("file")
    if nodes is not None and file is not None:
        raise SceneError(f"mesh.nodes = {nodes} and mesh.file = '{file}' are both set: give exactly one of them")
    if nodes is None and file is None:
        raise SceneError("mesh needs exactly one of mesh.nodes (icosphere node count) or mesh.file (a mesh file)")
    if file is not None and mesh.get("relax_start"):
        raise SceneError(f"mesh.relax_start moves the nodes of an icosphere, not of mesh.file = '{file}': remove one")
    if nodes is not None and nodes not in VALID_NODE_COUNTS:
        valid = ", ".join(str(n) for n in VALID_NODE_COUNTS)
        raise SceneError(f"mesh.nodes = {nodes} is not an icosphere node count 10*4^k+2; valid values: {valid}")


def _check_effect_names(effects: list) -> set[str]:
    """Every effect is in the vocabulary, none twice. Returns them as a set."""
    known = ", ".join(EFFECTS)
    seen: set[str] = set()
    for i, name in enumerate(effects):
        if name not in EFFECTS:
            close = difflib.get_close_matches(name, list(EFFECTS), n=1, cutoff=0.6)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            raise SceneError(f"effects.{i}: unknown effect '{name}'{hint}; known effects: {known}")
        if name in seen:
            raise SceneError(f"effects lists '{name}' twice")
        seen.add(name)
    return seen


def _check_effect_combinations(seen: set[str]) -> None:
    """Exactly one of the normal balance and the fixed normal velocity; what needs the normal
    balance has it; shear viscosity is there."""
    if ("normal_balance" in seen) == ("fixed_normal_velocity" in seen):
        got = "both" if "normal_balance" in seen else "neither"
        raise SceneError(f"effects must contain exactly one of 'normal_balance' and 'fixed_normal_velocity', got {got}")
    for name in _NEED_NORMAL_BALANCE:
        if name in seen and "normal_balance" not in seen:
            raise SceneError(
                f"the effect '{name}' requires 'normal_balance' in effects "
                "(it cannot be combined with 'fixed_normal_velocity')"
            )
    if "shear_viscosity" not in seen:
        raise SceneError(
            "effects must contain 'shear_viscosity': without shear viscosity every area-preserving "
            "flow costs nothing and the force balance does not determine the velocity"
        )


def _check_coefficients(visc: dict, seen: set[str]) -> None:
    """A viscous effect is on exactly when its coefficient is nonzero."""
    for effect, key in (("shear_viscosity", "shear"), ("bulk_viscosity", "bulk")):
        value = visc[key]
        if value > 0 and effect not in seen:
            raise SceneError(
                f"viscosity.{key} = {fmt_value(value)} but the effect '{effect}' is off: "
                f"add it to effects or set viscosity.{key}: 0"
            )
        if value == 0 and effect in seen:
            raise SceneError(
                f"the effect '{effect}' is on but viscosity.{key} = 0: "
                f"set viscosity.{key} > 0 or remove '{effect}' from effects"
            )
    bending = {k: visc[k] for k in ("bending", "bending_bulk")}
    if any(v > 0 for v in bending.values()) and "bending_viscosity" not in seen:
        named = " and ".join(f"viscosity.{k} = {fmt_value(v)}" for k, v in bending.items() if v > 0)
        zero = ", ".join(f"viscosity.{k}: 0" for k, v in bending.items() if v > 0)
        raise SceneError(f"{named} but the effect 'bending_viscosity' is off: add it to effects or set {zero}")
    if all(v == 0 for v in bending.values()) and "bending_viscosity" in seen:
        raise SceneError(
            "the effect 'bending_viscosity' is on but viscosity.bending = 0 and "
            "viscosity.bending_bulk = 0: set one of them > 0 or remove 'bending_viscosity' from effects"
        )


def _check_time(time: dict) -> None:
    """The semi-implicit tension is first order: refused with an explicit second-order scheme."""
    scheme = SCHEMES.get(time.get("scheme", "euler"))
    if time.get("implicit_tension") is True and scheme is not None and not scheme.semi_implicit:
        raise SceneError(
            f"time.implicit_tension = true is a first-order treatment of the tension and would spoil the "
            f"second-order scheme time.scheme = {time['scheme']}: use euler, adaptive_euler or bdf2, or set "
            "time.implicit_tension: auto"
        )


#: The most steps a dynamic scene's time.dt may ask for: time.t_end / time.dt above it is refused
#: (1e-300 would spin for ever; a fixed step this small takes months of solves).
MAX_STEPS = 1e8


def _check_step_count(data: dict) -> None:
    """``time.dt`` a dynamic run can honour: at most :data:`MAX_STEPS` steps of it to ``time.t_end``
    (for an adaptive scheme it is the first step, which grows by a bounded factor per step)."""
    time = data.get("time") or {}
    if "shape_evolution" not in data["effects"] or "dt" not in time or "t_end" not in time:
        return
    dt, t_end = float(time["dt"]), float(time["t_end"])
    if t_end > dt * MAX_STEPS:
        raise SceneError(
            f"time.dt = {fmt_value(dt)} is too small for time.t_end = {fmt_value(t_end)}: {t_end / dt:.3g} steps "
            f"(at most {MAX_STEPS:.0e}); set time.dt >= {fmt_value(t_end / MAX_STEPS)}"
        )


def _check_stop_neck(data: dict) -> None:
    """``time.stop_neck`` below the initial radius: a run would otherwise stop at its first frame."""
    stop = (data.get("time") or {}).get("stop_neck")
    if stop is not None and stop >= data["mesh"]["radius"]:
        raise SceneError(
            f"time.stop_neck = {fmt_value(stop)} must be smaller than mesh.radius = "
            f"{fmt_value(data['mesh']['radius'])}: the run would stop at its first frame"
        )


def _check_mirror(data: dict) -> None:
    """``mesh.remesh.mirror``: the curved remeshing of a 3D ``rayleigh_p2`` run only (cortex_ti.surface.mirror)."""
    rem = data["mesh"].get("remesh") or {}
    if not rem.get("mirror"):
        return
    formulation = data["numerics"]["formulation"]
    if data["model"] != "3d" or not FORMULATIONS[formulation].curved or rem.get("min_angle") is None:
        raise SceneError(
            "mesh.remesh.mirror = true reflects a half of the curved remeshing: it needs model 3d, "
            f"numerics.formulation rayleigh_p2 and mesh.remesh.min_angle (not {data['model']}, {formulation})"
        )
    for i, pattern in enumerate(data.get("active_stress") or []):
        if pattern.get("type") in ("ring", "fold") and float(pattern.get("center", EQUATOR)) != EQUATOR:
            raise SceneError(
                f"mesh.remesh.mirror = true keeps the equator a plane of symmetry, but active_stress.{i}.center = "
                f"{fmt_value(pattern['center'])} puts the ring off it: set mirror: false"
            )


def _check_division(data: dict) -> None:
    """``division.neck_radius`` of the 3D model: a run that remeshes flat triangles (``rayleigh_p1``) or curved
    cells (``rayleigh_p2``) with normal or lagrangian nodes and no fluids (the cut and the solve by body,
    cortex_ti.surface.division and curved_division), a neck the remeshing resolves
    (at least :data:`DIVISION_MIN_EDGES` smallest target edges, ``h_min``), and above ``time.stop_neck``."""
    division = data.get("division") or {}
    neck = division.get("neck_radius")
    after = [
        f"division.{k} = {fmt_value(division[k])}"
        for k, default in (("ring", "keep"), ("implicit_tension_weight", None))
        if division.get(k, default) != default
    ]
    if after and (neck is None or data["model"] == "axisymmetric"):
        raise SceneError(
            f"{after[0]} acts on the daughters of a 3D cut: "
            + ("set division.neck_radius" if neck is None else "the axisymmetric model stops at its cut; remove it")
        )
    if neck is None:
        return
    where = f"division.neck_radius = {fmt_value(neck)}"
    if data["model"] == "axisymmetric":
        return  # the meridian's cut: _check_axisymmetric_division
    rem = data["mesh"].get("remesh") or {}
    if rem.get("min_angle") is None:
        raise SceneError(f"{where} needs remeshing (mesh.remesh.min_angle): the daughters are remeshed after the cut")
    formulation = data["numerics"]["formulation"]
    weight = division.get("implicit_tension_weight")
    if weight is not None and "implicit_tension_weight" not in FORMULATIONS[formulation].keys:
        weighted = " or ".join(n for n, f in FORMULATIONS.items() if "implicit_tension_weight" in f.keys)
        raise SceneError(
            f"division.implicit_tension_weight = {fmt_value(weight)}: numerics.formulation = {formulation} has no "
            f"weight on its semi-implicit tension ({weighted} only); remove it"
        )
    if formulation not in ("rayleigh_p1", "rayleigh_p2"):
        raise SceneError(
            f"{where}: numerics.formulation = {formulation} cannot be cut yet; use rayleigh_p1 or rayleigh_p2"
        )
    if data["mesh"]["motion"] not in ("normal", "lagrangian"):
        raise SceneError(f"{where}: mesh.motion = {data['mesh']['motion']} is not split by body; use normal")
    if "fluids" in data["effects"]:
        raise SceneError(f"{where}: with the effect 'fluids' the daughters interact; remove one of the two")
    stop = (data.get("time") or {}).get("stop_neck")
    if stop is not None and stop >= neck:
        raise SceneError(f"{where}: time.stop_neck = {fmt_value(stop)} would stop the run before the cut")
    h_min = rem.get("h_min")
    if h_min is None and data["mesh"]["file"] is None:
        n, radius = data["mesh"]["nodes"], data["mesh"]["radius"]
        h_min = radius * math.sqrt(8.0 * math.pi / (math.sqrt(3.0) * n)) / H_MIN_DIVISOR  # the icosphere's mean edge
    if h_min is not None and neck < DIVISION_MIN_EDGES * h_min:
        raise SceneError(
            f"{where} is below what the mesh resolves: at least {DIVISION_MIN_EDGES:g} times the smallest edge "
            f"length h_min = {h_min:.3g} ({DIVISION_MIN_EDGES * h_min:.3g} R0)"
        )


def _check_multistep(data: dict) -> None:
    """``bdf2`` and ``bdf3`` (the ``dense`` schemes: a tolerance and a one-step start): their
    semi-implicit tension only with the formulation that implements it, a tolerance the solves can
    honour, a start step within the largest step. Only for a 3D run that evolves its shape (the
    axisymmetric model has its own integrator)."""
    time = data.get("time") or {}
    scheme = SCHEMES.get(time.get("scheme", "euler"))
    evolves = data.get("model", "3d") == "3d" and "shape_evolution" in data["effects"]
    if scheme is None or not scheme.dense or not evolves:
        return
    name = time["scheme"]
    formulation = data["numerics"]["formulation"]
    if not FORMULATIONS[formulation].centred_implicit and time.get("implicit_tension") is True:
        raise SceneError(
            f"time.scheme = {name} with time.implicit_tension = true centres the semi-implicit tension on the "
            f"last step's rate, which numerics.formulation = {formulation} does not implement: use "
            f"rayleigh_p1, time.implicit_tension: auto ({name} then runs explicit), or time.scheme = euler"
        )
    rtol = solver_rtol(data)
    tol, dt_max = scheme.resolve_step_control(time.get("tol"), time.get("dt_max"), step_control_nodes(data))
    if tol < 10.0 * rtol:
        raise SceneError(
            f"time.tol = {fmt_value(tol)} is below what {name} can honour: each solve leaves a relative "
            f"error solver.rtol = {fmt_value(rtol)} in the velocity; set time.tol >= {fmt_value(10.0 * rtol)}"
        )
    if time["dt"] > dt_max:
        raise SceneError(
            f"time.dt = {fmt_value(time['dt'])} ({name}'s first, one-step Euler step) is larger than time.dt_max = "
            f"{fmt_value(dt_max)}: set time.dt <= time.dt_max"
        )


def _check_patterns(patterns: list, seen: set[str], has_fields: bool = False) -> None:
    """Patterns exactly when the active stress is on; pattern details the schema cannot say."""
    if patterns and "active_stress" not in seen:
        raise SceneError(
            f"active_stress has {len(patterns)} pattern(s) but the effect 'active_stress' is off: "
            "add it to effects or set active_stress: []"
        )
    if not patterns and "active_stress" in seen and not has_fields:
        raise SceneError(
            "the effect 'active_stress' is on but the active_stress list is empty: "
            "add a pattern or remove 'active_stress' from effects"
        )
    for i, pattern in enumerate(patterns):
        if pattern["type"] == "harmonics":
            for j, term in enumerate(pattern["terms"]):
                if abs(term["m"]) > term["l"]:
                    raise SceneError(f"active_stress.{i}.terms.{j}.m = {term['m']} but |m| must be <= l = {term['l']}")
        elif pattern["type"] == "ring":
            if not any(pattern["axis"]):
                raise SceneError(f"active_stress.{i}.axis must not be all zero, got {pattern['axis']}")


def _check_axisymmetric(data: dict) -> None:
    """``model: axisymmetric`` needs a surface of revolution about z and a tension that does not
    vary about z; the first thing that breaks the symmetry is named. (A ``python`` pattern is
    checked when it is evaluated: :func:`cortex_ti.axisymmetric.run.axisymmetric_tension`.)"""
    why = "model = axisymmetric needs a scene symmetric about the z axis"
    mesh = data["mesh"]
    ax = data["axisymmetric"]
    if ax["points"] == "adaptive" and ax["neck_resolution"] > 0:
        raise SceneError(
            f"axisymmetric.neck_resolution = {fmt_value(ax['neck_resolution'])} weights the arc-length points; "
            "axisymmetric.points = adaptive places its own: set neck_resolution: 0 or points: arclength"
        )
    stop = ax["stop_neck"]
    if stop >= mesh["radius"]:
        raise SceneError(
            f"axisymmetric.stop_neck = {fmt_value(stop)} must be smaller than mesh.radius = "
            f"{fmt_value(mesh['radius'])}: the run would stop at its first step"
        )
    if mesh["file"] is not None:
        raise SceneError(
            f"{why}: mesh.file = '{mesh['file']}' is a user's mesh; the axisymmetric model starts from "
            "the sphere of radius mesh.radius (set mesh.nodes instead, it is not used)"
        )
    if mesh["shear"]:
        raise SceneError(
            f"{why}: mesh.shear = {fmt_value(mesh['shear'])} tilts the shape (set it to 0 or use model: 3d)"
        )
    if mesh["transform"] is not None:
        raise SceneError(f"{why}: mesh.transform deforms the initial sphere (remove it or use model: 3d)")
    myosin = (data["fields"] or {}).get("myosin")
    if myosin is not None and (myosin.get("noise") or {}).get("amplitude", 0.0) > 0:
        raise SceneError(
            f"{why}: fields.myosin.noise draws an independent number at every node of a 3D mesh, which "
            "varies about z (set fields.myosin.noise.amplitude: 0, or use model: 3d)"
        )
    _check_axisymmetric_patterns(data["active_stress"], "active_stress", why)
    if myosin is not None:
        _check_axisymmetric_patterns(myosin.get("initial") or [], "fields.myosin.initial", why)


def _check_axisymmetric_division(data: dict) -> None:
    """``division.neck_radius`` on the meridian: below the radius, at or above what its points
    resolve (:func:`axisymmetric_neck_floor`), and without a myosin field (not moved across a cut yet)."""
    neck = (data.get("division") or {}).get("neck_radius")
    if neck is None:
        return
    n = data["axisymmetric"]["n"]
    if neck >= data["mesh"]["radius"]:
        raise SceneError(
            f"division.neck_radius = {fmt_value(neck)} must be smaller than mesh.radius = "
            f"{fmt_value(data['mesh']['radius'])}"
        )
    floor = axisymmetric_neck_floor(n)
    if neck < floor:
        raise SceneError(
            f"division.neck_radius = {fmt_value(neck)} is below what axisymmetric.n = {n} points resolve "
            f"({floor:.3g} R0 = {AXISYMMETRIC_NECK_RESOLUTION:g} / n^2): raise it or axisymmetric.n"
        )
    if (data["fields"] or {}).get("myosin") is not None:
        raise SceneError(
            "division.neck_radius with fields.myosin: the axisymmetric model does not move a myosin across a cut yet"
        )


def _check_axisymmetric_patterns(patterns: list, where: str, why: str) -> None:
    """The patterns under ``where`` (``active_stress``, ``fields.myosin.initial``) must not vary
    about z; the first that does is named."""
    for i, pattern in enumerate(patterns):
        kind = pattern["type"]
        if kind == "field":
            raise SceneError(
                f"{why}: {where}.{i} is a field pattern, whose values exist only at the nodes of a "
                "3D mesh (write the tension as a python pattern of the polar angle, or use model: 3d)"
            )
        if kind == "fold" and pattern["sigma_phi"] != 0:
            raise SceneError(
                f"{why}: {where}.{i} is a fold pattern, which varies about its axis "
                f"(sigma_phi = {fmt_value(pattern['sigma_phi'])})"
            )
        if kind == "harmonics":
            for j, term in enumerate(pattern["terms"]):
                if term["m"] != 0 and term["coeff"] != 0:
                    raise SceneError(
                        f"{why}: {where}.{i}.terms.{j} has m = {term['m']}, which varies about z "
                        "(only m = 0 harmonics are axisymmetric)"
                    )
        axis = pattern.get("axis")
        if axis is not None and (axis[0] != 0 or axis[1] != 0):
            raise SceneError(
                f"{why}: {where}.{i}.axis = {axis} is not the z axis (rotate the scene so that "
                "the pattern's axis is [0, 0, 1], or use model: 3d)"
            )
