"""The shape dynamics of the axisymmetric cortex: the right-hand side of the node motion and its
exact Jacobian (:class:`Dynamics`, one per parametrisation: ``lagrangian``, ``arclength``,
``adaptive``), the full-meridian dynamics and normal embedding the spectrum compares with, the
measures a run stops on (the neck, the margin of the bending-viscosity force) and the limits of
the label stretch a run resolves (:mod:`cortex_ti.axisymmetric.evolve` integrates it).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg as sla

from . import myosin as _my
from .balance import (
    ForceBalance,
    ZetaFn,
    check_gauge,
    check_n,
    check_visc,
    eval_zeta,
    lu_checked,
)
from .myosin import Myosin
from .spectral import Spectral, geometry

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

#: The full meridian's node rates are low-pass filtered, ``exp(-FILTER_STRENGTH (k / n)^FILTER_ORDER)`` on
#: mode k of n (Hou and Li's filter, J. Comput. Phys. 226, 2007: modes below n/2 keep all but 5e-10 of
#: themselves, the last one e^-36). A body that translates (an off-centre ring: the velocity gauge fixes its
#: mean velocity, not its centroid) moves its normally moving points along its own surface, a parametric
#: drift of variable sign, which Fourier collocation turned into a grid-scale mode growing at a rate
#: proportional to n (the ring at pi/2 - 0.2, A = 20, kappa = 0.01 at t = 0.1: the fastest rate 4.37, 4.65,
#: 13.1 / t_a at n = 48, 64, 96, a zigzag; it ended that run at t = 0.24). Filtered, the fastest rate is
#: 4.36646 at every n, its mode smooth (docs/validation/division_axisymmetric.md, "The ring off the
#: equator"). Only a problem without up-down symmetry is filtered (``Dynamics(filtered=True)``, which
#: :func:`~cortex_ti.axisymmetric.evolve.simulate` sets for it): a symmetric one does not translate, and its
#: rates stay exact at any n (the shape-mode tests).
FILTER_STRENGTH = 36.0
FILTER_ORDER = 36


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
    zr = eval_zeta(zeta, np.linspace(0.0, np.pi, 1025))
    return float(zr.max() - zr.min()) > 1e-12 * max(1.0, float(np.abs(zr).max()))


class _ZetaSeries:
    """Cosine series of ``zeta(u)`` on [0, pi] (1024 modes): only its derivative is used, for the
    Jacobian of the arc-length mode (the values themselves always come from the user function)."""

    def __init__(self, zeta: ZetaFn, m: int = 1024):
        from scipy.fft import dct

        u = (np.arange(m) + 0.5) * (np.pi / m)
        X = dct(eval_zeta(zeta, u), type=2)
        c = X / m
        c[0] *= 0.5
        self.c = c
        self.k = np.arange(m, dtype=float)

    def derivative(self, u: ArrayF) -> ArrayF:
        return -(np.sin(np.outer(u, self.k)) * self.k) @ self.c


def _low_pass(sp: Spectral, cls: str) -> ArrayF:
    """The nodal matrix of the exponential filter ``exp(-FILTER_STRENGTH (k / n)^FILTER_ORDER)`` on the
    k-th basis function of class ``cls``."""
    s = np.exp(-FILTER_STRENGTH * (np.arange(sp.n) / sp.n) ** FILTER_ORDER)
    return sp.B[cls] @ (s[:, None] * sp.Binv[cls])


class Dynamics:
    """Right-hand side of the shape evolution at the nodes and its exact Jacobian.

    ``lagrangian``: state ``(r, z)`` at fixed labels ``u`` (nodes = material points moving
    with ``v_n n``).  ``arclength``: state ``(r, z, u)`` at computational points ``sigma`` that
    move with ``v_n n + w e_s``, ``w`` chosen so that ``|dX/dsigma|`` stays uniform (= L/pi);
    the material label is carried along, ``du/dt = (w / h) du/dsigma`` (``h = |dX/dsigma|``).
    ``filtered``: on the full meridian, low-pass filter the node rates (see ``FILTER_STRENGTH``).
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
        filtered: bool = False,
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
            zr = eval_zeta(zeta, np.linspace(0.0, np.pi, 1025))
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
            self.zeta_nodes = eval_zeta(zeta, sp.u)
        else:
            self.series = _ZetaSeries(zeta)
        self.filters = (
            None
            if sp.symmetric or not filtered
            else [_low_pass(sp, c) for c in ("R", "Z", "O")[: 3 if self.labelled else 2]]
        )

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
                g["zeta"] = eval_zeta(self.zeta_fn, ur) + 1j * u.imag * self.series.derivative(ur)
            else:
                g["zeta"] = eval_zeta(self.zeta_fn, u)
        if self.myosin is not None:
            g["q"] = y[..., self.iq : self.iq + n]
            g["c"] = g["q"] / (g["r"] * g["h"])
            g["zeta"] = g["zeta"] + self.myosin.tension(g["c"])
        return g

    def solve(self, y: ArrayF) -> tuple[dict, ArrayF, tuple]:
        g = self.geometry(y)
        A, b = self.system.assemble(g)
        lu = lu_checked(A)
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
        if self.filters is not None:  # the rates of r, z (and the label): see FILTER_STRENGTH
            for i, f in enumerate(self.filters):
                out[i] = out[i] @ f.T
        return np.concatenate(out, axis=-1)

    def residual(self, x: ArrayF, g: dict) -> ArrayF:
        """The residual ``A(y) x - b(y)`` of :meth:`solve`'s system, batched (the fluids extend it)."""
        return self.system.residual(x, g)

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
        res = self.residual(np.repeat(x0[None, :], m, axis=0).astype(complex), gc)
        dx = sla.lu_solve(lu, res.imag.T / eps, check_finite=False).T  # A^-1 dR/dy
        xc = x0[None, :] - 1j * eps * dx
        vel = self.velocity(gc, xc)
        return (vel.imag / eps).T


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
) -> Dynamics:
    """The shape dynamics of ``simulate(..., symmetric=False, parametrization='lagrangian')``:
    points at ``n`` labels on the whole meridian moving with ``v_n n``, state ``y = (r, z)``
    (``tension='material'``: ``y = (r, z, u)``, ``u`` the material label at each point, initially
    the point's polar angle); its ``rhs(t, y)`` and exact Jacobian ``jac(t, y)`` linearise the
    dynamics about any state (e.g. a saved frame), without the up-down reduction, so modes odd
    under z -> -z are seen. ``cls``: a subclass of the dynamics to build instead (for experiments).
    ``myosin``: the state ends with the myosin amount per unit parameter ``q = c r h``
    (:mod:`cortex_ti.axisymmetric.myosin`; on the sphere of radius R, ``q = c R^2 sin(sigma)``)."""
    phys = check_visc(eta_s, eta_b, eta_bar, eta_bar_b, radius)
    sp = Spectral(check_n(n), False)
    if tension not in ("nodes", "material"):
        raise ValueError(f"tension must be 'nodes' or 'material', got {tension!r}")
    return (cls or Dynamics)(
        sp,
        ForceBalance(sp, phys, check_gauge(gauge)),
        zeta,
        "lagrangian",
        carried=tension == "material",
        myosin=myosin,
    )


