"""The up-down lobe mode of a symmetric constriction: the growth rate of the perturbations odd under
the reflection z -> -z, from the axisymmetric linearisation.

A ring on the equator keeps the shape mirror-symmetric, but a perturbation that moves volume from one
side of the furrow to the other (the lobe mode) may grow: then the furrow slips and the daughters come
out unequal (docs/validation/division_axisymmetric.md, "the lobe mode"). :func:`lobe_rate` mirrors a
half-meridian state of the adaptive points onto the full meridian, takes the exact Jacobian of its
dynamics (:meth:`~cortex_ti.axisymmetric.dynamics.Dynamics.jac`) and returns the largest real part of
its eigenvalues whose eigenvectors are odd under the reflection.
"""

from __future__ import annotations

import numpy as np

from .balance import ForceBalance, check_gauge, check_visc
from .dynamics import Dynamics
from .spectral import Spectral

__all__ = ["lobe_rate", "fastest_mode"]


def lobe_rate(
    zeta,
    y: np.ndarray,
    *,
    eta_s: float = 1.0,
    eta_b: float = 1.0,
    eta_bar: float = 0.0,
    eta_bar_b: float = 0.0,
    kappa: float = 0.0,
    radius: float = 1.0,
) -> float:
    """Largest real part (1/t_a) of the eigenvalues of the modes odd under z -> -z of the full-meridian
    adaptive dynamics at the mirrored symmetric half-meridian state ``y`` = (r, z, u) of ``n`` points
    each (``zeta``: the tension of the label, as :func:`~cortex_ti.axisymmetric.evolve.simulate`'s);
    nan if no odd mode is found."""
    y = np.asarray(y, dtype=float)
    n = y.size // 3
    r, z, u = y[:n], y[n : 2 * n], y[2 * n : 3 * n]
    yf = np.concatenate([r, r[::-1], z, -z[::-1], u, np.pi - u[::-1]])
    sp = Spectral(2 * n, False)
    ph = check_visc(eta_s=eta_s, eta_b=eta_b, eta_bar=eta_bar, eta_bar_b=eta_bar_b, radius=radius, kappa=kappa)
    dyn = Dynamics(sp, ForceBalance(sp, ph, check_gauge("velocity")), zeta, "adaptive")
    w, vec = np.linalg.eig(dyn.jac(0.0, yf))
    m = 2 * n
    reflect = np.zeros((3 * m, 3 * m))  # the reflection of a perturbation that keeps the state symmetric
    idx = np.arange(m)
    for blk, sign in ((0, 1.0), (1, -1.0), (2, -1.0)):
        reflect[blk * m + idx, blk * m + idx[::-1]] = sign
    odd = np.linalg.norm(reflect @ vec + vec, axis=0) < np.linalg.norm(reflect @ vec - vec, axis=0)
    keep = odd & (np.abs(w) > 1e-6)
    return float(w[keep].real.max()) if keep.any() else float("nan")


def fastest_mode(
    zeta,
    y: np.ndarray,
    *,
    kappa: float = 0.0,
    filtered: bool = True,
    mode: str = "adaptive",
    gauge: str = "velocity",
    **viscosities,
) -> tuple[float, float]:
    """(the largest real part (1/t_a) of the eigenvalues of the full-meridian dynamics at its state ``y``
    = (r, z, u) (``mode='lagrangian'``: (r, z)), how much that mode's r part zigzags: ``|diff v| / |v|``, 2
    for a pure node-to-node zigzag, small for a resolved mode). ``filtered``: with the node-rate filter of
    a problem without up-down symmetry (:data:`~cortex_ti.axisymmetric.dynamics.FILTER_STRENGTH`);
    ``mode``, ``gauge``: as :func:`~cortex_ti.axisymmetric.evolve.simulate`'s ``parametrization`` and
    ``gauge``. A growth rate that converges in n is the model's; one that grows with n and zigzags is the
    discretisation's."""
    y = np.asarray(y, dtype=float)
    n = y.size // (2 if mode == "lagrangian" else 3)
    sp = Spectral(n, False)
    visc = {"eta_s": 1.0, "eta_b": 1.0, "eta_bar": 0.0, "eta_bar_b": 0.0, "radius": 1.0, **viscosities}
    ph = check_visc(**visc, kappa=kappa)
    dyn = Dynamics(sp, ForceBalance(sp, ph, check_gauge(gauge)), zeta, mode, filtered=filtered)
    w, vec = np.linalg.eig(dyn.jac(0.0, y))
    k = int(np.argmax(w.real))
    v = vec[:n, k]
    return float(w[k].real), float(np.linalg.norm(np.diff(v)) / np.linalg.norm(v))
