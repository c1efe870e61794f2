"""A scene run with ``model: axisymmetric``: its tension as a function of the polar angle, the
spectral meridian solver, and a trajectory file in the layout of a 3D run.

The file holds the surface of revolution as points and triangles (the nodes are material
points, like the 3D code's: they move with the normal velocity), the velocity, active tension,
pressure and normals at those points, the same per-frame diagnostics as a 3D run (the pole and
furrow radii, volume and area from the spectral solution itself, the others measured on the
surface), and the solution along the meridian (dimension ``meridian``, north to south:
``meridian_label`` = theta0, ``meridian_r``, ``meridian_z``, ``meridian_s`` the arc length from
the north pole, ``meridian_v_s`` along the meridian from north to south, ``meridian_v_n``
outward, ``meridian_zeta``), so ``cortex-ti plot``, ``export`` and the workflow's stores read it
as any trajectory.
"""

from __future__ import annotations

import logging
import math
import time
from pathlib import Path

import numpy as np

from ..about import provenance
from ..analysis.diagnostics import DIAGNOSTIC_ATTRS, NECK_ATTRS, frame_diagnostics
from ..errors import CortexError, SceneError, SolverError, check_interrupted
from ..io.claim import check_output, claim_output
from ..io.trajectory import TrajectoryWriter, last_frame, partial_path
from ..physics.patterns import evaluate_active_stress
from ..scene.loader import Scene
from ..scene.settings import RunSettings
from .balance import static_flow
from .dynamics import STRETCH_LIMIT, STRETCH_LIMITS, first_unresolved, label_matters
from .evolve import StepFailed, simulate
from .fluids import axisymmetric_fluids
from .myosin import Myosin
from .result import revolve
from .rigidity import rigidity
from .run_checks import RunChecks

log = logging.getLogger(__name__)

__all__ = [
    "axisymmetric_tension",
    "axisymmetric_myosin",
    "viscosities",
    "evolution_options",
    "AxisymmetricRun",
    "MERIDIAN_VARIABLES",
]

#: The meridian arrays of an axisymmetric trajectory (dims: time, meridian).
MERIDIAN_VARIABLES = {
    "meridian_label": {
        "units": "rad",
        "long_name": "material label: the polar angle theta0 of the point on the initial sphere",
    },
    "meridian_r": {"units": "R0", "long_name": "distance from the axis along the meridian"},
    "meridian_z": {"units": "R0", "long_name": "height along the meridian"},
    "meridian_s": {"units": "R0", "long_name": "arc length from the north pole"},
    "meridian_v_s": {"units": "R0/t_a", "long_name": "tangential velocity along the meridian, north to south"},
    "meridian_v_n": {"units": "R0/t_a", "long_name": "normal velocity (outward)"},
    "meridian_zeta": {"units": "zeta_0", "long_name": "active tension"},
}
#: A dynamic run's per-frame material stretch (:attr:`SimulationResult.stretch
#: <cortex_ti.axisymmetric.evolve.SimulationResult>`).
MATERIAL_STRETCH_ATTRS = {
    "units": "1",
    "long_name": "material stretch: max/min over the meridian of |dX/du| (u the material label)",
    "description": f"inf once the label map has folded; above {STRETCH_LIMIT:g} arc-length points do not resolve it "
    "(the neck radius stops converging in axisymmetric.n, docs/validation/constriction.md)",
}
#: A dynamic run's smallest principal in-plane stress per frame (:meth:`SimulationResult.principal_stress
#: <cortex_ti.axisymmetric.evolve.SimulationResult.principal_stress>`).
MIN_STRESS_ATTRS = {
    "units": "zeta_0",
    "long_name": "smallest principal in-plane stress over the meridian (tension plus viscous)",
    "description": "below 0 the cortex is compressed: without bending resistance its short waves grow, and the "
    "run stops converging in axisymmetric.n (docs/validation/constriction.md)",
}
#: Whether the frame's label map is resolved by the run's points (1) or not (0, from the first
#: frame past its parametrisation's limit on; the study leaves such frames out of comparisons).
LABEL_RESOLVED_ATTRS = {
    "units": "1",
    "long_name": "the label map is resolved (1) or not (0)",
    "description": "0 from the first frame whose material stretch passes the parametrisation's limit "
    "(arc-length points: "
    f"{STRETCH_LIMIT:g}; adaptive points: none) or whose label map has folded; 1 before it, and always "
    "for points that carry no label (docs/validation/constriction.md)",
}
#: With ``fields.myosin``: its density along the meridian and at the points (the 3D variable).
MYOSIN_VARIABLES = {
    "meridian_myosin": (("time", "meridian"), {"units": "c0 units", "long_name": "myosin density along the meridian"}),
    "myosin": (
        ("time", "node"),
        {
            "units": "c0 units (amount per R0^2)",
            "long_name": "myosin density: conserved, carried by the full velocity, diffusing, turning over",
        },
    ),
    "myosin_total": (("time",), {"units": "c0 R0^2", "long_name": "total myosin, oint c dA (spectral quadrature)"}),
}
_EXACT = ("pole_radius", "furrow_radius", "volume", "area")
#: The integrator's state written with every frame of a dynamic run, from which ``--resume`` continues.
STATE_VAR = "axisymmetric_state"
STATE_ATTRS = {
    "units": "R0",
    "long_name": "the integrator's state at the frame (collocation points' r and z, and labels and myosin content "
    "where the run carries them): --resume continues from it",
}


