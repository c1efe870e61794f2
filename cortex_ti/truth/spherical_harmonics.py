"""Real orthonormal spherical harmonics and the expansion of a callable on the unit sphere, for the
exact sphere flow (:mod:`cortex_ti.truth.sphere_exact`): the frame of a pattern axis, the
normalised associated Legendre functions by a stable recurrence, ``Y_lm`` one at a time or every
one up to ``l_max`` at once (no Condon-Shortley phase), Gauss-Legendre nodes, the expansion
(:class:`Spectrum`, :func:`expand`), the mean over the sphere, and the synthesis of a
vector field from the per-degree weights of its gradient and normal parts. Written from the derivation
(``docs/derivations/sphere_exact.md``); imports nothing of the package.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

FOUR_PI = 4.0 * math.pi
Y00 = 1.0 / math.sqrt(FOUR_PI)


# ---------------------------------------------------------------------------------------------
# frames and normalised associated Legendre functions
# ---------------------------------------------------------------------------------------------


def frame_matrix(axis=None) -> np.ndarray:
    """Rotation ``Q`` (rows ``e1, e2, a``) taking global to local coordinates, ``x_loc = Q x``.

    ``a = axis / |axis|``; ``e1`` is the image of +x under the minimal rotation taking +z to a
    (``axis = -z``: rotation by pi about +x).  ``axis=None`` gives the identity.
    """
    if axis is None:
        return np.eye(3)
    a = np.asarray(axis, dtype=float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or not np.linalg.norm(a) > 0:
        raise ValueError(f"axis must be a finite nonzero 3-vector, got {axis!r}")
    a = a / np.linalg.norm(a)
    if 1.0 + a[2] < 1e-12:
        e1 = np.array([1.0, 0.0, 0.0])
    else:
        e1 = np.array([1.0 - a[0] ** 2 / (1.0 + a[2]), -a[0] * a[1] / (1.0 + a[2]), -a[0]])
    e1 = e1 - (e1 @ a) * a
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(a, e1), a])


_REC_CACHE: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def rec_tables(lmax: int) -> tuple[np.ndarray, np.ndarray]:
    """``a[l, m], b[l, m]`` of ``P_l^m = a (z P_{l-1}^m - b P_{l-2}^m)`` (orthonormal)."""
    if lmax not in _REC_CACHE:
        l = np.arange(lmax + 1, dtype=float)[:, None]
        m = np.arange(lmax + 1, dtype=float)[None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            a = np.sqrt((4 * l * l - 1) / (l * l - m * m))
            b = np.sqrt(((l - 1) ** 2 - m * m) / (4 * (l - 1) ** 2 - 1))
        a[~np.isfinite(a)] = 0.0
        b[~np.isfinite(b)] = 0.0
        _REC_CACHE[lmax] = (a, b)
    return _REC_CACHE[lmax]


def _legendre_rows(z: np.ndarray, lmax: int, s: np.ndarray | None = None, deriv: bool = False, mmax: int | None = None):
    r"""Yield ``(l, q, dq)`` for l = 0..lmax, ``q[:, m]`` for m = 0..min(l, mmax).

    ``s is None``: ``q = Qbar_l^m(z) = Pbar_l^m(z) / s^m``, a polynomial in z (regular at the
    poles), ``dq = d Qbar / dz`` if ``deriv``. ``s`` given: ``q = Pbar_l^m = s^m Qbar`` (bounded).
    ``Pbar_l^m`` are orthonormal on the unit sphere with ``e^{i m phi}``-free normalisation
    ``int Pbar^2 dOmega = 1`` for the m = 0 factor, i.e. ``Y_l0 = Pbar_l^0`` and
    ``Y_l,+-m = sqrt 2 Pbar_l^m cos / sin(m phi)`` (no Condon-Shortley phase).
    Recurrences: ``Pbar_m^m = sqrt((2m+1)/(2m)) s Pbar_{m-1}^{m-1}``,
    ``Pbar_{m+1}^m = sqrt(2m+3) z Pbar_m^m``, and the three-term recurrence in l
    (:func:`rec_tables`); the same ones hold for Qbar without the factor s.
    The weights Qbar grow like ``sqrt((l+m)!/(l-m)!) / (2^m m!)`` at z = 1 (1e58 at l = 300):
    fine in double precision for l up to ~1000.
    """
    if mmax is None:
        mmax = lmax
    z = np.asarray(z, dtype=float)
    n = z.size
    a, b = rec_tables(lmax)
    M = mmax + 1
    diag = np.empty((n, M))
    diag[:, 0] = Y00
    for m in range(1, M):
        diag[:, m] = diag[:, m - 1] * math.sqrt((2 * m + 1) / (2 * m))
        if s is not None:
            diag[:, m] *= s
    zc = z[:, None]
    q2 = np.zeros((n, M))
    q1 = np.zeros((n, M))
    d2 = np.zeros((n, M)) if deriv else None
    d1 = np.zeros((n, M)) if deriv else None
    for l in range(lmax + 1):
        w = min(l, mmax) + 1
        q = np.zeros((n, M))
        d = np.zeros((n, M)) if deriv else None
        k = min(l - 1, w)  # m < l - 1 by the three-term recurrence
        if k > 0:
            al = a[l, :k]
            bl = b[l, :k]
            q[:, :k] = al * (zc * q1[:, :k] - bl * q2[:, :k])
            if deriv:
                d[:, :k] = al * (q1[:, :k] + zc * d1[:, :k] - bl * d2[:, :k])
        if l >= 1 and l - 1 <= mmax:
            c = math.sqrt(2 * l + 1)
            q[:, l - 1] = c * z * diag[:, l - 1]
            if deriv:
                d[:, l - 1] = c * diag[:, l - 1]
        if l <= mmax:
            q[:, l] = diag[:, l]
        yield l, q[:, :w], (d[:, :w] if deriv else None)
        q2, q1 = q1, q
        if deriv:
            d2, d1 = d1, d


def real_sph_harm(l: int, m: int, points) -> np.ndarray:
    """Real orthonormal ``Y_lm`` (no Condon-Shortley phase) at the directions of ``points``.

    ``Y_10 = sqrt(3/4pi) z``, ``Y_11 = sqrt(3/4pi) x``, ``Y_1-1 = sqrt(3/4pi) y``,
    ``Y_21 = sqrt(15/4pi) x z``, ``Y_20 = sqrt(5/16pi) (3 z^2 - 1)``.
    """
    p = np.atleast_2d(np.asarray(points, dtype=float))
    u = p / np.linalg.norm(p, axis=1, keepdims=True)
    am = abs(m)
    if am > l:
        raise ValueError("|m| > l")
    q = None
    for _ll, qq, _ in _legendre_rows(u[:, 2], l, mmax=am):
        q = qq
    val = q[:, am]
    if m == 0:
        return val
    wm = (u[:, 0] + 1j * u[:, 1]) ** am
    return math.sqrt(2.0) * val * (wm.real if m > 0 else wm.imag)


def real_sph_harms(lmax: int, points) -> np.ndarray:
    """Every :func:`real_sph_harm` up to degree ``lmax`` at once, ``(N, (lmax + 1)^2)``, column
    ``l^2 + l + m`` holding ``Y_lm`` (m = -l..l), from one recurrence.

    >>> p = np.array([[0.3, -0.5, 0.8], [0.0, 0.0, -1.0]])
    >>> Y = real_sph_harms(3, p)
    >>> bool(np.allclose(Y[:, 9 + 3 - 2], real_sph_harm(3, -2, p), atol=1e-15))
    True
    """
    p = np.atleast_2d(np.asarray(points, dtype=float))
    u = p / np.linalg.norm(p, axis=1, keepdims=True)
    phi = np.arctan2(u[:, 1], u[:, 0])
    out = np.empty((p.shape[0], (lmax + 1) ** 2))
    for l, q, _ in _legendre_rows(u[:, 2], lmax, s=np.hypot(u[:, 0], u[:, 1])):
        out[:, l * l + l] = q[:, 0]
        for m in range(1, l + 1):
            out[:, l * l + l + m] = math.sqrt(2.0) * q[:, m] * np.cos(m * phi)
            out[:, l * l + l - m] = math.sqrt(2.0) * q[:, m] * np.sin(m * phi)
    return out


# ---------------------------------------------------------------------------------------------
# expansion of a callable
# ---------------------------------------------------------------------------------------------


@dataclass
class Spectrum:
    """Real spherical-harmonic expansion of a field in a local frame ``x_loc = frame @ x``.

    ``coeffs[l, m]`` (complex, m = 0..l) ``= zeta_lm - i zeta_l,-m`` for m > 0 and ``zeta_l0``
    for m = 0, so that ``zeta = sum_l Re sum_m nu_m coeffs[l, m] Qbar_l^m(z) (x + i y)^m`` with
    ``nu_0 = 1, nu_m = sqrt 2``. Axisymmetric: ``coeffs`` has shape ``(lmax+1, 1)``.
    """

    lmax: int
    frame: np.ndarray
    axisymmetric: bool
    coeffs: np.ndarray
    quadrature: dict = field(default_factory=dict)

    @property
    def degree_norms(self) -> np.ndarray:
        """``||zeta_l|| = sqrt(sum_m zeta_lm^2)`` (L2 norm of degree l on the unit sphere)."""
        return np.sqrt(np.sum(np.abs(self.coeffs) ** 2, axis=1))

    @property
    def mean(self) -> float:
        return float(self.coeffs[0, 0].real) * Y00

    def l1_vector(self) -> np.ndarray:
        """The degree-1 part as ``zeta_1(n) = g . n`` (global frame); ``g = 0`` if axisymmetric
        with zero coefficient."""
        c = self.coeffs
        k = math.sqrt(3.0 / FOUR_PI)
        if self.axisymmetric:
            g_loc = np.array([0.0, 0.0, c[1, 0].real * k])
        else:
            g_loc = np.array([c[1, 1].real * k, -c[1, 1].imag * k, c[1, 0].real * k])
        return self.frame.T @ g_loc

    def evaluate(self, points, weights=None) -> np.ndarray:
        """``sum_l weights[l] zeta_l`` at the directions of ``points`` (default weights 1)."""
        u = _unit(points)
        w = np.ones(self.lmax + 1) if weights is None else np.asarray(weights, dtype=float)
        out = synthesize_chunked(self, w, np.zeros(self.lmax + 1), u)
        return out["vn"]


def _unit(points) -> np.ndarray:
    p = np.atleast_2d(np.asarray(points, dtype=float))
    if p.ndim != 2 or p.shape[1] != 3:
        raise ValueError(f"points must have shape (N, 3), got {p.shape}")
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def _call(zeta, pts: np.ndarray) -> np.ndarray:
    val = np.asarray(zeta(pts), dtype=float).reshape(-1)
    if val.shape[0] != pts.shape[0]:
        raise ValueError(f"zeta returned {val.shape[0]} values for {pts.shape[0]} points")
    if not np.all(np.isfinite(val)):
        raise ValueError("zeta returned non-finite values")
    return val


def check_axisymmetric(zeta, Q: np.ndarray, z: np.ndarray, rtol: float = 1e-12) -> float:
    """Largest relative change of zeta over 7 azimuths at the nodes z (0 if axisymmetric)."""
    phis = np.array([0.0, 0.7853981633974483, 1.9, 2.6, 3.6, 4.2, 5.55])
    s = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    vals = []
    for ph in phis:
        loc = np.stack([s * math.cos(ph), s * math.sin(ph), z], axis=1)
        vals.append(_call(zeta, loc @ Q))
    vals = np.array(vals)
    scale = max(np.max(np.abs(vals)), 1e-300)
    return float(np.max(np.ptp(vals, axis=0)) / scale)


_GL_CACHE: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes and weights on [-1, 1], refined by Newton steps on the three-term
    recurrence (numpy's ``leggauss`` alone leaves ~1e-13 errors in the quadrature of high
    Legendre functions at n ~ 500) and symmetrised."""
    if n not in _GL_CACHE:
        x, _ = np.polynomial.legendre.leggauss(n)
        for it in range(4):
            p0, p1 = np.ones_like(x), x.copy()
            for k in range(2, n + 1):
                p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
            dp = n * (x * p1 - p0) / (x * x - 1.0)
            if it < 3:
                x = x - p1 / dp
        w = 2.0 / ((1.0 - x * x) * dp * dp)
        x = 0.5 * (x - x[::-1])
        w = 0.5 * (w + w[::-1])
        _GL_CACHE[n] = (x, w)
    return _GL_CACHE[n]


