r"""The meridian's spectral discretisation: collocation points, parity-adapted Fourier bases
and the geometry of a curve of revolution given at the nodes.

The meridian is labelled by ``u in [0, pi]`` (the material label: the polar angle ``theta0`` of
the point on the initial sphere; ``u = 0`` the north pole, ``z > 0``). Every field is expanded in
a Fourier basis whose parity builds the pole regularity in: ``z, v_n, zeta`` (even at the poles)
in ``cos(k u)``, ``r, v_s`` (odd) in ``sin(k u)``; with up-down symmetry only ``[0, pi/2]`` is
solved and the bases are ``cos(2k u)`` (v_n), ``sin(2k u)`` (v_s), ``sin((2k+1) u)`` (r),
``cos((2k+1) u)`` (z). Collocation at the shifted points ``u_j = (j + 1/2) pi / n`` (full) or
``(j + 1/2) pi / (2 n)`` (symmetric), which never include a pole, so ``1/r`` is only ever
evaluated where ``r > 0``: the pole conditions are exact properties of the basis, not
equations. ``v_s``'s highest mode is not seen by the derivative at these points; it is set to
zero and the corresponding component of the tangential residual is dropped (a Petrov-Galerkin
closure of that one mode). The derivation: ``docs/derivations/axisymmetric.md``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["Spectral", "geometry"]

ArrayF = np.ndarray


class Spectral:
    """Collocation points and parity-adapted Fourier bases on the meridian label ``u``.

    Classes of functions (their values at the nodes define them uniquely):

    ============  =======================  ===========================  =========
    class         full meridian            symmetric half               used for
    ============  =======================  ===========================  =========
    ``'E'``       ``cos(k u)``, k=0..n-1   ``cos(2k u)``, k=0..n-1      v_n, zeta, h, curvatures
    ``'O'``       ``sin(k u)``, k=1..n     ``sin(2k u)``, k=1..n        v_s, tangential residual
    ``'R'``       ``sin(k u)``, k=1..n     ``sin((2k+1) u)``, k=0..n-1  r, dA/du integrands
    ``'Z'``       ``cos(k u)``, k=0..n-1   ``cos((2k+1) u)``, k=0..n-1  z, cos(psi)
    ============  =======================  ===========================  =========

    The derivative maps E<->O and R<->Z.  The last mode of 'O' (and of 'R' in the full case) has a
    derivative that vanishes at every node (the "Nyquist" mode); it is treated specially.
    """

    def __init__(self, n: int, symmetric: bool):
        if int(n) != n or n < 4:
            raise ValueError(f"n must be an integer >= 4, got {n!r}")
        n = int(n)
        self.n = n
        self.symmetric = bool(symmetric)
        half = np.pi / (2 * n) if symmetric else np.pi / n
        self.u = (np.arange(n) + 0.5) * half
        k = np.arange(n)
        if symmetric:
            self.waves = {"E": ("c", 2 * k), "O": ("s", 2 * (k + 1)), "R": ("s", 2 * k + 1), "Z": ("c", 2 * k + 1)}
        else:
            self.waves = {"E": ("c", k), "O": ("s", k + 1), "R": ("s", k + 1), "Z": ("c", k)}
        self.B: dict[str, ArrayF] = {}
        self.Binv: dict[str, ArrayF] = {}
        self.D: dict[str, ArrayF] = {}
        for cls, (kind, m) in self.waves.items():
            ph = np.outer(self.u, m)
            if kind == "c":
                B, dB = np.cos(ph), -np.sin(ph) * m
            else:
                B, dB = np.sin(ph), np.cos(ph) * m
            Binv = np.linalg.inv(B)
            self.B[cls], self.Binv[cls] = B, Binv
            self.D[cls] = dB @ Binv
        # quadrature over the whole meridian [0, pi] of an integrand of class 'R'
        kind, m = self.waves["R"]
        q = (1.0 - np.cos(m * np.pi)) / m
        self.wR = q @ self.Binv["R"]
        # quadrature over [0, pi] of an integrand of class 'O' (full case only; it is 0 by symmetry otherwise)
        kind, m = self.waves["O"]
        q = (1.0 - np.cos(m * np.pi)) / m
        self.wO = q @ self.Binv["O"]
        # filters that remove the Nyquist mode (derivative zero at every node) of class 'O', and
        # of class 'R' in the full case (where 'R' = 'O')
        mask = np.ones(n)
        mask[-1] = 0.0
        self.FO = self.B["O"] @ (mask[:, None] * self.Binv["O"])
        self.FR = None if symmetric else self.FO
        # antiderivative E -> O vanishing at u = 0 (the mean, mode 0, is dropped)
        kind, m = self.waves["E"]
        S = np.zeros((n, n))
        S[:, 1:] = np.sin(np.outer(self.u, m[1:])) / m[1:]
        self.IE = S @ self.Binv["E"]

    def coeffs(self, cls: str, values: ArrayF) -> ArrayF:
        """Expansion coefficients of nodal values (last axis) in the basis of ``cls``."""
        return np.asarray(values) @ self.Binv[cls].T

    def evaluate(self, cls: str, values: ArrayF, u: ArrayF, derivative: int = 0) -> ArrayF:
        """Spectral interpolation of nodal values of class ``cls`` at labels ``u`` (any in [0, pi])."""
        kind, m = self.waves[cls]
        c = self.coeffs(cls, values)
        ph = np.outer(np.atleast_1d(np.asarray(u, dtype=float)), m)
        if kind == "c":
            funcs = [np.cos, lambda x: -np.sin(x), lambda x: -np.cos(x), np.sin]
        else:
            funcs = [np.sin, np.cos, lambda x: -np.sin(x), lambda x: -np.cos(x)]
        out = funcs[derivative % 4](ph) * (m.astype(float) ** derivative)
        return out @ c.T if c.ndim == 1 else (out @ c.T).T


def geometry(sp: Spectral, r: ArrayF, z: ArrayF) -> dict:
    """Metric, tangent angle and principal curvatures at the nodes (batched over leading axes).

    ``h = |X_u|`` (ds = h du), ``rs = dr/ds = cos(psi)``, ``zs = dz/ds = -sin(psi)``,
    ``k1 = d psi/ds`` (meridional), ``k2 = sin(psi)/r`` (azimuthal); sphere: k1 = k2 = 1/R.
    Works for complex input (complex-step differentiation).
    """
    if sp.FR is not None:
        r = r @ sp.FR.T
    ru = r @ sp.D["R"].T
    zu = z @ sp.D["Z"].T
    ruu = ru @ sp.D["Z"].T
    zuu = zu @ sp.D["R"].T
    h = np.sqrt(ru * ru + zu * zu)
    rs = ru / h
    zs = zu / h
    k1 = (zu * ruu - ru * zuu) / h**3
    k2 = -zs / r
    return dict(r=r, z=z, h=h, rs=rs, zs=zs, k1=k1, k2=k2)