def axisymmetric_tension(settings: RunSettings):
    """The scene's active tension as a function of the polar angle on its initial sphere,
    ``zeta(theta0)`` (vectorised); a python pattern that varies about z is refused here, naming it."""
    return _of_polar_angle(settings, list(settings.patterns), "active_stress")


def axisymmetric_myosin(settings: RunSettings) -> Myosin | None:
    """The scene's ``fields.myosin`` for the meridian solver (None without it): its initial
    density ``c0 +`` the patterns of ``fields.myosin.initial`` as a function of the polar angle,
    refused (naming it) if one varies about z."""
    f = settings.field("myosin")
    if f is None:
        return None
    extra = _of_polar_angle(settings, list(f["initial"]), "fields.myosin.initial")
    c0 = float(f["c0"])
    t = f["tension"]
    return Myosin(
        c0=c0,
        diffusion=float(f["diffusion"]),
        turnover=float(f["turnover"]),
        law=t["law"],
        zeta0=float(t["zeta0"]),
        gamma=float(t["gamma"]),
        initial=lambda th: c0 + extra(th),
    )


def _of_polar_angle(settings: RunSettings, patterns: list, where: str):
    """The sum of ``patterns`` on the initial sphere as a function of the polar angle (vectorised),
    checked not to vary about z at 11 azimuths."""
    radius = settings.mesh.radius
    if not patterns:
        return lambda theta: np.zeros(np.shape(theta))

    def at(theta, phi=0.0):
        th = np.asarray(theta, dtype=float)
        pts = radius * np.stack([np.sin(th) * np.cos(phi), np.sin(th) * np.sin(phi), np.cos(th) + 0.0 * th], -1)
        return evaluate_active_stress(pts.reshape(-1, 3), patterns).reshape(th.shape)

    theta = np.linspace(0.0, np.pi, 181)
    ref = at(theta)
    scale = max(1.0, float(np.max(np.abs(ref))))
    for phi in np.linspace(0.0, 2.0 * np.pi, 13)[1:-1]:
        dev = float(np.max(np.abs(at(theta, phi) - ref)))
        if dev > 1e-10 * scale:
            which = ", ".join(f"{where}.{i} ({p['type']})" for i, p in enumerate(patterns))
            raise SceneError(
                f"scene '{settings.name}': model = axisymmetric needs a tension that does not vary about "
                f"the z axis, but {which} changes by {dev:.3g} between azimuths 0 and {phi:.3g} rad"
            )
    return lambda th: at(th)


