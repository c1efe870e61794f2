r"""The force balance on an axisymmetric shape, and the static flow on a sphere.

Tangential balance ``nabla_a t^ab = 0`` along the meridian and normal balance
``C_ab t^ab = P`` at every node for ``v = v_s e_s + v_n n`` (no azimuthal velocity), with
``t^ab = 2 eta_s (v^ab - v^c_c g^ab/2) + eta_b v^c_c g^ab + zeta g^ab`` and the 3D code's
bending-viscosity normal force (paper Eq. 45, :mod:`cortex_ti.physics.terms.bending`); the
incompressible interior ``oint v_n dA = 0`` with its multiplier ``P``, and on the full meridian
the rigid axial translation fixed by ``oint v_z dA = 0`` (the 3D code's gauge) or by the
enclosed volume's centroid. Conventions: ``conventions.md`` (outward normal, a sphere has
``C = 2/R``, ``zeta > 0`` contractile, ``P = p_in - p_out``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from .rigidity import helfrich_force
from .spectral import Spectral, geometry

__all__ = ["ForceBalance", "StaticResult", "static_flow", "ZetaFn"]

ArrayF = np.ndarray
ZetaFn = Callable[[np.ndarray], np.ndarray]


@dataclass
class _Physics:
    eta_s: float
    eta_b: float
    eta_bar: float
    eta_bar_b: float
    fixed_normal: bool = False
    #: "paper": the bending viscosity's normal force as paper Eq. 45, ``beta^cd nabla_c nabla_d v_n + beta_0
    #: v_n``; "dissipation": the force of the dissipation the 3D Rayleighian formulations integrate,
    #: ``nabla_c (beta^cd nabla_d v_n) + beta_0 v_n`` (:mod:`cortex_ti.physics.terms.bending`), which adds
    #: ``(nabla_c beta^cs) d_s v_n = (d_s beta^ss + (r_s / r)(beta^ss - beta^pp)) d_s v_n``
    bending_form: str = "paper"
    #: Helfrich bending rigidity kappa (eta_s R0^2 / t_a) and spontaneous curvature c0 (1/R0, the
    #: convention's C = k1 + k2): the normal force of :mod:`cortex_ti.axisymmetric.rigidity`
    kappa: float = 0.0
    c0: float = 0.0

    @property
    def bending(self) -> bool:
        return self.eta_bar != 0.0 or self.eta_bar_b != 0.0


class ForceBalance:
    """The collocated linear system ``A x = b`` for ``x = [v_s, v_n, P(, lam)]`` on a given shape
    (the geometry dict carries the nodal tension ``zeta`` too).

    Rows: tangential balance (as 'O'-coefficients, the last one replaced by v_s's Nyquist
    coefficient = 0), normal balance at the nodes, the volume constraint and (full meridian
    only) zero net axial velocity ``oint v_z dA = 0`` whose multiplier ``lam`` is a uniform
    axial force density (0 in the continuum: the tension pattern exerts no net force).
    """

    def __init__(self, sp: Spectral, phys: _Physics, gauge: str = "velocity"):
        self.sp, self.ph, self.gauge = sp, phys, gauge
        self.n = sp.n
        self.has_lam = not sp.symmetric
        self.nx = 2 * self.n + 1 + (1 if self.has_lam else 0)

    def balance(self, vs: ArrayF, vn: ArrayF, g: dict) -> tuple[ArrayF, ArrayF]:
        """Nodal tangential force ``nabla_a t^{a s}`` (physical component along e_s) and normal
        force ``C_ab t^ab`` (+ the bending normal force) of the surface stress for the velocity
        ``v = v_s e_s + v_n n`` (batched over leading axes).  The balance is ``tan = 0``,
        ``nor = P`` (+ the net-force multiplier terms)."""
        sp, ph = self.sp, self.ph
        es, eb = ph.eta_s, ph.eta_b
        c1, c2 = es + eb, eb - es
        r, h, rs, k1, k2 = g["r"], g["h"], g["rs"], g["k1"], g["k2"]
        a = (vs @ sp.D["O"].T) / h  # d v_s / ds        (class E)
        b = vs * rs / r  # v_s cos(psi) / r  (class E)
        vss = a + k1 * vn  # v_ss
        vpp = b + k2 * vn  # v_phiphi (physical)
        zeta = g["zeta"]
        tss = c1 * vss + c2 * vpp + zeta
        tpp = c2 * vss + c1 * vpp + zeta
        tan = (tss @ sp.D["E"].T) / h + (rs / r) * (tss - tpp)
        nor = k1 * tss + k2 * tpp
        if ph.bending:
            dvn = (vn @ sp.D["E"].T) / h  # d v_n / ds (class O)
            C = k1 + k2
            Ct = k1 * k1 + k2 * k2
            Cb = k1**3 + k2**3
            d = ph.eta_bar_b - ph.eta_bar
            bss = -2.0 * ph.eta_bar * k1 - d * C
            bpp = -2.0 * ph.eta_bar * k2 - d * C
            b0 = 2.0 * ph.eta_bar * (C * Ct - Cb) - d * C * Ct
            d2vn = (dvn @ sp.D["O"].T) / h
            nor = nor + bss * d2vn + bpp * (rs / r) * dvn + b0 * vn
            if ph.bending_form == "dissipation":
                nor = nor + ((bss @ sp.D["E"].T) / h + (rs / r) * (bss - bpp)) * dvn
        return tan, nor

    # -- residual in "apply" form, batched over leading axes of x and/or the geometry ------------
    def residual(self, x: ArrayF, g: dict) -> ArrayF:
        sp, ph, n = self.sp, self.ph, self.n
        vs, vn, P = x[..., :n], x[..., n : 2 * n], x[..., 2 * n]
        lam = x[..., 2 * n + 1] if self.has_lam else None
        r, h, rs, zs = g["r"], g["h"], g["rs"], g["zs"]
        tan, nor = self.balance(vs, vn, g)
        nor = nor - P[..., None]
        if ph.kappa:
            nor = nor - helfrich_force(sp, g, ph.kappa, ph.c0)
        if lam is not None:
            tan = tan + lam[..., None] * zs
            nor = nor - lam[..., None] * rs
        if ph.fixed_normal:
            nor = vn + 0.0 * nor
        tanc = tan @ sp.Binv["O"].T
        nyq = vs @ sp.Binv["O"][-1]
        tanc = np.concatenate([tanc[..., :-1], nyq[..., None]], axis=-1)
        w = sp.wR * r * h  # dA / (2 pi) weights (class-'R' quadrature)
        if ph.fixed_normal:
            vol = P + 0.0 * (vn @ sp.wR)
        else:
            vol = (vn * w).sum(-1)
        rows = [tanc, nor, vol[..., None]]
        if self.has_lam:
            if self.gauge == "velocity":  # oint v_z dA = 0 (the 3D code's convention)
                mom = ((zs * vs + rs * vn) * r * h) @ sp.wO
            else:  # oint z v_n dA = 0: the centroid of the enclosed volume does not move
                mom = (g["z"] * vn * r * h) @ sp.wR
            rows.append(mom[..., None])
        return np.concatenate(rows, axis=-1)

    def assemble_generic(self, g: dict) -> tuple[ArrayF, ArrayF]:
        """``A``, ``b`` by applying :meth:`residual` to the unit vectors (slow; for checks)."""
        r0 = self.residual(np.zeros(self.nx), g)
        A = (self.residual(np.eye(self.nx), g) - r0).T
        return A, -r0

    def assemble(self, g: dict) -> tuple[ArrayF, ArrayF]:
        """Dense ``A`` (nx, nx) and ``b`` (nx,) with ``A x = b`` equivalent to ``residual(x) = 0``
        (same equations as :meth:`residual`, assembled block by block; unbatched geometry)."""
        sp, ph, n, nx = self.sp, self.ph, self.n, self.nx
        es, eb = ph.eta_s, ph.eta_b
        c1, c2 = es + eb, eb - es
        r, h, rs, zs, k1, k2, zeta = g["r"], g["h"], g["rs"], g["zs"], g["k1"], g["k2"], g["zeta"]
        q = rs / r
        Ma = sp.D["O"] / h[:, None]  # v_s -> d v_s/ds
        Dt = sp.D["E"] / h[:, None]  # (class E) -> d/ds
        A = np.zeros((nx, nx))
        b = np.zeros(nx)
        # tangential (nodal), then transformed to 'O' coefficients
        f1 = c1 * k1 + c2 * k2  # d t_ss / d v_n
        f2 = c2 * k1 + c1 * k2  # d t_pp / d v_n
        Tvs = Dt @ (c1 * Ma)
        Tvs += Dt * (c2 * q)[None, :]
        Tvs += (2.0 * es * q)[:, None] * Ma
        Tvs[np.diag_indices(n)] -= 2.0 * es * q * q
        Tvn = Dt * f1[None, :]
        Tvn[np.diag_indices(n)] += 2.0 * es * q * (k1 - k2)
        T0 = Dt @ zeta
        Bo = sp.Binv["O"]
        A[:n, :n] = Bo @ Tvs
        A[:n, n : 2 * n] = Bo @ Tvn
        b[:n] = -(Bo @ T0)
        if self.has_lam:
            A[:n, 2 * n + 1] = Bo @ zs
        A[n - 1, :] = 0.0
        A[n - 1, :n] = Bo[-1]
        b[n - 1] = 0.0
        # normal
        if ph.fixed_normal:
            A[n : 2 * n, n : 2 * n] = np.eye(n)
            A[2 * n, 2 * n] = 1.0
        else:
            A[n : 2 * n, :n] = f1[:, None] * Ma
            A[n : 2 * n, :n][np.diag_indices(n)] += f2 * q
            Nvn = np.diag(k1 * f1 + k2 * f2)
            if ph.bending:
                C = k1 + k2
                Ct = k1 * k1 + k2 * k2
                Cb = k1**3 + k2**3
                d = ph.eta_bar_b - ph.eta_bar
                bss = -2.0 * ph.eta_bar * k1 - d * C
                bpp = -2.0 * ph.eta_bar * k2 - d * C
                b0 = 2.0 * ph.eta_bar * (C * Ct - Cb) - d * C * Ct
                Nvn += (bss[:, None] * Ma) @ Dt + (bpp * q)[:, None] * Dt
                if ph.bending_form == "dissipation":
                    Nvn += ((Dt @ bss) + q * (bss - bpp))[:, None] * Dt
                Nvn[np.diag_indices(n)] += b0
            A[n : 2 * n, n : 2 * n] = Nvn
            A[n : 2 * n, 2 * n] = -1.0
            if self.has_lam:
                A[n : 2 * n, 2 * n + 1] = -rs
            b[n : 2 * n] = -(k1 + k2) * zeta
            if ph.kappa:
                b[n : 2 * n] += helfrich_force(sp, g, ph.kappa, ph.c0)
            A[2 * n, n : 2 * n] = sp.wR * r * h
        if self.has_lam:
            if self.gauge == "velocity":
                A[2 * n + 1, :n] = sp.wO * zs * r * h
                A[2 * n + 1, n : 2 * n] = sp.wO * rs * r * h
            else:
                A[2 * n + 1, n : 2 * n] = sp.wR * g["z"] * r * h
        return A, b

    def unpack(self, x: ArrayF) -> dict:
        n = self.n
        out = dict(v_s=x[..., :n], v_n=x[..., n : 2 * n], P=x[..., 2 * n])
        out["lam"] = x[..., 2 * n + 1] if self.has_lam else np.zeros_like(out["P"])
        return out


# The checks and helpers the shape evolution (evolve.py, dynamics.py) shares with the static
# balance: an internal API of the axisymmetric package, not in __all__.


def check_visc(
    eta_s, eta_b, eta_bar, eta_bar_b, radius, fixed_normal=False, bending_form="paper", kappa=0.0, c0=0.0
) -> _Physics:
    """The viscosities, rigidity and radius checked (finite, >= 0, eta_s and radius > 0, v_n
    determined) as a :class:`_Physics`; ``ValueError`` naming the bad one."""
    vals = dict(eta_s=eta_s, eta_b=eta_b, eta_bar=eta_bar, eta_bar_b=eta_bar_b, radius=radius, kappa=kappa)
    for k, v in vals.items():
        try:
            fv = float(v)
        except (TypeError, ValueError):
            raise ValueError(f"{k} must be a real number, got {v!r}") from None
        if not math.isfinite(fv):
            raise ValueError(f"{k} must be finite, got {v!r}")
        if fv < 0.0:
            raise ValueError(f"{k} must be >= 0, got {v!r}")
    if float(eta_s) <= 0.0:
        raise ValueError(f"eta_s must be > 0, got {eta_s!r}")
    if float(radius) <= 0.0:
        raise ValueError(f"radius must be > 0, got {radius!r}")
    if float(eta_b) == 0.0 and float(eta_bar) == 0.0 and float(eta_bar_b) == 0.0 and not fixed_normal:
        raise ValueError(
            "eta_b = 0 without bending viscosity leaves v_n undetermined on a sphere (singular normal balance)"
        )
    if bending_form not in ("paper", "dissipation"):
        raise ValueError(f"bending_form must be 'paper' or 'dissipation', got {bending_form!r}")
    try:
        c0 = float(c0)
    except (TypeError, ValueError):
        raise ValueError(f"spontaneous curvature c0 must be a real number, got {c0!r}") from None
    if not math.isfinite(c0):
        raise ValueError(f"spontaneous curvature c0 must be finite, got {c0!r}")
    return _Physics(
        float(eta_s), float(eta_b), float(eta_bar), float(eta_bar_b), bool(fixed_normal), bending_form, float(kappa), c0
    )


def check_gauge(gauge: str) -> str:
    """``gauge`` if it is ``velocity`` or ``centroid``, else ``ValueError``."""
    if gauge not in ("velocity", "centroid"):
        raise ValueError(f"gauge must be 'velocity' or 'centroid', got {gauge!r}")
    return gauge


def eval_zeta(zeta: ZetaFn, theta: ArrayF) -> ArrayF:
    """``zeta(theta)`` as finite floats of ``theta``'s shape (a scalar function is mapped point by point)."""
    if not callable(zeta):
        raise ValueError("zeta must be a callable zeta(theta0) -> tension")
    try:
        val = np.asarray(zeta(theta), dtype=float)
        if val.shape != theta.shape:
            val = np.broadcast_to(val, theta.shape).copy()
    except (TypeError, ValueError):
        val = np.array([float(zeta(float(t))) for t in theta])
    if not np.all(np.isfinite(val)):
        raise ValueError("zeta(theta0) returned a non-finite value")
    return val


