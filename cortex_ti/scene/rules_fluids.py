"""The scene rules of the effect ``fluids`` (docs/guide/fluids.md): its keys, the 3D ``rayleigh_p1``
dynamics or the axisymmetric model's, the solve (``fluid.solver``) and the mesh the dense method can
hold. Called by :func:`cortex_ti.scene.rules.check_rules`, the one place scenes are checked."""

from __future__ import annotations

import importlib.util

from ..errors import SceneError
from ..physics.fluids_fast import FMM_MISSING
from ..physics.model import resolve_fluid_solver
from .schema import fmt_value

#: The most nodes a scene with the effect ``fluids`` and ``fluid.solver: dense`` may have (the matrix-free
#: solvers have no limit): its boundary-integral map is dense, (3N)^2
#: doubles built and factorised on every solve. Measured (docs/validation/fluids.md, "Cost of a step"):
#: at 2562 nodes 1.8 GB and 29 CPU seconds per step on one thread; 10242 nodes would need 16 times the
#: memory (~28 GB, more than this 24 GB machine) and 64 times the time (~30 minutes a step).
FLUIDS_MAX_NODES = 2562

def check_fluids(data: dict, seen: set[str]) -> None:
    """The effect ``fluids`` (docs/guide/fluids.md): its keys only with it; a positive medium and a
    cytoplasm of viscosity >= 0; the far field's values only with their type; the 3D ``rayleigh_p1``
    dynamics (or the axisymmetric model's, forces along the axis) with its volume constraint, no gauge,
    no remeshing, a mesh the dense method can hold."""
    fluid = data["fluid"]
    far = fluid["far_field"]
    if "fluids" not in seen:
        changed = (
            [f"fluid.{k} = {fmt_value(fluid[k])}" for k, d in (("inner", 1.0), ("outer", 1.0)) if fluid[k] != d]
            + (["fluid.body_force"] if any(fluid["body_force"]) else [])
            + ([f"fluid.far_field.type = {far['type']}"] if far["type"] != "none" else [])
        )
        if changed:
            raise SceneError(f"{changed[0]} but the effect 'fluids' is off: add it to effects or remove the key")
        return
    axisymmetric = data["model"] == "axisymmetric"
    if axisymmetric:
        _check_axisymmetric_fluids(fluid, seen)
    formulation = data["numerics"]["formulation"]
    if formulation != "rayleigh_p1" and not axisymmetric:
        raise SceneError(
            f"the effect 'fluids' with numerics.formulation = {formulation}: the fluids' dissipation is a term of "
            "the Rayleighian on flat triangles only; use numerics.formulation: rayleigh_p1"
        )
    if not fluid["outer"] > 0:
        raise SceneError(
            f"fluid.outer = {fmt_value(fluid['outer'])} must be > 0: the medium's drag is what fixes the cell's "
            "rigid motions (for a cortex in vacuum remove the effect 'fluids')"
        )
    if fluid["inner"] < 0:
        raise SceneError(f"fluid.inner = {fmt_value(fluid['inner'])} must be >= 0 (a viscosity)")
    if far["type"] != "uniform" and any(far["velocity"]):
        raise SceneError(
            f"fluid.far_field.velocity is the velocity of type uniform, not of type {far['type']}: remove it or set "
            "fluid.far_field.type: uniform"
        )
    if far["type"] not in ("shear", "extension") and far["rate"] != 0:
        raise SceneError(
            f"fluid.far_field.rate = {fmt_value(far['rate'])} is the rate of type shear or extension, not of type "
            f"{far['type']}: remove it or set fluid.far_field.type"
        )
    if "incompressibility" not in seen:
        raise SceneError(
            "the effect 'fluids' needs the effect 'incompressibility': the cytoplasm is an incompressible fluid, so "
            "the enclosed volume is kept"
        )
    if data["translation"] == "centroid":
        raise SceneError(
            "translation = centroid with the effect 'fluids': the medium fixes the cell's translation and rotation, "
            "a gauge would contradict it; remove translation (no gauge is applied with fluids)"
        )
    if (data["mesh"].get("remesh") or {}).get("min_angle") is not None:
        raise SceneError(
            "mesh.remesh with the effect 'fluids' is not implemented (the remeshing's settling steps and the "
            "dense operator on a changing node count are untested): remove mesh.remesh"
        )
    nodes = data["mesh"].get("nodes") if data["mesh"].get("file") is None else None
    if axisymmetric:
        return  # the meridian's own operator: fluid.solver chooses among the 3D solves only
    solver = resolve_fluid_solver(fluid["solver"], nodes, fluid["inner"], fluid["outer"])
    if solver in ("fmm", "direct"):
        if solver == "fmm" and fluid["inner"] != fluid["outer"]:
            raise SceneError(
                f"fluid.solver = fmm with fluid.inner = {fmt_value(fluid['inner'])} != fluid.outer = "
                f"{fmt_value(fluid['outer'])}: the FMM solve has the single layer only (equal viscosities); "
                "use fluid.solver: direct"
            )
        if solver == "fmm" and importlib.util.find_spec("fmm3dpy") is None:
            raise SceneError(FMM_MISSING)
    elif nodes is not None and nodes > FLUIDS_MAX_NODES:
        raise SceneError(fluids_size_message(nodes))

def _check_axisymmetric_fluids(fluid: dict, seen: set[str]) -> None:
    """The fluids of ``model: axisymmetric`` (cortex_ti/axisymmetric/fluids.py): forces from outside along
    the axis only, and a shape evolution (the static meridian solve has no fluids)."""
    far = fluid["far_field"]
    if far["type"] == "shear":
        raise SceneError(
            "fluid.far_field.type = shear with model = axisymmetric: a shear is not axisymmetric, use model: 3d"
        )
    if any(fluid["body_force"][:2]):
        raise SceneError(
            f"fluid.body_force = {fmt_value(fluid['body_force'])} with model = axisymmetric: it must point along z"
        )
    if far["type"] == "uniform" and any(far["velocity"][:2]):
        raise SceneError(
            f"fluid.far_field.velocity = {fmt_value(far['velocity'])} with model = axisymmetric: it must point along z"
        )
    if "shape_evolution" not in seen:
        raise SceneError(
            "the effect 'fluids' with model = axisymmetric needs the effect 'shape_evolution' (the static meridian "
            "solve has no fluids; cortex_ti.axisymmetric.stokes.with_fluids is the static coupling)"
        )

def fluids_size_message(nodes: int) -> str:
    """Why a mesh of ``nodes`` nodes is refused with the effect ``fluids`` (also for a mesh file)."""
    return (
        f"mesh of {nodes} nodes with the effect 'fluids': the dense boundary-integral method holds at most "
        f"{FLUIDS_MAX_NODES} nodes (its (3N)^2 matrices are built and factorised on every solve: 1.8 GB and "
        "30 s per step at 2562 nodes, 16 times the memory and 64 times the time at 10242): set fluid.solver: fmm "
        "(docs/guide/fluids.md)"
    )