#: The solver's name for each way of fixing the translation (scene key ``translation``).
GAUGES = {"mean_velocity": "velocity", "centroid": "centroid"}


def evolution_options(settings: RunSettings) -> dict:
    """The shape evolution's keywords from the scene: the tension carried by the material or glued to the
    normally moving points, the meridian points (normally moving, equally spaced in arc length, weighted by
    curvature with ``neck_resolution``, or adaptive), the neck stop and ``axisymmetric.bending_form``."""
    a = settings.axisymmetric
    if a.points == "adaptive":
        parametrization = "adaptive"
    else:
        parametrization = "arclength" if a.neck_resolution > 0 or a.points == "arclength" else "auto"
    return dict(
        tension="material" if settings.tension_carried else "nodes",
        parametrization=parametrization,
        monitor=a.neck_resolution,
        stop_neck=_stop_neck(settings),
        bending_form=a.bending_form,
    )


def _stop_neck(settings: RunSettings) -> float | None:
    """Where the meridian run stops: the larger of ``time.stop_neck`` (a scene's request) and
    ``axisymmetric.stop_neck`` (the model's floor); None when neither lies below the radius. With
    ``division.neck_radius`` the floor is that radius (the cut; a scene run's trajectory ends there,
    the daughters are :func:`cortex_ti.axisymmetric.division.simulate_division`'s)."""
    if settings.division_neck is not None:  # the cut's radius replaces the floor (it may lie below it)
        return max(settings.division_neck, settings.time.stop_neck or 0.0)
    stop = max(settings.axisymmetric.stop_neck, settings.time.stop_neck or 0.0)
    return stop if stop < settings.mesh.radius else None


def viscosities(settings: RunSettings) -> dict:
    """The viscous coefficients as the solver's keywords (bending ones 0 without the effect)."""
    v = settings.viscosity
    return dict(eta_s=v.shear, eta_b=v.bulk, eta_bar=v.bending, eta_bar_b=v.bending_bulk)


