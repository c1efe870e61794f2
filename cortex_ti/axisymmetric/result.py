"""What an axisymmetric run returns: :class:`SimulationResult` (the saved states on the full
meridian, their diagnostics, the surface of revolution of a frame) and how it is built from the
saved states of :func:`cortex_ti.axisymmetric.evolve.simulate`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from .balance import (
    ZetaFn,
    eval_zeta,
)
from .dynamics import MARGIN_GRID, ArrayF, Dynamics, bending_margin, meridian_neck
from .myosin import Myosin
from .spectral import Spectral


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
        sig = MARGIN_GRID if sigma is None else np.asarray(sigma, dtype=float)
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
        zeta = eval_zeta(self._zeta_fn, lab)
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


def _diagnostics(dyn: Dynamics, y: ArrayF, g: dict, x: ArrayF, radius: float) -> dict:
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
    margin = bending_margin(system.ph, sp, y) if system.ph.bending else float("nan")
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
        neck_radius=meridian_neck(dyn, y),
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


def build_result(dyn, saved, R: float, stats: dict, params: dict) -> SimulationResult:
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