def is_symmetric(zeta: ZetaFn) -> bool:
    """Whether ``zeta`` is mirror-symmetric about the equator, ``zeta(pi - t) = zeta(t)`` (to 1e-13)."""
    t = np.linspace(0.0, np.pi / 2, 401)
    a, b = eval_zeta(zeta, t), eval_zeta(zeta, np.pi - t)
    return bool(np.max(np.abs(a - b)) <= 1e-13 * max(1.0, np.max(np.abs(a))))


def check_n(n) -> int:
    """``n`` as an int if it is an integer >= 4, else ``ValueError``."""
    try:
        ni = int(n)
    except (TypeError, ValueError):
        raise ValueError(f"n must be an integer >= 4, got {n!r}") from None
    if ni != n or ni < 4:
        raise ValueError(f"n must be an integer >= 4, got {n!r}")
    return ni


def lu_checked(A: ArrayF):
    """The LU factors of the force-balance matrix ``A`` (:func:`scipy.linalg.lu_factor`), ``ValueError``
    for non-finite entries or a singular system."""
    if not np.all(np.isfinite(A)):
        raise ValueError("non-finite entries in the force-balance matrix (degenerate shape?)")
    lu = sla.lu_factor(A, check_finite=False)
    d = np.abs(np.diag(lu[0]))
    if d.min() <= 1e-13 * d.max():
        raise ValueError("the force-balance system is singular (parameters or a degenerate shape)")
    return lu