class AxisymmetricRun(RunChecks):
    """A scene with ``model: axisymmetric`` ready to run (the counterpart of
    :class:`~cortex_ti.simulation.core.Simulation`)."""

    def __init__(self, scene: Scene):
        if scene.settings.model != "axisymmetric":
            raise SceneError(f"scene '{scene.name}' has model = {scene.settings.model}, not axisymmetric")
        self.scene = scene
        self.settings = scene.settings
        self.zeta = axisymmetric_tension(self.settings)
        self.myosin = axisymmetric_myosin(self.settings)
        self.result = None
        self.seconds = 0.0
        self.resumed_at_end = False

    # ------------------------------------------------------------------------------- solving
    def solve(self):
        """The static flow on the initial sphere (:class:`~cortex_ti.axisymmetric.balance.StaticResult`)."""
        s = self.settings
        zeta, my = self.zeta, self.myosin
        if my is not None:  # the tension of the initial density on the sphere

            def zeta(th, base=self.zeta):
                return base(th) + my.tension(my.density(th))

        try:
            return static_flow(
                zeta,
                **viscosities(s),
                radius=s.mesh.radius,
                n=2 * s.axisymmetric.n,
                fixed_normal=s.has("fixed_normal_velocity"),
                gauge=GAUGES[s.translation],
                **rigidity(s),
            )
        except ValueError as exc:
            raise CortexError(f"scene '{s.name}', axisymmetric model: {exc}") from None

    def simulate(self, on_save=None, start=None):
        """The shape evolution to ``time.t_end`` with frames every ``time.save_every`` and at
        ``time.save_times`` (:class:`~cortex_ti.axisymmetric.evolve.SimulationResult`); ``on_save``
        and ``start`` as in :func:`~cortex_ti.axisymmetric.evolve.simulate` (each frame as it comes;
        continue from an earlier frame's state)."""
        s = self.settings
        st = s.time
        times = self._save_times()
        try:
            res = simulate(
                self.zeta,
                **viscosities(s),
                radius=s.mesh.radius,
                t_end=st.t_end,
                save_times=times,
                n=s.axisymmetric.n,
                rtol=s.axisymmetric.rtol,
                interpolate=True,
                gauge=GAUGES[s.translation],
                myosin=self.myosin,
                on_save=on_save,
                start=start,
                fluids=axisymmetric_fluids(s.fluid),
                **evolution_options(s),
                **rigidity(s),
            )
        except StepFailed as exc:
            self.result = exc.result  # its frames are written, then the run fails (run)
            self._warn_unresolved(exc.result)
            self._warn_compressed(exc.result)
            self._warn_negative_myosin(exc.result)
            return exc.result
        except ValueError as exc:
            raise CortexError(f"scene '{s.name}', axisymmetric model: {exc}") from None
        self._warn_unresolved(res)
        self._warn_compressed(res)
        self._warn_negative_myosin(res)
        if s.division_neck is not None and res.stopped.startswith("neck"):
            msg = "division.neck_radius reached, %s: the file ends at the cut (daughters: division.simulate_division)"
            log.warning("%s (axisymmetric): " + msg, s.name, res.stopped)
        elif res.stopped != "t_end":
            log.warning("%s (axisymmetric): stopped early, %s; the frames so far are kept", s.name, res.stopped)
        return res

    def _unresolved(self, res) -> int | None:
        """The first frame whose label map this run's points no longer resolve (None: all are, or
        the points carry no label): past its parametrisation's
        :data:`~cortex_ti.axisymmetric.evolve.STRETCH_LIMITS`, or folded. A tension that does not
        depend on the label (a myosin's alone) makes the label a passive marker: None."""
        limit = STRETCH_LIMITS.get(evolution_options(self.settings)["parametrization"])
        if limit is None or not label_matters(self.zeta):
            return None
        return first_unresolved(res.stretch, limit)

    def _warn_unresolved(self, res) -> None:
        """One line when the points carry a label map they no longer resolve (:meth:`_unresolved`):
        from that frame on the run's numbers stop converging with n."""
        k = self._unresolved(res)
        if k is not None:
            log.warning(
                "%s (axisymmetric): from t = %.4g (neck %.4g R0) the label map of the %s points is %s: the "
                "frames after it are not converged in axisymmetric.n",
                self.settings.name,
                res.t[k],
                res.furrow_radius[k],
                evolution_options(self.settings)["parametrization"],
                "folded" if not np.isfinite(res.stretch[k]) else f"stretched {res.stretch[k]:.3g} > {STRETCH_LIMIT:g}",
            )

    # ------------------------------------------------------------------------------- writing
    def run(self, output: str | Path, resume: bool = False, progress: bool = True, force: bool = False) -> Path:
        """Solve (static scene) or evolve (``shape_evolution``) and write the trajectory atomically.

        A dynamic run writes each frame to ``<output>.partial`` as the integrator reaches it
        (flushed, with the integrator's state ``axisymmetric_state``), so an interrupted or killed
        run keeps its frames; ``resume`` continues from the last of them (the integrator starts
        afresh there, so the continued run agrees with an uninterrupted one to the integrator's
        tolerance ``axisymmetric.rtol``, not to round-off). A partial file without that state (an
        older one) is started over; a static run (one solve) always starts over. What is already at
        ``output`` is refused as the command line refuses it (:func:`cortex_ti.io.claim.check_output`)
        unless ``resume`` or ``force``."""
        output = Path(output)
        with claim_output(output):
            check_output(output, resume, force)
            if self.settings.dynamic:
                return self._run_dynamic(output, resume, force)
            return self._run_static(output, replace=force or resume)

    def _run_static(self, output: Path, replace: bool) -> Path:
        t0 = time.perf_counter()
        frames = list(self._static_frames())
        self.seconds = time.perf_counter() - t0
        first = frames[0][1]
        writer = TrajectoryWriter(
            output,
            first["triangles"],
            len(first["points"]),
            self._attrs(),
            extra_vars=self._extra_vars(),
            extra_dims={"meridian": len(first["meridian_label"])},
            force=replace,
        )
        with writer:
            for t, f in frames:
                writer.append(
                    t, f["points"], f["velocity"], f["zeta"], f["pressure"], **{k: f[k] for k in self._extra_vars()}
                )
        log.info("%s (axisymmetric): static flow in %.2f s", self.settings.name, self.seconds)
        return output

    def _save_times(self) -> np.ndarray:
        st = self.settings.time
        n_frames = int(math.floor(st.t_end / st.save_every + 1e-9))
        times = np.concatenate([np.arange(n_frames + 1) * st.save_every, st.save_times, [st.t_end]])
        return np.unique(np.round(np.minimum(times, st.t_end), 12))

    def _resume_from(self, output: Path):
        """``(t, y, frames, label resolved)`` of the last frame of ``<output>.partial``, or None."""
        partial = partial_path(output)
        if not partial.exists():
            log.info("nothing to resume at %s; starting from t = 0", partial)
            return None
        last = last_frame(partial)
        y = last["extra"].get(STATE_VAR)
        if not last["n_frames"] or y is None:
            log.info("%s holds no frame with the integrator's state; starting from t = 0", partial)
            return None
        resolved = last["extra"].get("label_resolved")
        return float(last["time"]), np.asarray(y, dtype=float), int(last["n_frames"]), resolved

    def _run_dynamic(self, output: Path, resume: bool, force: bool = False) -> Path:
        s = self.settings
        times = self._save_times()
        labels = np.linspace(0.0, np.pi, s.axisymmetric.surface_points)
        limit = STRETCH_LIMITS.get(evolution_options(s)["parametrization"]) if label_matters(self.zeta) else None
        start = self._resume_from(output) if resume else None
        box = {"writer": None, "frames": 0, "t": 0.0, "unresolved": False}
        if start is not None:
            box["frames"], box["t"] = start[2], start[0]
            box["unresolved"] = start[3] is not None and float(start[3]) == 0.0
            log.info("resuming %s at t = %.4g (frame %d)", output, start[0], start[2])

        def on_save(res, y):
            check_interrupted()
            t = float(res.t[0])
            if limit is not None and first_unresolved(res.stretch, limit) is not None:
                box["unresolved"] = True
            later = times[times > t + 1e-12 * max(1.0, s.time.t_end)]
            dt = float(later[0] - t) if later.size else float(s.time.save_every)
            f = self._dynamic_frame(res, labels, dt, resolved=not box["unresolved"])
            if box["writer"] is None:
                box["writer"] = self._writer(output, y.size, resume=start is not None, force=force)
            extra = {k: f[k] for k in self._extra_vars()}
            box["writer"].append(t, f["points"], f["velocity"], f["zeta"], f["pressure"], **extra, **{STATE_VAR: y})
            box["frames"] += 1
            box["t"] = t

        t0 = time.perf_counter()
        try:
            if start is not None and start[0] >= s.time.t_end - 1e-12 * max(1.0, s.time.t_end):
                res = None  # the partial file reaches t_end: only its rename was missing
                self.resumed_at_end = True
            else:
                res = self.simulate(on_save=on_save, start=None if start is None else start[:2])
            self.result = res
        except BaseException:
            if box["writer"] is not None:
                box["writer"].close_partial()  # the frames so far, for --resume
            raise
        finally:
            self.seconds = time.perf_counter() - t0
        writer = box["writer"]
        if writer is None:  # resumed at the end (killed before the rename): nothing left to compute
            writer = self._writer(output, start[1].size, resume=True, force=force)
        failed = res is not None and res.stopped.startswith("failed: ")
        if failed:  # the frames before the failed step are kept, in the partial file
            kept = writer.close_partial()
            raise SolverError(
                f"scene '{s.name}', axisymmetric model: {res.stopped[8:]}; the "
                f"{box['frames']} frames to t = {box['t']:.6g} before it are kept in {kept}"
            )
        writer.finish()
        log.info("%s (axisymmetric): %d frames to t = %.4g in %.2f s", s.name, box["frames"], box["t"], self.seconds)
        return output

    def _writer(self, output: Path, state_size: int, resume: bool, force: bool = False) -> TrajectoryWriter:
        """The writer of a dynamic run: the revolved surface's triangles (the same in every frame),
        the frame's variables and the integrator's state (``state_size`` numbers)."""
        s = self.settings
        labels = np.linspace(0.0, np.pi, s.axisymmetric.surface_points)
        points, triangles, _ = revolve(np.sin(labels), np.cos(labels), s.axisymmetric.azimuthal_points)
        return TrajectoryWriter(
            output,
            triangles,
            len(points),
            self._attrs(),
            extra_vars={**self._extra_vars(), STATE_VAR: (("time", "state"), STATE_ATTRS)},
            extra_dims={"meridian": len(labels), "state": state_size},
            resume=resume,
            force=force,
        )

    def summary(self) -> dict:
        """What the run took (the cost tables' fields of a 3D run's summary)."""
        s, r = self.settings, self.result
        out = {
            "scene": s.name,
            "model": "axisymmetric",
            "n_nodes": 2 * s.axisymmetric.n,
            "fit": "spectral",
            "solver_backend": "dense LU",
            "effects": sorted(s.effects),
            "implicit_tension": False,
            "fit_residual_weight": 0.0,
        }
        if r is None and s.dynamic and self.resumed_at_end:  # the partial file had reached t_end
            out.update(steps=0, rejected=0, solves=0, t_reached=float(s.time.t_end), stopped="t_end")
        elif r is None or not s.dynamic:
            out.update(steps=0, rejected=0, solves=1, t_reached=0.0, stopped="static")
        else:
            out.update(
                steps=int(r.n_steps),
                rejected=0,
                solves=int(r.n_rhs),
                t_reached=float(r.t[-1]),
                stopped=r.stopped.split(" ")[0] if r.stopped != "t_end" else "t_end",
            )
        out["ms_solve_per_solve"] = 1e3 * self.seconds / max(out["solves"], 1)
        return out

    def _attrs(self) -> dict:
        s = self.settings
        return {
            "scene": self.scene.to_yaml(),
            "effects": ",".join(sorted(s.effects)),
            "model": "axisymmetric",
            "fit_scheme": "spectral",
            "solver_backend": "dense LU",
            "n_meridian_points": 2 * s.axisymmetric.n,
            **provenance(),
        }

    def _extra_vars(self) -> dict:
        out = {"normal": (("time", "node", "xyz"), {"units": "1", "long_name": "outward unit normal at the nodes"})}
        out.update({k: (("time",), v) for k, v in DIAGNOSTIC_ATTRS.items()})
        out.update({k: (("time", "meridian"), v) for k, v in MERIDIAN_VARIABLES.items()})
        if self.myosin is not None:
            out.update(MYOSIN_VARIABLES)
        out.update({k: (("time",), v) for k, v in NECK_ATTRS.items()})
        if self.settings.dynamic:
            out["dt"] = (("time",), {"units": "t_a", "long_name": "time between frames (the Radau steps are adaptive)"})
            out["material_stretch"] = (("time",), MATERIAL_STRETCH_ATTRS)
            out["label_resolved"] = (("time",), LABEL_RESOLVED_ATTRS)
            out["min_stress"] = (("time",), MIN_STRESS_ATTRS)
        return out

    def _static_frames(self):
        s = self.settings
        res = self.solve()
        self.result = res
        theta = np.linspace(0.0, np.pi, s.axisymmetric.surface_points)
        at = res.at(theta)
        e = dict(
            label=theta,
            r=s.mesh.radius * np.sin(theta),
            z=s.mesh.radius * np.cos(theta),
            n_r=np.sin(theta),
            n_z=np.cos(theta),
            v_s=at["v_s"],
            v_n=at["v_n"],
            v_r=at["v_r"],
            v_z=at["v_z"],
            zeta=self.zeta(theta),
        )
        if self.myosin is not None:
            e["c"] = self.myosin.density(theta)
            e["zeta"] = e["zeta"] + self.myosin.tension(e["c"])
        pressure = res.P if s.has("incompressibility") else float("nan")
        exact = {
            "pole_radius": s.mesh.radius,
            "furrow_radius": s.mesh.radius,
            "volume": 4.0 / 3.0 * np.pi * s.mesh.radius**3,
            "area": 4.0 * np.pi * s.mesh.radius**2,
            "neck_radius": float("nan"),  # a sphere has none
        }
        if self.myosin is not None:  # oint c dA on the sphere (Gauss-Legendre in cos(theta))
            x, w = np.polynomial.legendre.leggauss(256)
            exact["myosin_total"] = float(2 * np.pi * s.mesh.radius**2 * (w @ self.myosin.density(np.arccos(x))))
        yield 0.0, self._frame(e, pressure, exact, dt=None)

    def _dynamic_frame(self, res, labels: np.ndarray, dt: float, resolved: bool) -> dict:
        """The frame of a one-frame :class:`~cortex_ti.axisymmetric.evolve.SimulationResult`."""
        s = self.settings
        # the written points: the normally moving ones (the 3D code's nodes) when the meridian
        # points move normally, whatever carries the tension; else the material points
        coordinate = "sigma" if res.params["parametrization"] == "lagrangian" else "label"
        e = res.evaluate(0, labels, coordinate=coordinate)
        pressure = float(res.P[0]) if s.has("incompressibility") else float("nan")
        exact = {k: float(getattr(res, k)[0]) for k in _EXACT}
        neck = float(res.neck_radius[0])
        exact["neck_radius"] = neck if math.isfinite(neck) else float("nan")  # inf there: no neck
        if res.myosin_total is not None:
            exact["myosin_total"] = float(res.myosin_total[0])
        return {
            **self._frame(e, pressure, exact, dt=dt),
            "material_stretch": float(res.stretch[0]),
            "label_resolved": float(resolved),
            "min_stress": float(res.min_stress[0]),
        }

    def _frame(self, e: dict, pressure: float, exact: dict, dt) -> dict:
        """One frame: the meridian values ``e`` revolved about z, with the diagnostics."""
        s = self.settings
        points, triangles, where = revolve(e["r"], e["z"], s.axisymmetric.azimuthal_points)
        j, phi = where[:, 0].astype(int), where[:, 1]
        c, sn = np.cos(phi), np.sin(phi)

        def cartesian(radial, axial):
            return np.stack([radial[j] * c, radial[j] * sn, axial[j]], -1)

        velocity, normal = cartesian(e["v_r"], e["v_z"]), cartesian(e["n_r"], e["n_z"])
        diag = frame_diagnostics(points, triangles, velocity, normal, axis=s.pattern_axis)
        diag.update(exact)
        ds = np.hypot(np.diff(e["r"]), np.diff(e["z"]))
        frame = dict(
            points=points,
            triangles=triangles,
            velocity=velocity,
            zeta=e["zeta"][j],
            pressure=pressure,
            normal=normal,
            meridian_label=e["label"],
            meridian_r=e["r"],
            meridian_z=e["z"],
            meridian_s=np.concatenate([[0.0], np.cumsum(ds)]),
            meridian_v_s=e["v_s"],
            meridian_v_n=e["v_n"],
            meridian_zeta=e["zeta"],
            **({"meridian_myosin": e["c"], "myosin": e["c"][j]} if "c" in e else {}),
            **diag,
        )
        if dt is not None:
            frame["dt"] = dt
        return frame
