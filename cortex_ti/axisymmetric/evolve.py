r"""Shape evolution of the axisymmetric cortex: the material points move with ``v_n n``.

The state is the node positions ``(r, z)`` (``lagrangian``: the nodes are the normally moving
material points, label fixed) or ``(r, z, u)`` (``arclength``: nodes kept equidistant in arc
length, carrying the material label; ``adaptive``: the same, the spacing following a monitor of
curvature, label stretch and tension gradient). The time stepping is scipy's Radau IIA (or BDF) with
error control on the node positions and an exact Jacobian (complex step through one
linearised solve): the normal modes are stiff (rates growing like l^2, bounded by the bending
viscosity), which an L-stable implicit scheme takes in its stride.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.linalg as sla
from scipy.integrate import BDF, Radau

from . import myosin as _my
from .balance import (
    ForceBalance,
    ZetaFn,
    _check_gauge,
    _check_n,
    _check_visc,
    _eval_zeta,
    _is_symmetric,
    _lu,
)
from .myosin import Myosin
from .spectral import Spectral, geometry

__all__ = [
    "SimulationResult",
    "simulate",
    "revolve",
    "full_meridian_dynamics",
    "normal_embedding",
    "STRETCH_LIMIT",
    "first_unresolved",
    "label_matters",
]

ArrayF = np.ndarray

#: The material stretch (max/min of ``|dX/du|`` over the meridian) beyond which the label map is
#: no longer resolved: glued deep rings stop self-converging there (docs/validation/constriction.md:
#: the neck radius agrees between n = 96 and 128 to 1e-8 at a stretch of 3, 1e-5 at 16, 2e-4 at 65,
#: 1e-3 at 480).
STRETCH_LIMIT = 100.0
#: The stretch limit of each parametrisation that carries the label: the adaptive points gather
#: where the label's stretch changes and converge to 1e-9 at stretches of 1e5 (a neck of 0.1 R0),
#: so only a folded map counts (docs/validation/constriction.md, "Adaptive points").
STRETCH_LIMITS = {"arclength": STRETCH_LIMIT, "adaptive": math.inf}

#: The adaptive points (``parametrization='adaptive'``, derivation Sec. 13) equidistribute
#: ``h rho``, ``rho^2 = 1 + ADAPT_CURVATURE^2 (k1^2 + k2^2) + ADAPT_STRETCH^2 (d ln|dX/du| / ds)^2
#: + ADAPT_TENSION^2 (d zeta / ds / range(zeta))^2``: the curvature term (R0) keeps points in a
#: closing neck, the stretch term where the label's rate changes (the flanks of a stretched neck),
#: the tension term where the tension's front steepens. ``1/rho`` is low-pass filtered in sigma
#: (Gaussian, ``exp(-(k ADAPT_WIDTH)^2)`` on mode k) so the spacing never has structure at the
#: grid scale, and the spacing relaxes to its target at ``ADAPT_RATE`` (1/t_a), faster than a
#: neck closes (``|d ln r_neck / dt|`` <= ~3 at amplitude 20). Measured in
#: docs/validation/constriction.md ("Adaptive points").
ADAPT_CURVATURE = 0.5
ADAPT_STRETCH = 0.3
ADAPT_TENSION = 0.6
ADAPT_WIDTH = 0.03
ADAPT_RATE = 20.0


def first_unresolved(stretch: ArrayF, limit: float = STRETCH_LIMIT) -> int | None:
    """The first frame whose material stretch exceeds ``limit`` or whose label map has folded
    (a non-finite stretch), None if there is none.

    >>> first_unresolved(np.array([1.0, 40.0, 150.0, np.inf])), first_unresolved(np.array([1.0, 2.0]))
    (2, None)"""
    bad = np.nonzero(~np.isfinite(stretch) | (np.asarray(stretch) > limit))[0]
    return int(bad[0]) if bad.size else None


def label_matters(zeta: ZetaFn) -> bool:
    """Whether the prescribed tension depends on the material label: not uniform over [0, pi] (to
    1e-12 of its size). A uniform one (a scene whose only pattern is a myosin's) makes the label a
    passive marker, whose stretch says nothing about what the run resolves.

    >>> label_matters(lambda t: 1.0 + 0.0 * t), label_matters(lambda t: 1.0 + 0.1 * np.cos(t) ** 2)
    (False, True)"""
    zr = _eval_zeta(zeta, np.linspace(0.0, np.pi, 1025))
    return float(zr.max() - zr.min()) > 1e-12 * max(1.0, float(np.abs(zr).max()))


class _ZetaSeries:
    """Cosine series of ``zeta(u)`` on [0, pi] (1024 modes): only its derivative is used, for the
    Jacobian of the arc-length mode (the values themselves always come from the user function)."""

    def __init__(self, zeta: ZetaFn, m: int = 1024):
        from scipy.fft import dct

        u = (np.arange(m) + 0.5) * (np.pi / m)
        X = dct(_eval_zeta(zeta, u), type=2)
        c = X / m
        c[0] *= 0.5
        self.c = c
        self.k = np.arange(m, dtype=float)

    def derivative(self, u: ArrayF) -> ArrayF:
        return -(np.sin(np.outer(u, self.k)) * self.k) @ self.c


class _Dynamics:
    """Right-hand side of the shape evolution at the nodes and its exact Jacobian.

    ``lagrangian``: state ``(r, z)`` at fixed labels ``u`` (nodes = material points moving
    with ``v_n n``).  ``arclength``: state ``(r, z, u)`` at computational points ``sigma`` that
    move with ``v_n n + w e_s``, ``w`` chosen so that ``|dX/dsigma|`` stays uniform (= L/pi);
    the material label is carried along, ``du/dt = (w / h) du/dsigma`` (``h = |dX/dsigma|``).
    """

    def __init__(
        self,
        sp: Spectral,
        system: ForceBalance,
        zeta: ZetaFn,
        mode: str,
        relax: float = 1.0,
        carried: bool = False,
        monitor: float = 0.0,
        myosin: Myosin | None = None,
    ):
        self.sp, self.system, self.zeta_fn, self.mode = sp, system, zeta, mode
        self.myosin = myosin
        self.n = sp.n
        self.relax = relax
        self.carried = bool(carried)
        self.monitor = float(monitor)
        # the state carries the material label u(sigma) unless the nodes are the tension's points
        self.labelled = mode != "lagrangian" or self.carried
        # the myosin amount per unit parameter q = c r h follows (r, z) and the labels u
        self.iq = (3 if self.labelled else 2) * self.n
        self.poles = _my.pole_rows(sp) if myosin is not None else None
        self.nrhs = 0
        self.njac = 0
        if mode == "adaptive":
            _, m = sp.waves["E"]
            zr = _eval_zeta(zeta, np.linspace(0.0, np.pi, 1025))
            self.zeta_range = max(float(zr.max() - zr.min()), 1e-3 * max(1.0, float(np.abs(zr).max())))
            # the stretch term resolves the label because the prescribed tension depends on it; a
            # uniform one does not (a myosin ring's), and its points need not follow the label
            self.adapt_stretch = ADAPT_STRETCH if label_matters(zeta) else 0.0
            if myosin is not None:
                # the myosin's tension is not in ``zeta`` (a uniform or absent pattern, whose range is
                # the 1e-3 floor): its scale is the law's tension at c0, else the floor would weigh its
                # gradients a thousandfold and crowd the points (112 s to t = 0.5 for myosin_constriction)
                self.zeta_range = max(self.zeta_range, abs(float(myosin.tension(float(myosin.c0)))))
            self.adapt_filter = sp.B["E"] @ (np.exp(-((m * ADAPT_WIDTH) ** 2))[:, None] * sp.Binv["E"])
        if not self.labelled:
            self.zeta_nodes = _eval_zeta(zeta, sp.u)
        else:
            self.series = _ZetaSeries(zeta)

    def geometry(self, y: ArrayF) -> dict:
        n = self.n
        g = geometry(self.sp, y[..., :n], y[..., n : 2 * n])
        if not self.labelled:
            g["zeta"] = self.zeta_nodes
        else:
            u = y[..., 2 * n : 3 * n]
            g["u"] = u
            if np.iscomplexobj(u):  # complex step: zeta(u + i d) = zeta(u) + i d zeta'(u)
                ur = u.real[0] if u.ndim > 1 else u.real
                g["zeta"] = _eval_zeta(self.zeta_fn, ur) + 1j * u.imag * self.series.derivative(ur)
            else:
                g["zeta"] = _eval_zeta(self.zeta_fn, u)
        if self.myosin is not None:
            g["q"] = y[..., self.iq : self.iq + n]
            g["c"] = g["q"] / (g["r"] * g["h"])
            g["zeta"] = g["zeta"] + self.myosin.tension(g["c"])
        return g

    def solve(self, y: ArrayF) -> tuple[dict, ArrayF, tuple]:
        g = self.geometry(y)
        A, b = self.system.assemble(g)
        lu = _lu(A)
        x = sla.lu_solve(lu, b, check_finite=False)
        return g, x, lu

    def mesh_velocity(self, g: dict, x: ArrayF) -> ArrayF:
        """Tangential velocity ``w`` of the computational points (arc-length and adaptive modes)."""
        sp = self.sp
        vn = x[..., self.n : 2 * self.n]
        a = g["k1"] * vn * g["h"]  # d h / dt at fixed material label, per unit du
        a0 = a @ sp.Binv["E"][0]  # mean over [0, pi]
        h0 = g["h"] @ sp.Binv["E"][0]  # L / pi
        if self.mode == "adaptive":  # equidistribute h * rho: target spacing (L/pi) rho^-1 / <rho^-1>
            q = self.adaptive_spacing(g)
            target = h0[..., None] * q / (q @ sp.Binv["E"][0])[..., None]
        elif self.monitor > 0.0:  # equidistribute h * rho: target spacing (L/pi) rho^-1 / <rho^-1> (Sec. 11)
            q = 1.0 / self.density(g)
            target = h0[..., None] * q / (q @ sp.Binv["E"][0])[..., None]
        else:
            target = h0[..., None]
        rate = ADAPT_RATE if self.mode == "adaptive" else self.relax
        gw = a0[..., None] - a + rate * (target - g["h"])
        return gw @ sp.IE.T

    def density(self, g: dict) -> ArrayF:
        """Node density of the neck-resolving parametrisation: ``rho = sqrt(1 + m^2 (k^2 + u_s^2))``
        with ``k^2 = k1^2 + k2^2``, ``u_s`` the rate of the tension's label along the arc and
        ``m = monitor`` (R0): points gather where the meridian bends or comes close to the axis
        (``k2 = sin(psi)/r``), so a closing neck keeps its share, and where the tension varies fast."""
        rho2 = 1.0 + self.monitor**2 * (g["k1"] ** 2 + g["k2"] ** 2)
        if "u" in g:  # and where the tension's label runs fast along the arc (|du/ds|, 1/R0 on the sphere)
            us = 1.0 + (g["u"] - self.sp.u) @ self.sp.D["O"].T
            rho2 = rho2 + self.monitor**2 * (us / g["h"]) ** 2
        return np.sqrt(rho2)

    def adaptive_spacing(self, g: dict) -> ArrayF:
        """The relative node spacing ``1/rho`` of the adaptive points (see ``ADAPT_CURVATURE``),
        low-pass filtered in sigma; complex-step safe (no abs, no max)."""
        sp = self.sp
        us = 1.0 + (g["u"] - sp.u) @ sp.D["O"].T  # du/dsigma (E)
        uss = us @ sp.D["E"].T  # (O)
        hs = g["h"] @ sp.D["E"].T  # (O)
        gs = (hs / g["h"] - uss / us) / g["h"]  # d ln(h / u_sigma) / ds (O)
        zs = (g["zeta"] @ sp.D["E"].T) / (g["h"] * self.zeta_range)  # (O)
        rho2 = (
            1.0
            + ADAPT_CURVATURE**2 * (g["k1"] ** 2 + g["k2"] ** 2)
            + self.adapt_stretch**2 * gs**2
            + ADAPT_TENSION**2 * zs**2
        )
        q = 1.0 / np.sqrt(rho2)
        return q @ self.adapt_filter.T

    def velocity(self, g: dict, x: ArrayF) -> ArrayF:
        sp, n = self.sp, self.n
        vn = x[..., n : 2 * n]
        dr = -vn * g["zs"]  # v_n sin(psi)
        dz = vn * g["rs"]  # v_n cos(psi)
        out = [dr, dz]
        if self.mode != "lagrangian":
            w = self.mesh_velocity(g, x)
            dr = dr + w * g["rs"]
            dz = dz + w * g["zs"]
            out = [dr, dz]
        else:
            w = 0.0
        if self.labelled:
            # the material label at a node changes as the material passes it: the node moves
            # tangentially with w, the material (carried tension) with v_s, normal-only points with 0
            slip = w - x[..., :n] if self.carried else w
            us = 1.0 + (g["u"] - sp.u) @ sp.D["O"].T
            du = (slip / g["h"] * us) @ sp.FO.T
            out.append(du)
        if self.myosin is not None:
            out.append(_my.rate(sp, self.myosin, g, x[..., :n], w, self.poles))
        if sp.FR is not None:
            out[0] = out[0] @ sp.FR.T
        return np.concatenate(out, axis=-1)

    def rhs(self, t: float, y: ArrayF) -> ArrayF:
        self.nrhs += 1
        g, x, _ = self.solve(y)
        return self.velocity(g, x)

    def jac(self, t: float, y: ArrayF) -> ArrayF:
        """Exact Jacobian by complex-step differentiation through one linearised solve.

        For a perturbation ``i eps e_k`` of the state, ``x(y + i eps e_k) = x0 - i eps A^-1 dR/dy_k``
        to first order (``R(x, y) = A(y) x - b(y)``), so one LU and one batched residual give all
        columns exactly (no truncation error)."""
        self.njac += 1
        g0, x0, lu = self.solve(y)
        m = y.size
        eps = 1e-30
        yc = y[None, :] + 1j * eps * np.eye(m)
        gc = self.geometry(yc)
        res = self.system.residual(np.repeat(x0[None, :], m, axis=0).astype(complex), gc)
        dx = sla.lu_solve(lu, res.imag.T / eps, check_finite=False).T  # A^-1 dR/dy
        xc = x0[None, :] - 1j * eps * dx
        vel = self.velocity(gc, xc)
        return (vel.imag / eps).T


@dataclass
class SimulationResult:
    """Saved states of :func:`simulate`, always on the **full** meridian, ordered from the north
    pole (label 0) to the south pole (label pi).  Arrays with a time axis have shape
    ``(len(t), N)`` with ``N`` the number of nodes on the full meridian.

    ``u`` is the material (Lagrangian) label of each node = the polar angle theta0 of that
    material point on the initial sphere.  In the ``lagrangian`` parametrisation the nodes are
    material points and ``u`` is the same at every time; in ``arclength`` the nodes are
    equidistant in arc length and ``u`` varies.

    Fields: ``r, z`` node positions (R0), ``v_s`` material tangential velocity (along increasing
    u, i.e. north -> south), ``v_n`` (outward), ``v_r, v_z`` Cartesian (cylindrical radial /
    axial) velocity (R0/t_a), ``zeta`` tension at the nodes (zeta(u)), ``P`` pressure difference
    (zeta_0/R0), ``lam`` net axial force multiplier (0 up to discretisation error without
    bending viscosity or with up-down symmetry), ``pole_radius`` (half the pole-to-pole
    distance), ``furrow_radius`` (cylindrical radius in the plane z = z_centroid normal to the
    axis; z_centroid = area centroid, 0 with symmetry), ``volume``, ``area``, ``z_centroid``,
    ``stretch`` (max/min over the meridian of the material stretch |dX/du| / R0: the clustering of
    the normally moving points; inf if the label map has folded, i.e. the material is no longer
    resolved), ``grid_stretch`` (max/min of the node spacing in arc length), ``neck_radius`` (the
    smallest interior local minimum of r; inf without one), ``bending_margin`` (the smallest over
    the nodes of ``2 eta_bar k_i + (eta_bar_b - eta_bar) C``, i = 1, 2: the bending-viscosity
    normal force damps short waves only while it is > 0, derivation Sec. 12; nan without bending
    viscosity), ``min_stress`` (the smallest principal in-plane stress along the meridian,
    :meth:`principal_stress` on 512 points, tension plus
    viscous, as the 3D code's ``surface_stress``: below 0 the cortex is compressed, and without
    bending resistance its short waves grow the faster the shorter, so the run stops converging in
    n). With a myosin field: ``c`` its density at the nodes (c0 units) and
    ``myosin_total`` the amount ``oint c dA`` (None without). ``stopped``: ``'t_end'``, or what
    ended the run early and when (``stop_neck`` reached, or the model ill-posed:
    ``stop_ill_posed``).
    Run statistics: ``wall_time`` (s, integration only), ``n_rhs`` (force-balance solves),
    ``n_steps`` (accepted steps), ``n_jac``, ``n_lu``.
    """

    t: ArrayF
    u: ArrayF
    r: ArrayF
    z: ArrayF
    v_s: ArrayF
    v_n: ArrayF
    v_r: ArrayF
    v_z: ArrayF
    zeta: ArrayF
    P: ArrayF
    lam: ArrayF
    pole_radius: ArrayF
    furrow_radius: ArrayF
    volume: ArrayF
    area: ArrayF
    z_centroid: ArrayF
    stretch: ArrayF
    grid_stretch: ArrayF
    neck_radius: ArrayF
    bending_margin: ArrayF
    wall_time: float
    n_rhs: int
    n_steps: int
    n_jac: int
    n_lu: int
    params: dict
    stopped: str = "t_end"
    c: ArrayF | None = None
    myosin_total: ArrayF | None = None
    _states: list = field(repr=False, default_factory=list)
    _spectral: Spectral | None = field(repr=False, default=None)
    _zeta_fn: ZetaFn | None = field(repr=False, default=None)
    _myosin: Myosin | None = field(repr=False, default=None)

    def index(self, t: float) -> int:
        """Index of the saved time closest to ``t``."""
        return int(np.argmin(np.abs(self.t - t)))

    def _sigma_of_label(self, i: int, lab: ArrayF) -> ArrayF:
        sp, st = self._spectral, self._states[i]
        if st.get("u") is None:
            return lab
        du = st["u"] - sp.u
        grid = np.linspace(0.0, np.pi, 2049)
        ug = grid + sp.evaluate("O", du, grid)
        sig = np.interp(lab, ug, grid)
        for _ in range(6):  # Newton polish on the spectral u(sigma)
            f = sig + sp.evaluate("O", du, sig) - lab
            fp = 1.0 + sp.evaluate("O", du, sig, 1)
            sig = np.clip(sig - f / fp, 0.0, np.pi)
        return sig

    @cached_property
    def min_stress(self) -> ArrayF:
        """Per saved time, the smallest principal in-plane stress along the meridian
        (:meth:`principal_stress` on its default 512 points)."""
        return np.array([float(np.min(self.principal_stress(i))) for i in range(len(self.t))])

    def principal_stress(self, i: int, sigma: ArrayF | None = None) -> ArrayF:
        """The principal in-plane stresses ``(len(sigma), 2)`` (meridional, azimuthal) at saved
        time index ``i`` and computational parameters ``sigma`` (default 512 points over the
        meridian): the tension plus the viscous stress ``2 eta_s e + (eta_b - eta_s) tr(e)``, the
        strain rates ``e_ss = d v_s / ds + k1 v_n``, ``e_phiphi = v_r / r`` (the 3D code's
        ``surface_stress`` on each triangle; derivation, Sec. 14)."""
        sp, st = self._spectral, self._states[i]
        sig = _MARGIN_GRID if sigma is None else np.asarray(sigma, dtype=float)
        e = self.evaluate(i, sig, coordinate="sigma")
        h = np.hypot(sp.evaluate("R", st["r"], sig, 1), sp.evaluate("Z", st["z"], sig, 1))
        ess = sp.evaluate("O", st["v_s"], sig, 1) / h + e["k1"] * e["v_n"]
        epp = np.where(e["r"] > 1e-12, e["v_r"] / np.where(e["r"] > 1e-12, e["r"], 1.0), ess)  # the poles: isotropic
        es, eb = self.params["eta_s"], self.params["eta_b"]
        base = e["zeta"] + (eb - es) * (ess + epp)
        return np.stack([base + 2.0 * es * ess, base + 2.0 * es * epp], axis=-1)

    def evaluate(self, i: int, u: ArrayF, *, coordinate: str = "label") -> dict:
        """Curve and fields at arbitrary parameter values at saved time index ``i``.

        Spectral interpolation of the solved nodal values.  ``coordinate='label'`` (default):
        ``u`` are material labels theta0 in [0, pi]; ``coordinate='sigma'``: ``u`` are values of
        the computational parameter (equal to the label in the lagrangian parametrisation,
        proportional to arc length in the arclength one: best for building a surface).
        Returns a dict of arrays: ``label``, ``sigma``, ``r, z`` (position), ``n_r, n_z`` (outward
        unit normal), ``t_r, t_z`` (unit tangent, north -> south), ``v_s, v_n, v_r, v_z``,
        ``zeta`` (the user's function at the label, plus the myosin's tension), ``k1, k2`` principal
        curvatures (meridional, azimuthal; sphere 1/R); with a myosin field ``c`` its density.
        """
        sp = self._spectral
        st = self._states[i]
        uu = np.atleast_1d(np.asarray(u, dtype=float))
        if np.any(uu < -1e-12) or np.any(uu > np.pi + 1e-12):
            raise ValueError("parameter values must lie in [0, pi]")
        uu = np.clip(uu, 0.0, np.pi)
        if coordinate == "label":
            sig, lab = self._sigma_of_label(i, uu), uu
        elif coordinate == "sigma":
            sig = uu
            lab = uu if st.get("u") is None else uu + sp.evaluate("O", st["u"] - sp.u, uu)
        else:
            raise ValueError("coordinate must be 'label' or 'sigma'")
        r = sp.evaluate("R", st["r"], sig)
        z = sp.evaluate("Z", st["z"], sig)
        ru = sp.evaluate("R", st["r"], sig, 1)
        zu = sp.evaluate("Z", st["z"], sig, 1)
        ruu = sp.evaluate("R", st["r"], sig, 2)
        zuu = sp.evaluate("Z", st["z"], sig, 2)
        h = np.hypot(ru, zu)
        tr, tz = ru / h, zu / h
        k1 = (zu * ruu - ru * zuu) / h**3
        safe = np.where(r > 1e-12, r, 1.0)
        k2 = np.where(r > 1e-12, -tz / safe, k1)  # at a pole the two curvatures agree
        vs = sp.evaluate("O", st["v_s"], sig)
        vn = sp.evaluate("E", st["v_n"], sig)
        nr, nz = -tz, tr
        zeta = _eval_zeta(self._zeta_fn, lab)
        extra = {}
        if st.get("c") is not None:
            extra["c"] = sp.evaluate("E", st["c"], sig)
            zeta = zeta + self._myosin.tension(extra["c"])
        return dict(
            label=lab,
            sigma=sig,
            r=r,
            z=z,
            n_r=nr,
            n_z=nz,
            t_r=tr,
            t_z=tz,
            k1=k1,
            k2=k2,
            v_s=vs,
            v_n=vn,
            v_r=vs * tr + vn * nr,
            v_z=vs * tz + vn * nz,
            zeta=zeta,
            **extra,
        )

    def surface(self, i: int, n_u: int = 65, n_phi: int = 64, *, coordinate: str = "sigma") -> tuple[ArrayF, ArrayF]:
        """Triangulated surface of revolution at saved index ``i``.

        ``n_u`` parameter values equally spaced in [0, pi] (``coordinate`` as in :meth:`evaluate`;
        poles included, one vertex each) times ``n_phi`` azimuthal points.  Returns
        ``points (N, 3)`` (x, y, z; the axis is z) and ``triangles (M, 3)`` oriented with the
        outward normal (counter-clockwise seen from outside).
        """
        if n_u < 3 or n_phi < 3:
            raise ValueError("need n_u >= 3 and n_phi >= 3")
        e = self.evaluate(i, np.linspace(0.0, np.pi, n_u), coordinate=coordinate)
        pts, tri, _ = revolve(e["r"], e["z"], n_phi)
        return pts, tri


def revolve(r: ArrayF, z: ArrayF, n_phi: int) -> tuple[ArrayF, ArrayF, ArrayF]:
    """The surface of revolution of a meridian sampled from the north pole (``r[0] = 0``) to the
    south pole (``r[-1] = 0``): ``points (N, 3)`` (one vertex per pole, ``n_phi`` per ring; the
    axis is z), ``triangles (M, 3)`` oriented with the outward normal, and for each point the
    index of its meridian sample and its azimuth ``phi`` (``(N, 2)``; 0 at the poles)."""
    n_u = len(r)
    phi = np.arange(n_phi) * (2 * np.pi / n_phi)
    rr, zz = np.asarray(r)[1:-1, None], np.asarray(z)[1:-1, None]
    ring_pts = np.stack([rr * np.cos(phi), rr * np.sin(phi), np.broadcast_to(zz, (n_u - 2, n_phi))], -1)
    pts = np.concatenate([[[0.0, 0.0, z[0]]], ring_pts.reshape(-1, 3), [[0.0, 0.0, z[-1]]]])
    where = np.concatenate(
        [
            [[0, 0.0]],
            np.stack(np.broadcast_arrays(np.arange(1, n_u - 1)[:, None], phi[None, :]), -1).reshape(-1, 2),
            [[n_u - 1, 0.0]],
        ]
    )
    k = np.arange(n_phi)
    kp = (k + 1) % n_phi

    def ring(j, kk):
        return 1 + (j - 1) * n_phi + kk

    tri = [np.stack([np.zeros(n_phi, int), ring(1, k), ring(1, kp)], 1)]
    for j in range(1, n_u - 2):
        a, b, c, d = ring(j, k), ring(j, kp), ring(j + 1, k), ring(j + 1, kp)
        tri.append(np.stack([a, c, d], 1))
        tri.append(np.stack([a, d, b], 1))
    last = len(pts) - 1
    tri.append(np.stack([np.full(n_phi, last), ring(n_u - 2, kp), ring(n_u - 2, k)], 1))
    return pts, np.concatenate(tri).astype(int), where


def _diagnostics(dyn: _Dynamics, y: ArrayF, g: dict, x: ArrayF, radius: float) -> dict:
    sp, system, n = dyn.sp, dyn.system, dyn.n
    z = y[n : 2 * n]
    f = system.unpack(x)
    w = sp.wR * g["r"] * g["h"]
    area = 2 * np.pi * w.sum()
    zu = z @ sp.D["Z"].T
    volume = np.pi * float(np.sum(sp.wR * g["r"] ** 2 * (-zu)))
    if sp.symmetric:
        zc = 0.0
        pole = float(sp.evaluate("Z", z, [0.0])[0])
        furrow = float(sp.evaluate("R", g["r"], [np.pi / 2])[0])
    else:
        zc = 2 * np.pi * float(np.sum(sp.wO * z * g["r"] * g["h"])) / area
        zn, zs_ = sp.evaluate("Z", z, [0.0, np.pi])
        pole = 0.5 * float(zn - zs_)
        furrow = _furrow(sp, g["r"], z, zc)
    vs, vn = f["v_s"], f["v_n"]
    if not dyn.labelled:
        u = sp.u.copy()
        us = np.ones(n)
    else:
        u = y[2 * n : 3 * n].copy()
        us = 1.0 + (u - sp.u) @ sp.D["O"].T
    mat = g["h"] / us / radius  # material line element |dX/du| / R0
    margin = _bending_margin(system.ph, sp, y) if system.ph.bending else float("nan")
    stretch = float(mat.max() / mat.min()) if np.all(us > 0) else float("inf")  # inf: label map folded
    if dyn.myosin is not None:
        c, total = np.asarray(g["c"]), 2 * np.pi * float(sp.wR @ g["q"])
    else:
        c, total = None, float("nan")
    return dict(
        c=c,
        myosin_total=total,
        u=u,
        r=g["r"],
        z=z,
        v_s=vs,
        v_n=vn,
        v_r=vs * g["rs"] - vn * g["zs"],
        v_z=vs * g["zs"] + vn * g["rs"],
        zeta=np.asarray(g["zeta"]),
        P=float(f["P"]),
        lam=float(f["lam"]),
        area=float(area),
        volume=volume,
        z_centroid=zc,
        pole_radius=pole,
        furrow_radius=furrow,
        stretch=stretch,
        grid_stretch=float(g["h"].max() / g["h"].min()),
        neck_radius=_neck(dyn, y),
        bending_margin=margin,
    )


def _furrow(sp: Spectral, r: ArrayF, z: ArrayF, zc: float) -> float:
    """Cylindrical radius where the meridian crosses z = zc (the smallest one if several)."""
    from scipy.optimize import brentq

    uu = np.linspace(0.0, np.pi, 2001)
    f = sp.evaluate("Z", z, uu) - zc
    roots = []
    for j in np.nonzero(np.sign(f[:-1]) * np.sign(f[1:]) <= 0)[0]:
        if f[j] == 0.0:
            roots.append(uu[j])
            continue
        roots.append(
            brentq(lambda s: float(sp.evaluate("Z", z, [s])[0]) - zc, uu[j], uu[j + 1], xtol=1e-15, rtol=1e-15)
        )
    if not roots:
        return float("nan")
    return float(min(sp.evaluate("R", r, roots)))


def _mirror(sp: Spectral, a: ArrayF, parity: int, shift: float = 0.0) -> ArrayF:
    """Full-meridian nodal values from the symmetric half: ``a(pi - s) = shift + parity a(s)``."""
    if not sp.symmetric:
        return a
    return np.concatenate([a, shift + parity * a[::-1]])


def simulate(
    zeta: ZetaFn,
    *,
    eta_s: float,
    eta_b: float,
    eta_bar: float,
    eta_bar_b: float,
    radius: float = 1.0,
    t_end: float,
    save_times: Sequence[float] | None = None,
    n: int = 48,
    rtol: float = 1e-10,
    atol: float | None = None,
    symmetric: bool | None = None,
    parametrization: str = "auto",
    gauge: str = "velocity",
    method: str = "Radau",
    interpolate: bool = False,
    max_steps: int = 100000,
    tension: str = "nodes",
    monitor: float = 0.0,
    stop_neck: float | None = None,
    stop_ill_posed: bool = True,
    myosin: Myosin | None = None,
    bending_form: str = "paper",
    kappa: float = 0.0,
    spontaneous_curvature: float = 0.0,
    on_save=None,
    start: tuple[float, ArrayF] | None = None,
) -> SimulationResult:
    """Evolve the cortex from the sphere of radius ``radius`` with ``dX/dt = v_n n``.

    Parameters
    ----------
    zeta : callable
        Active tension as a function of the initial polar angle theta0 in [0, pi] (units of
        zeta_0), vectorised or scalar.  Carried by the normally moving material points.  For
        spectral accuracy it should be smooth on the sphere (even about the poles).
    eta_s, eta_b, eta_bar, eta_bar_b : float
        Shear (> 0), bulk (>= 0) and bending (>= 0) viscosities (units eta_s, eta_s R0^2).
    radius : float
        Initial radius (R0).
    t_end : float
        Final time (t_a).
    save_times : sequence of float, optional
        Sorted times in [0, t_end] at which to save (default ``[0, t_end]``).
    n : int
        Collocation points on the half meridian (symmetric) or on the full meridian.
    rtol, atol : float
        Tolerances of the stiff integrator on the node positions (atol default ``rtol * radius``).
    symmetric : bool or None
        Solve only [0, pi/2] using the up-down symmetry (None: detect ``zeta(pi-t) == zeta(t)``).
    parametrization : {'auto', 'lagrangian', 'arclength', 'adaptive'}
        ``lagrangian``: nodes are the normally moving material points (state r, z).
        ``arclength``: nodes stay equidistant in arc length and carry the material label
        (state r, z, u); needed when the material points cluster (e.g. a drifting non-symmetric
        pattern).  ``adaptive``: like ``arclength``, but the nodes equidistribute
        ``sqrt(1 + a^2 (k1^2 + k2^2) + b^2 (d ln|dX/du|/ds)^2 + c^2 (dzeta/ds / range)^2)``
        (``ADAPT_*``), so a closing neck, the flanks of its stretched label map and the
        tension's fronts keep their points: deep glued furrows converge to a neck of 0.1 R0
        (docs/validation/constriction.md).  ``auto``: lagrangian with symmetry, arclength
        without.
    gauge : {'velocity', 'centroid'}
        Full meridian only (irrelevant with symmetry): the rigid axial translation is fixed by
        ``oint v_z dA = 0`` (default, the 3D code's convention) or by ``oint z v_n dA = 0``
        (the enclosed volume's centroid stays put).  With normal-only point motion the choice
        changes which material point sits where, hence the dynamics of a non-symmetric pattern.
    method : {'Radau', 'BDF'}
        scipy's implicit integrator (with the exact complex-step Jacobian).
    interpolate : bool
        Save via the integrator's dense output instead of stopping exactly at each save time
        (cheaper with many save times; its interpolation error is measured in REPORT.md).
    max_steps : int
        Abort with ValueError after this many steps.
    tension : {'nodes', 'material'}
        ``nodes``: the tension stays on the normally moving points (the paper's). ``material``: it
        is carried by the cortex's full velocity, ``dzeta/dt = 0`` following material points
        (the state then carries the material label of every node, Sec. 9 of the derivation).
    monitor : float
        Arc-length mode only: > 0 places the nodes by equidistributing
        ``h sqrt(1 + monitor^2 (k1^2 + k2^2))`` instead of the arc length, so a closing neck
        keeps its share of them (Sec. 11).
    stop_neck : float or None
        Stop cleanly (keeping the frames so far, plus one at the time of the crossing) when the
        neck radius falls to this value (R0); ``SimulationResult.stopped`` says so.
    stop_ill_posed : bool
        With bending viscosity, stop cleanly the same way when ``2 eta_bar k_i + (eta_bar_b -
        eta_bar) C`` (i = 1, 2) falls to 0 at a node: past it the bending-viscosity normal force
        amplifies short waves instead of damping them and the model has no converged solution
        (derivation, Sec. 12). Off, the run goes on until the integrator fails.
    myosin : Myosin or None
        A myosin density carried by the full velocity, diffusing and turning over, whose tension
        ``zeta(c)`` adds to ``zeta`` (:mod:`cortex_ti.axisymmetric.myosin`); the up-down symmetry
        is used only if its initial density has it too.
    bending_form : "paper" (Eq. 45, the default) or "dissipation": the bending viscosity's normal
        force as the 3D formulations ``rayleigh_p1`` and ``rayleigh_p2`` integrate it, the force of
        ``1/2 int B^cd d_c v_n d_d v_n dA``; the two differ by ``(nabla_c beta^cd) d_d v_n``, zero on
        a sphere (:class:`~cortex_ti.axisymmetric.balance._Physics`).
    kappa, spontaneous_curvature : float
        Helfrich bending rigidity (>= 0, eta_s R0^2 / t_a) and spontaneous curvature c0 (1/R0, ``C = 2/R``
        on a sphere): the normal force of ``kappa/2 oint (C - c0)^2 dA`` (:mod:`cortex_ti.axisymmetric.rigidity`).
    on_save : callable or None
        ``on_save(frame, y)`` as each save time is reached (before the next step): ``frame`` the
        :class:`SimulationResult` of that one frame (its statistics zero), ``y`` the integrator's
        state there, from which ``start`` continues. A run writes its frames as they come.
    start : (t, y) or None
        Continue from the state ``y`` at time ``t`` (an earlier run's ``on_save``) instead of the
        sphere at t = 0; only the save times after ``t`` are saved. The integrator starts afresh
        there, so the continued run agrees with the uninterrupted one to its tolerance, not to
        round-off.

    Returns
    -------
    SimulationResult

    Raises
    ------
    ValueError
        Bad input, singular force balance, or integrator failure (one-line message).
    """
    phys = _check_visc(
        eta_s, eta_b, eta_bar, eta_bar_b, radius, bending_form=bending_form, kappa=kappa, c0=spontaneous_curvature
    )
    n = _check_n(n)
    R = float(radius)
    st, atol = _check_times(t_end, save_times, rtol, atol, R)
    if method not in ("Radau", "BDF"):
        raise ValueError(f"method must be 'Radau' or 'BDF', got {method!r}")
    if parametrization not in ("auto", "lagrangian", "arclength", "adaptive"):
        raise ValueError(
            f"parametrization must be 'auto', 'lagrangian', 'arclength' or 'adaptive', got {parametrization!r}"
        )
    if tension not in ("nodes", "material"):
        raise ValueError(f"tension must be 'nodes' or 'material', got {tension!r}")
    if not (isinstance(monitor, (int, float)) and math.isfinite(monitor) and monitor >= 0):
        raise ValueError(f"monitor must be a finite number >= 0, got {monitor!r}")
    if stop_neck is not None and not (isinstance(stop_neck, (int, float)) and 0 < stop_neck < radius):
        raise ValueError(f"stop_neck must lie in (0, radius), got {stop_neck!r}")
    _eval_zeta(zeta, np.linspace(0.0, np.pi, 7))
    if myosin is not None and not isinstance(myosin, Myosin):
        raise ValueError(f"myosin must be a Myosin or None, got {type(myosin).__name__}")
    if symmetric is None:
        symmetric = _is_symmetric(zeta) and (myosin is None or myosin.symmetric())
    if parametrization == "auto":
        parametrization = "lagrangian" if symmetric else "arclength"
    if monitor and parametrization != "arclength":
        raise ValueError("monitor needs parametrization = 'arclength' (the nodes must be free to move tangentially)")
    sp = Spectral(n, symmetric)
    dyn = _Dynamics(
        sp,
        ForceBalance(sp, phys, _check_gauge(gauge)),
        zeta,
        parametrization,
        carried=tension == "material",
        monitor=monitor,
        myosin=myosin,
    )
    y0 = [R * np.sin(sp.u), R * np.cos(sp.u)] + ([sp.u.copy()] if dyn.labelled else [])
    if myosin is not None:  # q = c r h on the sphere (h = R)
        y0.append(myosin.density(sp.u) * R * np.sin(sp.u) * R)
    y0 = np.concatenate(y0)  # on the sphere the monitor is uniform: the nodes start equidistributed
    t_start = 0.0
    if start is not None:
        t_start, y_start = float(start[0]), np.asarray(start[1], dtype=float)
        if y_start.shape != y0.shape or not (0.0 <= t_start <= t_end):
            raise ValueError(
                f"cannot continue from a state of size {y_start.size} at t = {t_start:g}: this run's state has size "
                f"{y0.size} (n, symmetry, parametrization, tension and myosin must agree) and ends at {t_end:g}"
            )
        y0, st = y_start.copy(), st[st > t_start + 1e-12 * max(1.0, t_end)]
    stops = {}
    if stop_neck is not None:
        stops["neck"] = lambda y: _neck(dyn, y) - stop_neck
    if stop_ill_posed and phys.bending:
        stops["bending"] = lambda y: _bending_margin(phys, sp, y)
    params = dict(
        eta_s=phys.eta_s,
        eta_b=phys.eta_b,
        eta_bar=phys.eta_bar,
        eta_bar_b=phys.eta_bar_b,
        radius=R,
        n=n,
        rtol=rtol,
        atol=atol,
        symmetric=symmetric,
        method=method,
        parametrization=parametrization,
        gauge=gauge,
        interpolate=interpolate,
        tension=tension,
        monitor=monitor,
        stop_neck=stop_neck,
        stop_ill_posed=stop_ill_posed,
        myosin=None if myosin is None else {k: v for k, v in vars(myosin).items() if k != "initial"},
    )
    if phys.kappa:
        params.update(kappa=phys.kappa, spontaneous_curvature=phys.c0)

    def hook(t, y):
        if on_save is not None:
            on_save(_result(dyn, [(t, y)], R, dict(_NO_STATS), params), y)

    t0 = time.perf_counter()
    failure = None
    try:
        saved, nsteps, nlu, stopped = _integrate(
            dyn,
            y0,
            st,
            float(t_end),
            Radau if method == "Radau" else BDF,
            rtol,
            atol,
            interpolate,
            max_steps,
            stops,
            t_start=t_start,
            hook=hook,
        )
    except _Failed as exc:
        if not exc.saved:
            raise ValueError(str(exc)) from None
        (failure, saved, nsteps, nlu), stopped = exc.args, f"failed: {exc.args[0]}"
    stats = dict(wall_time=time.perf_counter() - t0, n_rhs=dyn.nrhs, n_steps=nsteps, n_jac=dyn.njac, n_lu=nlu)
    out = _result(dyn, saved, R, stats, params)
    out.stopped = stopped
    if failure is not None:
        raise StepFailed(failure, out)
    return out


class StepFailed(ValueError):
    """The integrator failed at a step (one-line message); ``result`` holds the frames saved
    before it (``stopped``: ``'failed: ...'``), so a run can keep them."""

    def __init__(self, message: str, result: SimulationResult):
        super().__init__(message)
        self.result = result


class _Failed(Exception):
    """Inside :func:`_integrate`: a step failed; args ``(message, saved, steps, LU factorisations)``."""

    @property
    def saved(self):
        return self.args[1]


def full_meridian_dynamics(
    zeta: ZetaFn,
    n: int,
    *,
    eta_s: float,
    eta_b: float,
    eta_bar: float,
    eta_bar_b: float,
    radius: float = 1.0,
    gauge: str = "velocity",
    cls: type | None = None,
    tension: str = "nodes",
    myosin: Myosin | None = None,
) -> _Dynamics:
    """The shape dynamics of ``simulate(..., symmetric=False, parametrization='lagrangian')``:
    points at ``n`` labels on the whole meridian moving with ``v_n n``, state ``y = (r, z)``
    (``tension='material'``: ``y = (r, z, u)``, ``u`` the material label at each point, initially
    the point's polar angle); its ``rhs(t, y)`` and exact Jacobian ``jac(t, y)`` linearise the
    dynamics about any state (e.g. a saved frame), without the up-down reduction, so modes odd
    under z -> -z are seen. ``cls``: a subclass of the dynamics to build instead (for experiments).
    ``myosin``: the state ends with the myosin amount per unit parameter ``q = c r h``
    (:mod:`cortex_ti.axisymmetric.myosin`; on the sphere of radius R, ``q = c R^2 sin(sigma)``)."""
    phys = _check_visc(eta_s, eta_b, eta_bar, eta_bar_b, radius)
    sp = Spectral(_check_n(n), False)
    if tension not in ("nodes", "material"):
        raise ValueError(f"tension must be 'nodes' or 'material', got {tension!r}")
    return (cls or _Dynamics)(
        sp,
        ForceBalance(sp, phys, _check_gauge(gauge)),
        zeta,
        "lagrangian",
        carried=tension == "material",
        myosin=myosin,
    )


def normal_embedding(dyn: _Dynamics, y: ArrayF) -> ArrayF:
    """(2n, n): the node displacements ``(dr, dz)`` of a normal displacement ``s`` per node on
    the state ``y``, so that ``N.T @ dyn.jac(t, y) @ N`` is the normal-normal operator the 3D
    spectrum computes (:func:`cortex_ti.dynamics.spectrum.normal_jacobian`)."""
    g = dyn.geometry(y)
    n, i = dyn.n, np.arange(dyn.n)
    N = np.zeros((2 * n, n))
    N[i, i], N[n + i, i] = -g["zs"], g["rs"]
    return N


def _check_times(t_end, save_times, rtol, atol, R) -> tuple[ArrayF, float]:
    """The save times (default ``[0, t_end]``) and ``atol`` (default ``rtol R``), checked."""
    for name, val in (("t_end", t_end), ("rtol", rtol)):
        if (
            isinstance(val, bool)
            or not isinstance(val, (int, float, np.floating, np.integer))
            or not math.isfinite(val)
            or val <= 0
        ):
            raise ValueError(f"{name} must be a finite number > 0, got {val!r}")
    atol = rtol * R if atol is None else atol
    if (
        isinstance(atol, bool)
        or not isinstance(atol, (int, float, np.floating))
        or not math.isfinite(atol)
        or atol <= 0
    ):
        raise ValueError(f"atol must be a finite number > 0, got {atol!r}")
    try:
        st = np.asarray([0.0, float(t_end)] if save_times is None else save_times, dtype=float).ravel()
    except (TypeError, ValueError):
        raise ValueError("save_times must be a sequence of numbers") from None
    if (
        st.size == 0
        or not np.all(np.isfinite(st))
        or np.any(st < 0)
        or np.any(st > t_end * (1 + 1e-12))
        or np.any(np.diff(st) < 0)
    ):
        raise ValueError("save_times must be finite, sorted and within [0, t_end]")
    return st, atol


def _neck(dyn: _Dynamics, y: ArrayF) -> float:
    """The neck radius: the smallest interior local minimum of ``r`` along the meridian (inf if
    there is none, e.g. a convex shape), from the spectral interpolant on 1025 points."""
    sig = np.linspace(0.0, np.pi, 1025)
    r = dyn.sp.evaluate("R", np.asarray(y[: dyn.n]).real, sig)
    i = np.nonzero((r[1:-1] < r[:-2]) & (r[1:-1] <= r[2:]))[0] + 1
    return float(r[i].min()) if i.size else float("inf")


def _crossing(solver, t_old: float, stop) -> tuple[float, ArrayF]:
    """Time and state at which ``stop`` (> 0 before, <= 0 after the last step) crosses zero, on
    the step's dense output."""
    from scipy.optimize import brentq

    dense = solver.dense_output()
    if not math.isfinite(stop(dense(t_old))):  # no neck yet at the step's start: find where one forms
        a, b = t_old, solver.t
        for _ in range(60):
            mid = 0.5 * (a + b)
            a, b = (mid, b) if not math.isfinite(stop(dense(mid))) else (a, mid)
        t_old = b
    if stop(dense(t_old)) <= 0.0:
        return t_old, np.asarray(dense(t_old))
    ts = brentq(lambda t: stop(dense(t)), t_old, solver.t, xtol=1e-12, rtol=1e-12)
    return float(ts), np.asarray(dense(ts))


_MARGIN_GRID = (np.arange(512) + 0.5) * (np.pi / 512)


def _bending_margin(ph, sp: Spectral, y: ArrayF) -> float:
    """The smallest along the meridian (the spectral interpolant on 512 points, equator included
    with symmetry) of ``2 eta_bar k_i + (eta_bar_b - eta_bar) C`` (i = 1, 2): > 0 while the
    bending-viscosity normal force damps short waves (derivation, Sec. 12)."""
    n, y = sp.n, np.asarray(y).real
    r = y[:n] if sp.FR is None else sp.FR @ y[:n]
    sig = np.concatenate([_MARGIN_GRID, [np.pi / 2]])
    ru, zu = sp.evaluate("R", r, sig, 1), sp.evaluate("Z", y[n : 2 * n], sig, 1)
    ruu, zuu = sp.evaluate("R", r, sig, 2), sp.evaluate("Z", y[n : 2 * n], sig, 2)
    h = np.hypot(ru, zu)
    k1 = (zu * ruu - ru * zuu) / h**3
    k2 = -zu / h / sp.evaluate("R", r, sig)
    d, C = ph.eta_bar_b - ph.eta_bar, k1 + k2
    return float(min(np.min(2 * ph.eta_bar * k1 + d * C), np.min(2 * ph.eta_bar * k2 + d * C)))


_STOP_MESSAGES = {
    "neck": "neck {neck:.4g} R0 at t={t:.6g}",
    "bending": "ill-posed at t={t:.6g}: the bending-viscosity normal force lost its sign on the meridian "
    "(2 eta_bar k_i + (eta_bar_b - eta_bar) C = 0; neck {neck:.4g} R0)",
}


class _Saved(list):
    """The saved ``(t, y)`` of :func:`_integrate`, each also handed to ``hook(t, y)`` as it comes."""

    def __init__(self, hook=None):
        super().__init__()
        self.hook = hook

    def append(self, item) -> None:
        super().append(item)
        if self.hook is not None:
            self.hook(*item)


_NO_STATS = dict(wall_time=0.0, n_rhs=0, n_steps=0, n_jac=0, n_lu=0)


def _integrate(dyn, y0, st, t_end, Solver, rtol, atol, interpolate, max_steps, stops=None, t_start=0.0, hook=None):
    """Step from ``t_start`` (0: the sphere) to the save times (or, with ``interpolate``, to
    ``t_end`` reading the dense output at the save times), or until one of ``stops`` (name -> f(y))
    falls to 0; ``hook(t, y)`` is called as each is saved. Returns ``(saved [(t, y)], steps, LU
    factorisations, why it stopped)``."""
    stops = stops or {}
    saved: list[tuple[float, ArrayF]] = _Saved(hook)
    nsteps = nlu = k = 0
    while k < st.size and st[k] <= t_start:
        saved.append((float(st[k]), y0.copy()))
        k += 1
    t, y = float(t_start), y0
    first = None
    while k < st.size:
        bound = t_end if interpolate else float(st[k])
        if bound <= t:  # repeated save time
            saved.append((float(st[k]), y.copy()))
            k += 1
            continue
        if first is not None:
            first = min(first, bound - t)
        try:
            solver = Solver(dyn.rhs, t, y, bound, rtol=rtol, atol=atol, jac=dyn.jac, first_step=first)
        except (ValueError, np.linalg.LinAlgError) as err:
            raise ValueError(f"integrator start failed at t={t:.6g}: {err}") from None
        while solver.status == "running":
            t_old = solver.t
            try:
                nsteps = _step(solver, nsteps, max_steps)
            except ValueError as err:
                raise _Failed(str(err), saved, nsteps, nlu + solver.nlu) from None
            hit = [(*_crossing(solver, t_old, f), name) for name, f in stops.items() if f(solver.y) <= 0.0]
            if hit:
                tc, yc, name = min(hit, key=lambda h: h[0])
                if interpolate:
                    k = _save_dense(solver, st[st < tc], k, saved)
                saved.append((tc, yc))
                why = _STOP_MESSAGES[name].format(neck=_neck(dyn, yc), t=tc)
                return saved, nsteps, nlu + solver.nlu, why
            if interpolate:
                k = _save_dense(solver, st, k, saved)
        nlu += solver.nlu
        if not interpolate:
            saved.append((float(st[k]), solver.y.copy()))
            k += 1
        # continue with the step size the controller proposed (not the one truncated at the bound)
        first = float(getattr(solver, "h_abs", 0.0) or 0.0) or None
        t, y = solver.t, solver.y
    return saved, nsteps, nlu, "t_end"


def _step(solver, nsteps: int, max_steps: int) -> int:
    """One step of the scipy integrator, its failures as one-line ValueErrors."""
    t_old = solver.t
    try:
        msg = solver.step()
    except (ValueError, np.linalg.LinAlgError) as err:  # singular system inside a stage
        raise ValueError(f"integrator step failed at t={t_old:.6g}: {err}") from None
    if solver.status == "failed":
        raise ValueError(f"integrator step failed at t={solver.t:.6g}: {msg}")
    if nsteps + 1 > max_steps:
        raise ValueError(f"integrator exceeded max_steps={max_steps} at t={solver.t:.6g}")
    return nsteps + 1


def _save_dense(solver, st, k: int, saved: list) -> int:
    """Save the states at the save times the last step passed (dense output between steps)."""
    dense = None
    while k < st.size and st[k] <= solver.t:
        if st[k] == solver.t:
            saved.append((float(st[k]), solver.y.copy()))
        else:
            dense = dense or solver.dense_output()
            saved.append((float(st[k]), np.asarray(dense(st[k]))))
        k += 1
    return k


def _result(dyn, saved, R: float, stats: dict, params: dict) -> SimulationResult:
    """The saved states on the full meridian, with the diagnostics recomputed at each (one extra
    force-balance solve each, not counted in the statistics)."""
    sp, lagrangian = dyn.sp, not dyn.labelled
    states, diags = [], []
    for _, ys in saved:
        g, x, _ = dyn.solve(ys)
        d = _diagnostics(dyn, ys, g, x, R)
        states.append(dict(r=d["r"], z=d["z"], v_s=d["v_s"], v_n=d["v_n"], u=None if lagrangian else d["u"], c=d["c"]))
        diags.append(d)

    def stack(key, parity, shift=0.0):
        return np.array([_mirror(sp, d[key], parity, shift) for d in diags])

    def series(key):
        return np.array([d[key] for d in diags])

    return SimulationResult(
        t=np.array([s[0] for s in saved]),
        u=stack("u", -1, np.pi),
        r=stack("r", 1),
        z=stack("z", -1),
        v_s=stack("v_s", -1),
        v_n=stack("v_n", 1),
        v_r=stack("v_r", 1),
        v_z=stack("v_z", -1),
        zeta=stack("zeta", 1),
        P=series("P"),
        lam=series("lam"),
        pole_radius=series("pole_radius"),
        furrow_radius=series("furrow_radius"),
        volume=series("volume"),
        area=series("area"),
        z_centroid=series("z_centroid"),
        stretch=series("stretch"),
        grid_stretch=series("grid_stretch"),
        neck_radius=series("neck_radius"),
        bending_margin=series("bending_margin"),
        c=stack("c", 1) if dyn.myosin is not None else None,
        myosin_total=series("myosin_total") if dyn.myosin is not None else None,
        **stats,
        params=params,
        _states=states,
        _spectral=sp,
        _zeta_fn=dyn.zeta_fn,
        _myosin=dyn.myosin,
    )