def normal_embedding(dyn: Dynamics, y: ArrayF) -> ArrayF:
    """(2n, n): the node displacements ``(dr, dz)`` of a normal displacement ``s`` per node on
    the state ``y``, so that ``N.T @ dyn.jac(t, y) @ N`` is the normal-normal operator the 3D
    spectrum computes (:func:`cortex_ti.dynamics.spectrum.normal_jacobian`)."""
    g = dyn.geometry(y)
    n, i = dyn.n, np.arange(dyn.n)
    N = np.zeros((2 * n, n))
    N[i, i], N[n + i, i] = -g["zs"], g["rs"]
    return N


def meridian_neck(dyn: Dynamics, y: ArrayF) -> float:
    """The neck radius: the smallest interior local minimum of ``r`` along the meridian (inf if
    there is none, e.g. a convex shape), from the spectral interpolant on 1025 points."""
    sig = np.linspace(0.0, np.pi, 1025)
    r = dyn.sp.evaluate("R", np.asarray(y[: dyn.n]).real, sig)
    i = np.nonzero((r[1:-1] < r[:-2]) & (r[1:-1] <= r[2:]))[0] + 1
    return float(r[i].min()) if i.size else float("inf")


MARGIN_GRID = (np.arange(512) + 0.5) * (np.pi / 512)


def bending_margin(ph, sp: Spectral, y: ArrayF) -> float:
    """The smallest along the meridian (the spectral interpolant on 512 points, equator included
    with symmetry) of ``2 eta_bar k_i + (eta_bar_b - eta_bar) C`` (i = 1, 2): > 0 while the
    bending-viscosity normal force damps short waves (derivation, Sec. 12)."""
    n, y = sp.n, np.asarray(y).real
    r = y[:n] if sp.FR is None else sp.FR @ y[:n]
    sig = np.concatenate([MARGIN_GRID, [np.pi / 2]])
    ru, zu = sp.evaluate("R", r, sig, 1), sp.evaluate("Z", y[n : 2 * n], sig, 1)
    ruu, zuu = sp.evaluate("R", r, sig, 2), sp.evaluate("Z", y[n : 2 * n], sig, 2)
    h = np.hypot(ru, zu)
    k1 = (zu * ruu - ru * zuu) / h**3
    k2 = -zu / h / sp.evaluate("R", r, sig)
    d, C = ph.eta_bar_b - ph.eta_bar, k1 + k2
    return float(min(np.min(2 * ph.eta_bar * k1 + d * C), np.min(2 * ph.eta_bar * k2 + d * C)))