@dataclass
class StaticResult:
    """Flow on the sphere of radius ``radius``.  Nodal fields on the solved nodes ``theta``.

    ``v_s`` is along increasing theta (north -> south), ``v_n`` along the outward normal,
    ``P = p_in - p_out``; ``lam`` the net-force multiplier (0 up to discretisation error, full
    meridian only).  Units as the inputs (paper: velocities R0/t_a, P in zeta_0/R0).
    """

    theta: ArrayF
    v_s: ArrayF
    v_n: ArrayF
    P: float
    lam: float
    zeta: ArrayF
    radius: float
    spectral: Spectral = field(repr=False)

    def at(self, theta: ArrayF) -> dict:
        """``v_s``, ``v_n`` (and Cartesian ``v_r``, ``v_z``) at any polar angles in [0, pi]."""
        th = np.atleast_1d(np.asarray(theta, dtype=float))
        vs = self.spectral.evaluate("O", self.v_s, th)
        vn = self.spectral.evaluate("E", self.v_n, th)
        return dict(v_s=vs, v_n=vn, v_r=vs * np.cos(th) + vn * np.sin(th), v_z=-vs * np.sin(th) + vn * np.cos(th))


def static_flow(
    zeta: ZetaFn,
    *,
    eta_s: float,
    eta_b: float,
    eta_bar: float,
    eta_bar_b: float,
    radius: float = 1.0,
    n: int = 128,
    symmetric: bool | None = None,
    fixed_normal: bool = False,
    gauge: str = "velocity",
    kappa: float = 0.0,
    spontaneous_curvature: float = 0.0,
) -> StaticResult:
    """Solve the force balance on a static sphere for the tension ``zeta(theta)``.

    Parameters
    ----------
    zeta : callable
        Active tension as a function of the polar angle ``theta`` in [0, pi] (vectorised or scalar).
    eta_s, eta_b : float
        Shear (> 0) and bulk (>= 0) surface viscosities.
    eta_bar, eta_bar_b : float
        Bending viscosities (>= 0; both 0 switches the bending normal force off).
    radius : float
        Sphere radius R > 0.
    n : int
        Collocation points (on [0, pi], or on [0, pi/2] when symmetric).
    symmetric : bool or None
        Use the up-down symmetry (None: detect ``zeta(pi - theta) == zeta(theta)``).
    fixed_normal : bool
        Tangential-only system: impose ``v_n = 0`` instead of the normal balance (P is then 0).
    gauge : {'velocity', 'centroid'}
        Full meridian only: fixes the rigid axial translation by ``oint v_z dA = 0`` (the 3D
        code's convention) or by ``oint z v_n dA = 0`` (the enclosed volume's centroid is fixed).
    kappa, spontaneous_curvature : float
        Helfrich rigidity and spontaneous curvature (:mod:`cortex_ti.axisymmetric.rigidity`): on the
        sphere they change only the pressure, by ``-kappa c0 (2/R - c0)/R``.

    Raises
    ------
    ValueError
        For bad input or a singular system.
    """
    phys = check_visc(eta_s, eta_b, eta_bar, eta_bar_b, radius, fixed_normal, kappa=kappa, c0=spontaneous_curvature)
    n = check_n(n)
    if symmetric is None:
        symmetric = is_symmetric(zeta)
    sp = Spectral(n, symmetric)
    R = float(radius)
    zt = eval_zeta(zeta, sp.u)
    system = ForceBalance(sp, phys, check_gauge(gauge))
    g = geometry(sp, R * np.sin(sp.u), R * np.cos(sp.u))
    g["zeta"] = zt
    A, b = system.assemble(g)
    x = sla.lu_solve(lu_checked(A), b, check_finite=False)
    f = system.unpack(x)
    return StaticResult(sp.u.copy(), f["v_s"], f["v_n"], float(f["P"]), float(f["lam"]), zt, R, sp)
