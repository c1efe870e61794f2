r"""Pinch-off on the meridian: a neck cut into two closed profiles, each evolved on as its own cell.

When the neck of a run falls to ``neck_radius`` (:func:`simulate_division`), :func:`cut` splits the
meridian at the neck's label ``u_n`` (the interior minimum of ``r``): each side keeps the mother's
curve from its pole to a *joint* near the neck and is closed by a circular *cap* that leaves the
joint along the curve's tangent and meets the axis at a right angle (tangent-continuous; the
curvature jumps at the joint, and the rigidity smooths it at once). The joint is placed (a root in
the label) so that the daughter's volume, by its own spectral quadrature, equals the mother's
volume on its side of the plane through the neck: the two daughters' volumes add up to the mother's
to the accuracy of the quadratures (round-off for a resolved mother). The removed band's material
labels go to the caps (linearly in arc length), so each daughter carries the mother's labels
``[0, u_n]`` (north) or ``[u_n, pi]`` (south), mapped linearly onto its own ``[0, pi]``: its
tension is the mother's at the same material point. Each daughter is a full-meridian run of its
own (``parametrization='adaptive'``: its points equidistribute the curvature, so the small cap is
resolved at once), with its own volume (the incompressibility keeps the cut's) and its own axial
translation gauge. The daughters do not interact (no fluid), so they are evolved one after the
other and their frames merged: the chained trajectory of :class:`DivisionResult`.

A myosin field (a conserved, carried density) is not moved across the cut yet: refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.optimize import brentq

from ..scene.rules import AXISYMMETRIC_NECK_RESOLUTION, axisymmetric_neck_floor
from .balance import ZetaFn
from .dynamics import ArrayF, Dynamics
from .result import SimulationResult
from .spectral import Spectral, geometry

__all__ = ["Daughter", "cut", "simulate_division", "DivisionResult", "spectral_volume", "resolution_floor"]

#: The smallest neck radius (R0) a run with ``n`` meridian points is cut at (the scene's rule).
resolution_floor = axisymmetric_neck_floor


@dataclass
class Daughter:
    """One side of a cut: ``y`` the state ``(r, z, label)`` at the ``n`` nodes of a full meridian
    (``Spectral(n, False)``); its own label ``l`` in [0, pi] is the mother's scaled linearly, and
    ``table`` = (own labels, the mother's labels there), increasing, maps it to the mother's material
    label (so its tension is the mother's at the same material point);
    ``labels`` the mother's labels it carries ``(u0, u1)``, ``volume`` its enclosed volume by its own
    quadrature, ``target`` its share of the mother's volume, ``joint`` the mother's label where the
    cap starts, ``cap_length`` the cap's arc length (R0)."""

    side: str
    y: ArrayF
    labels: tuple[float, float]
    volume: float
    target: float
    joint: float
    cap_length: float
    table: tuple[ArrayF, ArrayF]

    def mother_label(self, lam) -> ArrayF:
        """The mother's material label of the daughter's label ``lam``."""
        return np.interp(np.asarray(lam, dtype=float), *self.table)

    def zeta(self, mother: ZetaFn) -> ZetaFn:
        """The daughter's tension as a function of its own label: the mother's at the same material."""

        def zeta_d(lam):
            return mother(self.mother_label(lam))

        return zeta_d


def spectral_volume(sp: Spectral, y: ArrayF) -> float:
    """``pi oint r^2 (-dz)`` by the meridian's quadrature (the volume a run's diagnostics report)."""
    n = sp.n
    g = geometry(sp, y[:n], y[n : 2 * n])
    zu = g["z"] @ sp.D["Z"].T
    return math.pi * float(np.sum(sp.wR * g["r"] ** 2 * (-zu)))


class _Curve:
    """The mother's meridian as functions of the computational coordinate sigma in [0, pi] (its
    spectral interpolants, full meridian whatever the symmetry)."""

    def __init__(self, dyn: Dynamics, y: ArrayF):
        sp, n = dyn.sp, dyn.n
        y = np.asarray(y, dtype=float)
        self.sp = sp
        self.r = y[:n] if sp.FR is None else sp.FR @ y[:n]
        self.z = y[n : 2 * n]
        self.du = y[2 * n : 3 * n] - sp.u if dyn.labelled else None

    def at(self, s, d: int = 0):
        sp = self.sp
        return sp.evaluate("R", self.r, s, d), sp.evaluate("Z", self.z, s, d)

    def label(self, s):
        s = np.atleast_1d(np.asarray(s, dtype=float))
        return s if self.du is None else s + self.sp.evaluate("O", self.du, s)


def _gauss(a: float, b: float, panels: int = 96, order: int = 16):
    """Composite Gauss-Legendre nodes and weights on [a, b]."""
    x, w = np.polynomial.legendre.leggauss(order)
    edges = np.linspace(a, b, panels + 1)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[1:] + edges[:-1])
    return (mid[:, None] + half[:, None] * x).ravel(), (half[:, None] * w).ravel()


def _neck(c: _Curve) -> float:
    """sigma of the interior minimum of r with the smallest r (Newton on dr/dsigma = 0)."""
    s = np.linspace(0.0, np.pi, 4097)
    r = c.at(s)[0]
    i = np.nonzero((r[1:-1] < r[:-2]) & (r[1:-1] <= r[2:]))[0] + 1
    if not i.size:
        raise ValueError("the meridian has no neck (no interior minimum of the distance from the axis) to cut")
    j = i[np.argmin(r[i])]
    return float(brentq(lambda x: float(c.at([x], 1)[0][0]), s[j - 1], s[j + 1], xtol=1e-15, rtol=1e-15))


class _Side:
    """One side of the neck in the frame where its pole is at sigma = 0 and the neck at ``sn``
    (the south side is mirrored: ``sigma -> pi - sigma``, ``z -> -z``, ``u -> pi - u``)."""

    def __init__(self, c: _Curve, sn: float, south: bool):
        self.c, self.south = c, south
        self.sn = np.pi - sn if south else sn

    def _s(self, t):
        return np.pi - np.asarray(t, dtype=float) if self.south else np.asarray(t, dtype=float)

    def geo(self, t, d: int = 0):
        r, z = self.c.at(self._s(t), d)
        sign = (-1.0) ** d if self.south else 1.0  # d/dt = -d/dsigma on the mirrored side
        return sign * r, -sign * z if self.south else z

    def label(self, t):
        u = self.c.label(self._s(t))
        return np.pi - u if self.south else u

    def volume(self) -> float:
        """The mother's volume on this side of the plane through the neck."""
        t, w = _gauss(0.0, self.sn)
        r, _ = self.geo(t)
        _, zt = self.geo(t, 1)
        return math.pi * float(np.sum(w * r * r * (-zt)))


def _cap(rj: float, zj: float, psij: float, kj: float, dkj: float, m: int = 2049):
    """The cap from the joint ``(rj, zj)`` (tangent angle ``psij``, meridional curvature ``kj`` and
    its arc-length derivative ``dkj``) to the axis: the tangent angle an odd quintic about the pole,
    ``psi = pi + a tau + b tau^3 + c tau^5`` in the arc length ``tau`` in [-L, 0] (so the cap is
    smooth there), matching the joint's angle, curvature and its derivative (the curve is C3 at the
    joint), with ``L`` the shortest for which it reaches the axis. Where no such cap closes without
    crossing the axis, the curvature to match is blended toward the circle's (centred on the axis;
    the cap is then only tangent-continuous). Returns ``tau + L``, ``r``, ``z``, ``k1``, ``k2`` on
    ``m`` points."""
    circle = (np.pi - psij) * math.sin(psij) / rj if 0.0 < psij < np.pi else kj
    for theta in (1.0, 0.75, 0.5, 0.25, 0.0):
        try:
            return _cap_c3(rj, zj, psij, circle + theta * (kj - circle), theta * dkj, m)
        except ValueError:
            continue
    raise ValueError(f"no cap closes the neck (radius {rj:.3g}) from its joint")


def _cap_c3(rj, zj, psij, kj, dkj, m):
    def shape(L, m=m):
        x = -L  # psi - pi, psi', psi'' at tau = -L in the unknowns (a, b, c)
        M = np.array([[x, x**3, x**5], [1.0, 3 * x * x, 5 * x**4], [0.0, 6 * x, 20 * x**3]])
        a, b, c = np.linalg.solve(M, [psij - np.pi, kj, dkj])
        tau = np.linspace(-L, 0.0, m)
        psi = np.pi + tau * (a + tau * tau * (b + c * tau * tau))
        dt = tau[1] - tau[0]
        co, si = np.cos(psi), np.sin(psi)
        r = rj + np.concatenate([[0.0], np.cumsum(0.5 * (co[1:] + co[:-1]) * dt)])
        z = zj - np.concatenate([[0.0], np.cumsum(0.5 * (si[1:] + si[:-1]) * dt)])
        return tau, r, z, a + tau * tau * (3 * b + 5 * c * tau * tau), psi

    def end(L, mm=m):
        return shape(L, mm)[1][-1]

    ls = rj * np.geomspace(0.05, 50.0, 120)
    g = [end(L, 201) for L in ls]  # the shortest closing cap, bracketed on a coarse quadrature
    k = next((i for i in range(1, len(ls)) if g[i] <= 0.0 < g[i - 1]), None)
    if k is None:
        raise ValueError(f"no cap closes the neck (radius {rj:.3g}) from its joint")
    lo, hi = ls[max(k - 2, 0)], ls[min(k + 1, len(ls) - 1)]
    if not end(lo) > 0.0 >= end(hi):
        raise ValueError(f"no cap closes the neck (radius {rj:.3g}) from its joint")
    L = brentq(end, lo, hi, xtol=1e-15 * rj, rtol=1e-15)
    tau, r, z, k1, psi = shape(L)
    r[-1] = 0.0
    if np.any(r[:-1] <= 0.0) or np.any(np.diff(z) > 0.0) or k1[-1] <= 0.0:
        raise ValueError(f"the cap of the neck (radius {rj:.3g}) crosses the axis or turns back")
    k2 = np.empty_like(r)
    k2[:-1] = np.sin(psi[:-1]) / r[:-1]
    k2[-1] = k1[-1]
    return tau + L, r, z, k1, k2


def _daughter_state(side: _Side, tj: float, n: int):
    """The daughter's state on ``Spectral(n, False)`` in the side's frame (pole at sigma = 0, cap
    at pi) with the joint at the side's parameter ``tj``; its label is the mother's, scaled to end at
    pi at the cap's pole (the mother's tension stays as smooth in it). Returns the state, the cap's
    length, and the table (own label, mother's label)."""
    m = 4097
    t = np.linspace(0.0, tj, m)
    r_, z_ = side.geo(t)
    rt_, zt_ = side.geo(t, 1)
    rtt, ztt = side.geo(t, 2)
    h = np.hypot(rt_, zt_)
    s_m = np.concatenate([[0.0], np.cumsum(0.5 * (h[1:] + h[:-1]) * np.diff(t))])
    k1 = (zt_ * rtt - rt_ * ztt) / h**3
    k2 = np.empty_like(k1)
    k2[1:] = -zt_[1:] / (h[1:] * r_[1:])
    k2[0] = k1[0]
    if zt_[-1] >= 0.0:
        raise ValueError("the meridian does not run toward the neck at the joint (z must fall along it)")
    psij = math.atan2(-zt_[-1], rt_[-1])
    dk1 = (k1[-1] - k1[-2]) / (s_m[-1] - s_m[-2])
    tc, rc, zc, k1c, k2c = _cap(float(r_[-1]), float(z_[-1]), psij, float(k1[-1]), float(dk1))
    L_m, L_c = s_m[-1], tc[-1]
    s_all = np.concatenate([s_m, L_m + tc[1:]])
    r_all, z_all = np.concatenate([r_, rc[1:]]), np.concatenate([z_, zc[1:]])
    uj, un = float(side.label([tj])[0]), float(side.label([side.sn])[0])
    u_all = np.concatenate([side.label(t), uj + (un - uj) * tc[1:] / L_c])
    # nodes at s = total (sigma + beta sin sigma) / pi: odd about both poles (any other map of
    # sigma breaks the parity the bases build in), the spacing (1 - beta) times the mean at the cap's
    # pole, beta such that about CAP_SHARE of the nodes fall on the cap
    total = L_m + L_c
    sp = Spectral(n, False)
    beta = _beta(L_c / total)
    s_nodes = total * (sp.u + beta * np.sin(sp.u)) / np.pi
    on_m = s_nodes <= L_m
    t_nodes = CubicSpline(s_m, t)(s_nodes[on_m])
    r_out, z_out = np.empty(n), np.empty(n)
    r_out[on_m], z_out[on_m] = (a for a in side.geo(t_nodes))
    r_out[~on_m] = CubicSpline(s_all[m - 1 :], r_all[m - 1 :])(s_nodes[~on_m])
    z_out[~on_m] = CubicSpline(s_all[m - 1 :], z_all[m - 1 :])(s_nodes[~on_m])
    u_nodes = np.interp(s_nodes, s_all, u_all)
    u_nodes[on_m] = side.label(t_nodes)
    lam = np.pi * u_nodes / un
    # the cut state's modes near the grid scale (the cap is resolved to 1e-6 at n = 128, 1e-9 at
    # 256) would give the rigidity's fourth derivative a saw-tooth: low-pass them (the volume is
    # matched on the filtered state)
    r_out, z_out = _lowpass(sp, "R", r_out), _lowpass(sp, "Z", z_out)
    lam = sp.u + _lowpass(sp, "O", lam - sp.u)
    return np.concatenate([r_out, z_out, lam]), L_c, (np.array([0.0, np.pi]), np.array([0.0, un]))


#: The low-pass filter of a cut state: mode k of n damped by ``exp(-FILTER_STRENGTH (k/n)^FILTER_ORDER)``.
FILTER_STRENGTH, FILTER_ORDER = 36.0, 16


def _lowpass(sp: Spectral, cls: str, values: ArrayF) -> ArrayF:
    _, m = sp.waves[cls]
    damp = np.exp(-FILTER_STRENGTH * (m / float(sp.n)) ** FILTER_ORDER)
    return sp.B[cls] @ (damp * sp.coeffs(cls, values))


#: The share of a daughter's nodes placed on its cap at the cut (the adaptive points then move them).
CAP_SHARE = 0.2


def _beta(frac: float) -> float:
    """``beta`` in [0, 0.999] of the node map ``s / total = (sigma + beta sin sigma) / pi`` that puts
    :data:`CAP_SHARE` of the nodes on the last ``frac`` of the arc length (0.999 at most)."""
    e = np.pi * CAP_SHARE  # the last nodes, sigma in [pi - e, pi], cover (e - beta sin e) / pi
    beta = (e - np.pi * frac) / math.sin(e)
    return float(min(max(beta, 0.0), 0.999))


def _mirror_state(y: ArrayF, n: int) -> ArrayF:
    """The state of a side built in the mirrored frame, back in the mother's: ``sigma -> pi -
    sigma`` (the nodes reversed), ``z -> -z``, the daughter's label ``l -> pi - l``."""
    r, z, lab = y[:n], y[n : 2 * n], y[2 * n :]
    return np.concatenate([r[::-1], -z[::-1], np.pi - lab[::-1]])


def cut(dyn: Dynamics, y: ArrayF, n: int) -> tuple[Daughter, Daughter]:
    """Cut the mother's state ``y`` (of the dynamics ``dyn``) at its neck into (north, south)
    daughters of ``n`` full-meridian points each (module docstring). ``ValueError`` (one line) if
    the meridian has no neck or a joint cannot be placed."""
    if dyn.myosin is not None:
        raise ValueError("a cut of a run with a myosin field is not supported in the axisymmetric model")
    c = _Curve(dyn, y)
    sn = _neck(c)
    sides = [_Side(c, sn, south) for south in (False, True)]
    parts = [side.volume() for side in sides]
    # the two sides' volumes by a fine quadrature add up to the mother's by its own to its accuracy;
    # what they miss is shared equally, so the daughters' volumes add up to the mother's to round-off
    mother = spectral_volume(dyn.sp, np.asarray(y, dtype=float))
    miss = mother - sum(parts)
    sp = Spectral(n, False)
    out = []
    for side, part in zip(sides, parts, strict=True):
        target = part + 0.5 * miss

        def excess(tj, side=side, target=target):
            return spectral_volume(sp, _daughter_state(side, tj, n)[0]) - target

        # the cap at the neck itself adds about a half ball; moving the joint toward the pole removes more
        rn = float(side.geo([side.sn])[0][0])
        hi = side.sn
        step = max(1e-6, 1e-3 * side.sn)
        lo = hi - step
        while excess(lo) > 0.0:
            step *= 2.0
            lo = hi - step
            if lo <= 0.05 * side.sn:
                raise ValueError(f"no joint near the neck (radius {rn:.3g}) gives the daughter its side's volume")
        if excess(hi) < 0.0:
            raise ValueError(f"a cap at the neck (radius {rn:.3g}) leaves the daughter short of its side's volume")
        tj = brentq(excess, lo, hi, xtol=1e-15, rtol=1e-15)
        ys, cap, (lam, u) = _daughter_state(side, tj, n)
        labels = (0.0, float(u[-1]))
        if side.south:
            ys = _mirror_state(ys, n)
            lam, u = np.pi - lam[::-1], np.pi - u[::-1]
            labels = (float(u[0]), np.pi)
        uj = float(c.label([np.pi - tj if side.south else tj])[0])
        vol = spectral_volume(sp, ys)
        out.append(Daughter("south" if side.south else "north", ys, labels, vol, target, uj, cap, (lam, u)))
    return out[0], out[1]


@dataclass
class DivisionResult:
    """A run through a cut: ``mother`` (to the cut), ``daughters`` (north, south: each its own run
    from the cut on; None if the mother never reached the neck radius), ``cut_info`` (time, neck
    radius, the mother's volume, the daughters' volumes and targets, the labels at the neck and the
    joints); per frame of the chained trajectory: ``t``, ``n_bodies`` and ``body_volume`` (frames x
    2, nan where a body does not exist)."""

    mother: SimulationResult
    daughters: tuple[SimulationResult, SimulationResult] | None
    cut_info: dict = field(default_factory=dict)

    @property
    def _after(self) -> int:
        """Frames after the cut that both daughters have."""
        return 0 if self.daughters is None else min(d.t.size for d in self.daughters)

    @property
    def t(self) -> ArrayF:
        if self.daughters is None:
            return self.mother.t
        return np.concatenate([self.mother.t, self.daughters[0].t[: self._after]])

    @property
    def n_bodies(self) -> ArrayF:
        return np.concatenate([np.ones(self.mother.t.size, dtype=int), np.full(self._after, 2, dtype=int)])

    @property
    def body_volume(self) -> ArrayF:
        before = np.stack([self.mother.volume, np.full(self.mother.t.size, np.nan)], 1)
        if self.daughters is None:
            return before
        k = self._after
        after = np.stack([self.daughters[0].volume[:k], self.daughters[1].volume[:k]], 1)
        return np.concatenate([before, after])


def simulate_division(
    zeta: ZetaFn,
    *,
    neck_radius: float,
    t_end: float,
    save_times,
    n: int = 48,
    daughter_n: int | None = None,
    ring_after_cut: bool = False,
    **kwargs,
) -> DivisionResult:
    """:func:`~cortex_ti.axisymmetric.evolve.simulate` (adaptive points) to the time the neck falls
    to ``neck_radius``, then :func:`cut`, then each daughter on from the cut to ``t_end`` (the save
    times after the cut) on ``daughter_n`` full-meridian points (default ``2 n``) with the mother's
    other keywords. ``ring_after_cut`` False (the default): the ring disassembles at the cut, each
    daughter's tension is uniform, the mother's at its far pole, and its points move normally; True:
    each daughter keeps the mother's tension on its material (adaptive points), whose ring remnant
    then contracts onto the new pole (measured in docs/validation/division_axisymmetric.md: the run
    stops within 0.005 t_a). Refuses (ValueError, one line) a ``neck_radius`` below
    :func:`resolution_floor` of ``n`` and a myosin field. A daughter's integrator failure keeps the
    frames before it (the chained trajectory ends with the shorter daughter)."""
    from .evolve import StepFailed, simulate

    floor = resolution_floor(n)
    if isinstance(neck_radius, bool) or not (
        isinstance(neck_radius, (int, float)) and math.isfinite(neck_radius) and neck_radius > 0
    ):
        raise ValueError(f"neck_radius must be a number > 0, got {neck_radius!r}")
    if neck_radius < floor:
        raise ValueError(
            f"division.neck_radius = {neck_radius:g} R0 is below what {n} meridian points resolve "
            f"({floor:.3g} R0 = {AXISYMMETRIC_NECK_RESOLUTION:g} / n^2)"
        )
    if kwargs.get("myosin") is not None:
        raise ValueError("division with a myosin field is not supported in the axisymmetric model")
    kwargs = {k: v for k, v in kwargs.items() if k not in ("stop_neck", "parametrization", "start", "symmetric")}
    box = {}

    def keep(frame, y):
        box["y"] = y

    mother = simulate(
        zeta,
        t_end=t_end,
        save_times=save_times,
        n=n,
        stop_neck=neck_radius,
        parametrization="adaptive",
        on_save=keep,
        **kwargs,
    )
    if not mother.stopped.startswith("neck"):
        return DivisionResult(mother, None, {})
    from .balance import ForceBalance, check_gauge, check_visc  # the mother's dynamics, for its curve

    sp = Spectral(n, bool(mother.params["symmetric"]))
    phys = check_visc(
        kwargs.get("eta_s"),
        kwargs.get("eta_b"),
        kwargs.get("eta_bar"),
        kwargs.get("eta_bar_b"),
        kwargs.get("radius", 1.0),
        kappa=kwargs.get("kappa", 0.0),
        c0=kwargs.get("spontaneous_curvature", 0.0),
    )
    dyn = Dynamics(sp, ForceBalance(sp, phys, check_gauge(kwargs.get("gauge", "velocity"))), zeta, "adaptive")
    nd = int(daughter_n or 2 * n)
    north, south = cut(dyn, box["y"], nd)
    tc = float(mother.t[-1])
    st = np.asarray(save_times, dtype=float)
    after = st[st > tc + 1e-12 * max(1.0, t_end)]
    runs = []
    for d, pole in ((north, 0.0), (south, np.pi)):
        if ring_after_cut:
            zd, y0, par = d.zeta(zeta), d.y, "adaptive"
        else:
            z_pole = float(np.asarray(zeta(np.array([pole])), dtype=float).ravel()[0])
            zd, y0, par = (lambda th, z=z_pole: z + 0.0 * np.asarray(th, dtype=float)), d.y[: 2 * nd], "lagrangian"
        try:
            res = simulate(
                zd,
                t_end=t_end,
                save_times=np.concatenate([[tc], after]),
                n=nd,
                symmetric=False,
                parametrization=par,
                start=(tc, y0),
                **kwargs,
            )
        except StepFailed as exc:
            res = exc.result
        runs.append(res)
    info = dict(
        time=tc,
        neck=float(mother.neck_radius[-1]),
        mother_volume=float(mother.volume[-1]),
        volumes=(north.volume, south.volume),
        targets=(north.target, south.target),
        neck_label=north.labels[1],
        joints=(north.joint, south.joint),
        cap_lengths=(north.cap_length, south.cap_length),
        ring_after_cut=bool(ring_after_cut),
    )
    return DivisionResult(mother, (runs[0], runs[1]), info)