def expand(
    zeta,
    lmax: int = 120,
    *,
    axis=None,
    axisymmetric: bool | None = None,
    nquad: int | None = None,
    axisym_rtol: float = 1e-12,
) -> Spectrum:
    """Expand the callable ``zeta(points (N, 3) on the unit sphere) -> (N,)`` up to ``lmax``.

    General: Gauss-Legendre in ``z_loc = a . n`` (``nquad`` nodes, default ``3 lmax / 2 + 16``,
    exact for degree ``2 nquad - 1``) times ``2 nquad`` uniform azimuths (FFT), in the frame
    of ``axis``. Axisymmetric (``axisymmetric=True``, or ``None`` with an axis given and the
    callable found axisymmetric about it to ``axisym_rtol``): a Legendre expansion in
    ``a . n`` with ``2 lmax + 32`` Gauss nodes.
    """
    lmax = int(lmax)
    if lmax < 0:
        raise ValueError("lmax must be >= 0")
    Q = frame_matrix(axis)
    if axisymmetric is None:
        if axis is None:
            axisymmetric = False
        else:
            zt, _ = gauss_legendre(2 * lmax + 32)
            axisymmetric = check_axisymmetric(zeta, Q, zt) <= axisym_rtol
    if axisymmetric:
        nz = nquad or 2 * lmax + 32
        z, wz = gauss_legendre(nz)
        s = np.sqrt(np.maximum(0.0, 1.0 - z * z))
        loc = np.stack([s, np.zeros_like(z), z], axis=1)
        f = _call(zeta, loc @ Q)
        coeffs = np.zeros((lmax + 1, 1), dtype=complex)
        for l, q, _ in _legendre_rows(z, lmax, mmax=0):
            coeffs[l, 0] = 2.0 * math.pi * np.sum(wz * f * q[:, 0])
        return Spectrum(lmax, Q, True, coeffs, {"n_z": nz, "n_phi": 1, "n_eval": nz})
    nz = nquad or (3 * lmax) // 2 + 16
    nphi = 2 * nz
    z, wz = gauss_legendre(nz)
    s = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = np.arange(nphi) * (2.0 * math.pi / nphi)
    loc = np.stack(
        [np.outer(s, np.cos(phi)), np.outer(s, np.sin(phi)), np.repeat(z[:, None], nphi, axis=1)], axis=-1
    ).reshape(-1, 3)
    f = _call(zeta, loc @ Q).reshape(nz, nphi)
    F = np.fft.fft(f, axis=1)[:, : lmax + 1] * (2.0 * math.pi / nphi)  # int f e^{-i m phi} dphi
    nu = np.full(lmax + 1, math.sqrt(2.0))
    nu[0] = 1.0
    G = (wz[:, None] * F) * nu[None, :]
    coeffs = np.zeros((lmax + 1, lmax + 1), dtype=complex)
    for l, p, _ in _legendre_rows(z, lmax, s=s):
        coeffs[l, : l + 1] = np.einsum("jm,jm->m", p, G[:, : l + 1])
    coeffs[:, 0] = coeffs[:, 0].real
    return Spectrum(lmax, Q, False, coeffs, {"n_z": nz, "n_phi": nphi, "n_eval": nz * nphi})


def sphere_mean(zeta, *, axis=None, axisymmetric: bool | None = None, lmax: int = 200) -> float:
    """Mean of ``zeta`` over the unit sphere (Gauss quadrature of the expansion's l = 0 term)."""
    return expand(zeta, lmax, axis=axis, axisymmetric=axisymmetric).mean


# ---------------------------------------------------------------------------------------------
# synthesis
# ---------------------------------------------------------------------------------------------


def _legendre_m(z: np.ndarray, m: int, lmax: int, deriv: bool = False):
    """Column m of the table: ``Qbar_l^m(z)`` (and ``d/dz``) for l = m..lmax, shape (lmax-m+1, n)."""
    a, b = rec_tables(lmax)
    n = z.size
    nl = lmax - m + 1
    q = np.empty((nl, n))
    d = np.empty((nl, n)) if deriv else None
    c = Y00
    for k in range(1, m + 1):
        c *= math.sqrt((2 * k + 1) / (2 * k))
    q[0] = c
    if deriv:
        d[0] = 0.0
    if nl > 1:
        c1 = math.sqrt(2 * m + 3)
        q[1] = c1 * c * z
        if deriv:
            d[1] = c1 * c
    tmp = np.empty(n)
    for i in range(2, nl):
        l = m + i
        al, bl = a[l, m], b[l, m]
        np.multiply(z, q[i - 1], out=tmp)
        tmp -= bl * q[i - 2]
        np.multiply(tmp, al, out=q[i])
        if deriv:
            np.multiply(z, d[i - 1], out=tmp)
            tmp += q[i - 1]
            tmp -= bl * d[i - 2]
            np.multiply(tmp, al, out=d[i])
    return q, d


def _synthesize(spec: Spectrum, wb: np.ndarray, wa: np.ndarray, u: np.ndarray, half: int | None = None) -> dict:
    r"""``vn = sum_l wb[l] zeta_l`` and ``g = sum_l wa[l] grad_1 zeta_l`` at unit directions u.

    ``grad_1`` is the surface gradient on the *unit* sphere, computed from the polynomial
    extension ``F = Re sum_m S_m(z) (x + i y)^m`` (``S_m = sum_l nu_m c_lm wa_l Qbar_l^m``) as the
    tangential part of its 3D gradient -- regular at the poles. If ``half`` is given, the
    partial sums up to degree ``half`` are returned too (``vn_half, g_half``).
    """
    Q = spec.frame
    x = u @ Q.T
    N = x.shape[0]
    lmax = spec.lmax
    z = x[:, 2].copy()
    w = x[:, 0] + 1j * x[:, 1]
    mmax = 0 if spec.axisymmetric else lmax
    nsets = 2 if half is not None else 1
    vn = np.zeros((nsets, N))
    gxy = np.zeros((nsets, N), dtype=complex)  # sum m S_m w^(m-1)  -> (dF/dx, -dF/dy)
    gz = np.zeros((nsets, N))
    wm = np.ones(N, dtype=complex)  # w^m
    wm1 = np.zeros(N, dtype=complex)  # w^(m-1)
    lv = np.arange(lmax + 1)
    for m in range(mmax + 1):
        nu = 1.0 if m == 0 else math.sqrt(2.0)
        c = spec.coeffs[m:, m] * nu
        cols = []
        for s_ in range(nsets):
            keep = np.ones(lmax + 1 - m) if s_ == 0 else (lv[m:] <= half).astype(float)
            cols += [c * wb[m:] * keep, c * wa[m:] * keep]
        C = np.stack(cols, axis=1)  # (nl, 2 nsets) complex
        if not np.any(C):
            wm1 = wm
            wm = wm * w
            continue
        q, d = _legendre_m(z, m, lmax, deriv=True)
        Cr = np.concatenate([C.real, C.imag], axis=1)  # (nl, 4 nsets)
        S = q.T @ Cr  # (N, 4 nsets)
        D = d.T @ Cr
        k = 2 * nsets
        for s_ in range(nsets):
            Sb = S[:, 2 * s_] + 1j * S[:, k + 2 * s_]
            Sa = S[:, 2 * s_ + 1] + 1j * S[:, k + 2 * s_ + 1]
            dSa = D[:, 2 * s_ + 1] + 1j * D[:, k + 2 * s_ + 1]
            vn[s_] += (Sb * wm).real
            gz[s_] += (dSa * wm).real
            if m > 0:
                gxy[s_] += m * Sa * wm1
        wm1 = wm
        wm = wm * w
    out = {}
    for s_, suffix in enumerate(["", "_half"][:nsets]):
        grad = np.stack([gxy[s_].real, -gxy[s_].imag, gz[s_]], axis=1)
        grad -= np.sum(grad * x, axis=1)[:, None] * x
        out["vn" + suffix] = vn[s_]
        out["g" + suffix] = grad @ Q
    return out


def synthesize_chunked(spec, wb, wa, u, half=None, chunk=16384) -> dict:
    """:func:`_synthesize` over the directions ``u`` in chunks of ``chunk`` rows (bounded memory)."""
    if u.shape[0] <= chunk:
        return _synthesize(spec, wb, wa, u, half)
    parts = [_synthesize(spec, wb, wa, u[i : i + chunk], half) for i in range(0, u.shape[0], chunk)]
    return {k: np.concatenate([p_[k] for p_ in parts]) for k in parts[0]}
